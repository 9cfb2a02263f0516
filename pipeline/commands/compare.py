"""`signcast compare`: the six solutions on one scenario, one report, one side-by-side video
(the study is pipeline.studies.compare)."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from pipeline.commands import options
from pipeline.outputs import output_folder


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "compare", help="run NSV, NSV2O, NSV3O(+C), SSV, FBA and BBA on one scenario and write the report",
        description="Code a natural clip as NSV, NSV2O, NSV3O and NSV3O+C, and a fingerspelled word performed by the "
                    "avatar as SSV (video objects), FBA and BBA (parameters re-rendered by the terminal); sweep Q and "
                    "frame rate; write records.jsonl, report.html, side_by_side.mp4 and summary.csv to --out.")
    add_scenario_arguments(parser)
    options.add_video_q(parser)
    parser.add_argument("--frame-rates", default="25,20,15,10", help="frame rates swept, comma-separated (default 25,20,15,10)")
    options.add_param_q(parser)
    options.add_codecs(parser)
    options.add_video_codecs(parser)
    parser.set_defaults(func=run)


def add_scenario_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("language", nargs="?", default="ase", help="sign language of the fingerspelled word (default ase)")
    parser.add_argument("word", nargs="?", default="HELLO", help="word the avatar fingerspells (default HELLO)")
    parser.add_argument("--video", default="carphone", help="natural signer video: a file or 'carphone' (default)")
    options.add_max_size(parser)
    options.add_out(parser, default=Path("signcast-out"))
    options.add_size(parser, "352x288")
    parser.add_argument("--backend", default="auto", help="kernels backend: auto, warp, opencl, numpy (default auto)")
    options.add_no_progress(parser)


def run(args: argparse.Namespace) -> int:
    from pipeline.studies.compare import CompareSettings
    from pipeline.studies.video import VideoSweep
    sweep = VideoSweep(qs=options.parse_qs(args.video_q, "--video-q"),
                       frame_rates=options.parse_floats(args.frame_rates, "--frame-rates"),
                       other_codecs=options.parse_video_codecs(args.video_codecs))
    return execute(CompareSettings(video=sweep, param_codecs=options.names(args.codecs),
                                   param_qs=options.parse_qs(args.param_q, "--param-q")), args)


def execute(settings, args: argparse.Namespace) -> int:
    """Complete settings with the scenario arguments (shared with demo), check, run, print the summary."""
    from dataclasses import replace

    from media.domain import parse_size
    from pipeline.studies import compare
    settings = replace(settings, language=args.language, word=args.word, clip=args.video, size=parse_size(args.size),
                       backend=args.backend, max_clip_size=options.parse_max_size(args.max_size))
    compare.check(settings, args.command)
    with output_folder(args.out, force=args.force):
        result = compare.run(settings, args.out, progress=not args.no_progress,
                             notify=lambda line: print(f"signcast {args.command}: {line}", file=sys.stderr))
    print(compare.format_summary(result.records))
    print(f"report: {result.report}")
    print(f"side by side: {result.side_by_side}")
    return 0
