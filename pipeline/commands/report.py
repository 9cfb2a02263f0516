"""`signcast report records.jsonl -o report.html`: re-make the report from records, recomputing nothing."""
from __future__ import annotations

import argparse
from pathlib import Path


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser("report", help="re-make the HTML report from a records.jsonl",
                                   description="Re-make the comparison report from records only, without recomputing. The page "
                                               "shows what the records measured: image quality of decoded pictures "
                                               "(compare, demo, video) or parameter quality (params, lab); records of `signcast live` "
                                               "give the delivery report, those of `signcast receive` what arrived.")
    parser.add_argument("records", type=Path, help="records.jsonl written by signcast compare/demo/video/params/lab/live/receive")
    parser.add_argument("-o", "--output", type=Path, default=None, help="report file (default: report.html beside the records, replaced if there)")
    parser.add_argument("--force", action="store_true", help="replace the -o file if it exists")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from comparisons.reports.records import read_typed_records, report_rows
    from comparisons.reports import live
    from pipeline.outputs import build_report, output_files, write_text
    records = read_typed_records(args.records)
    rows = report_rows(records)
    output = args.output or args.records.with_name("report.html")
    poster = args.records.with_name("side_by_side_poster.png")
    with output_files((output, "report"), force=args.force or args.output is None):
        if live.loss_points(rows):
            path = write_text(output, live.report_outputs(records)["report.html"])
        elif live.received_sessions(rows):
            path = write_text(output, live.receive_report_html(records))
        else:
            path = build_report(records, output, poster_png=poster.read_bytes() if poster.is_file() else None)
    print(f"report: {path}")
    return 0
