"""`signcast compare`: the six solutions on one signing, one report, one side-by-side video
(the study is pipeline.studies.compare).

`compare --video FILE [--pose clip.pose]`: the natural clip (its landmarks from the .pose, else extracted) and the
avatar driven by those landmarks; `compare LANGUAGE WORD`: the avatar fingerspelling a word is the reference of
every solution; `compare --pose clip.pose` alone: the avatar-only scenario of that .pose."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from pipeline.commands import options
from pipeline.outputs import output_folder


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "compare", help="run NSV, NSV2O, NSV3O(+C), SSV, FBA and BBA on one scenario and write the report",
        description="Carry one signing through NSV, NSV2O, NSV3O, NSV3O+C (the video coded), SSV (the avatar's render "
                    "as video objects), FBA and BBA (parameters re-rendered by the terminal): with --video, the natural "
                    "clip and the avatar driven by its landmarks; else the avatar fingerspelling LANGUAGE WORD (or "
                    "performing --pose). Landmarks extracted from what the viewer sees give the intelligibility of "
                    "every point; each solution is matched at the cheapest rate whose intelligibility reaches the "
                    "uncoded reference's threshold; write records.jsonl, report.html, side_by_side.mp4 and "
                    "summary.csv to --out.")
    add_scenario_arguments(parser)
    options.add_video_q(parser)
    parser.add_argument("--frame-rates", default="25,20,15,10",
                        help="frame rates swept at each matched Q, comma-separated; those below the signing's own rate "
                             "are used (default 25,20,15,10)")
    options.add_param_q(parser)
    options.add_codecs(parser)
    options.add_video_codecs(parser, default="libx264,libsvtav1")
    parser.add_argument("--solutions", default=None,
                        help="only these solutions, comma-separated, from NSV, NSV2O, NSV3O, NSV3O+C, NSV-ROI, SSV, FBA, "
                             "BBA (default: every one; NSV-ROI needs libx264 among --video-codecs)")
    parser.set_defaults(func=run)


def add_scenario_arguments(parser: argparse.ArgumentParser, natural: bool = True) -> None:
    """LANGUAGE WORD, and (natural) --video, --pose and --frames; --max-size, --out, --size, --backend,
    --no-progress."""
    parser.add_argument("language", nargs="?", default="ase", help="sign language of the fingerspelled word (default ase)")
    parser.add_argument("word", nargs="?", default="HELLO", help="word the avatar fingerspells (default HELLO)")
    if natural:
        add_natural_arguments(parser)
    options.add_max_size(parser)
    options.add_out(parser, default=Path("signcast-out"))
    options.add_size(parser, "352x288", "rendered signer size of the avatar-only scenarios (with --video: the clip's)")
    parser.add_argument("--backend", default="auto", help="kernels backend: auto, warp, opencl, numpy (default auto)")
    parser.add_argument("--extractions", type=int, default=None,
                        help="landmark extractions per point, each under its own sub-pixel shift, averaged: the "
                             "extractor's noise shrinks with their number, its time grows (1-16, default 4)")
    parser.add_argument("--refine", type=int, default=None,
                        help="more Q measured per solution, one at a time: inside its matched Q bracket, so that its "
                             "rate is interpolated between nearer Q, or beyond the swept Q where none (or every one) "
                             "reaches the threshold (0-5; default 2, the demo 1)")
    parser.add_argument("--landmark-step", type=int, default=None,
                        help="intelligibility measured on every Nth frame of what the viewer sees: landmark extraction "
                             "is most of the work (1 = every frame, the default; the demo 3)")
    options.add_no_progress(parser)


def add_natural_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--video", default=None,
                        help="natural signer video: a file or 'carphone' (default: none, the avatar-only scenario)")
    parser.add_argument("--pose", default=None,
                        help="a .pose file: with --video, that video's landmarks (signcast pose, same --max-size); "
                             "alone, the avatar performs it (avatar-only scenario)")
    parser.add_argument("--frames", type=int, default=None, help="only the first N frames (default: all)")
    parser.add_argument("--framing", default=None, choices=("source", "full-figure"),
                        help="with --video, where the avatar stands in the frame: 'source' frames it like the person "
                             "(one zoom and shift, and a roll for a tilted picture, of the render camera per clip, "
                             "fitted from the avatar's shoulders and face to the person's; the default), "
                             "'full-figure' the signing space from the hips to above the head; the avatar-only "
                             "scenarios render the full figure")


def run(args: argparse.Namespace) -> int:
    from pipeline.studies.compare import CompareSettings
    from pipeline.studies.video import VideoSweep
    sweep = VideoSweep(qs=options.parse_qs(args.video_q, "--video-q"),
                       frame_rates=options.parse_floats(args.frame_rates, "--frame-rates"),
                       other_codecs=options.parse_video_codecs(args.video_codecs))
    solutions = None if args.solutions is None else tuple(options.names(args.solutions))
    return execute(CompareSettings(video=sweep, param_codecs=options.names(args.codecs),
                                   param_qs=options.parse_qs(args.param_q, "--param-q"), solutions=solutions), args)


def scenario_fields(args: argparse.Namespace) -> dict:
    """CompareSettings fields of the scenario arguments (shared with demo)."""
    from media.domain import parse_size
    fields = dict(language=args.language, word=args.word, clip=getattr(args, "video", None),
                  pose=getattr(args, "pose", None), size=parse_size(args.size), backend=args.backend,
                  max_clip_size=options.parse_max_size(args.max_size), framing=getattr(args, "framing", None))
    for name, field in (("frames", "max_clip_frames"), ("extractions", "extractions"), ("refine", "refinements"),
                        ("landmark_step", "landmark_step")):
        if getattr(args, name, None) is not None:
            fields[field] = getattr(args, name)
    return fields


def execute(settings, args: argparse.Namespace) -> int:
    """Complete settings with the scenario arguments (shared with demo), check, run, print the summary."""
    from dataclasses import replace

    from pipeline.studies import compare
    settings = replace(settings, **scenario_fields(args))
    compare.check(settings, args.command)
    with output_folder(args.out, force=args.force) as out:
        result = compare.run(settings, out, progress=not args.no_progress,
                             notify=lambda line: print(f"signcast {args.command}: {line}", file=sys.stderr))
    print(compare.format_summary(result.records))
    print(f"report: {args.out / result.report.name}")
    print(f"side by side: {args.out / result.side_by_side.name}")
    return 0
