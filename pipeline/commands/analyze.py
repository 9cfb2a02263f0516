"""`signcast analyze LANGUAGES --out DIR`: statistics of real signing on the avatar (seed 002 ch. 5) per DOF and
per joint group of each language's whole fingerspelled alphabet (the study is pipeline.studies.analyze)."""
from __future__ import annotations

import argparse

from pipeline.commands import options
from pipeline.outputs import output_folder


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "analyze", help="statistics of the retargeted lexicon per DOF and joint group (seed 002 ch. 5)",
        description="Fingerspell each LANGUAGE's whole alphabet on the avatar and write DIR/records.jsonl and, per "
                    "language, <lang>_dofs.csv, <lang>_groups.csv, <lang>_finger_correlation.csv, "
                    "<lang>_histograms.csv and PNG plots (value and frame-difference distributions, long-term PSD "
                    "per group, finger correlation).")
    parser.add_argument("languages", help="sign language codes, comma-separated, e.g. ase or ase,gsg")
    parser.add_argument("--fps", type=float, default=25.0, help="frame rate of the analysed motion (default 25)")
    options.add_out(parser)
    options.add_no_progress(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from pipeline.studies import analyze
    settings = analyze.AnalyzeSettings(options.names(args.languages), args.fps)
    analyze.check(settings)
    with output_folder(args.out, force=args.force) as out:
        _, results = analyze.run(settings, out)
    for language, result in results.items():
        print(analyze.group_table(language, result))
    print(f"wrote records.jsonl, tables and plots to {args.out}")
    return 0
