"""`signcast compare`: the six solutions on one scenario, one report, one side-by-side video."""
from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

from pipeline.outputs import add_force_argument, output_folder


def _ints(text: str) -> tuple[int, ...]:
    try:
        return tuple(int(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated integers, got {text!r}") from None


def _floats(text: str) -> tuple[float, ...]:
    try:
        return tuple(float(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got {text!r}") from None


def _names(text: str) -> tuple[str, ...]:
    return tuple(v.strip() for v in text.split(",") if v.strip())


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "compare", help="run NSV, NSV2O, NSV3O(+C), SSV, FBA and BBA on one scenario and write the report",
        description="Code a natural clip as NSV, NSV2O, NSV3O and NSV3O+C, and a fingerspelled word performed by the "
                    "avatar as SSV (video objects), FBA and BBA (parameters re-rendered by the terminal); sweep Q and "
                    "frame rate; write records.jsonl, report.html, side_by_side.mp4 and summary.csv to --out.")
    add_scenario_arguments(parser)
    parser.add_argument("--video-q", type=_ints, default=(2, 6, 12, 24, 31), help="MPEG-4 quantizers (default 2,6,12,24,31)")
    parser.add_argument("--fps", type=_floats, default=(25.0, 20.0, 15.0, 10.0), help="frame rates (default 25,20,15,10)")
    parser.add_argument("--param-q", type=_ints, default=(1, 2, 4, 8, 16, 31), help="FBA/BBA Q values (default 1,2,4,8,16,31)")
    parser.add_argument("--codecs", type=_names, default=("fba-pred", "fba-dct", "bba-pred", "bba-dct", "bba-key"),
                        help="parameter codecs (default fba-pred,fba-dct,bba-pred,bba-dct,bba-key)")
    parser.add_argument("--video-codecs", type=_names, default=("libx264", "libsvtav1"),
                        help="today's video codecs at matched quality (default libx264,libsvtav1; none or '' for none)")
    parser.set_defaults(func=run)


def add_scenario_arguments(parser: argparse.ArgumentParser) -> None:
    from pipeline.commands.video import add_max_size_argument
    parser.add_argument("language", nargs="?", default="ase", help="sign language of the fingerspelled word (default ase)")
    parser.add_argument("word", nargs="?", default="HELLO", help="word the avatar fingerspells (default HELLO)")
    parser.add_argument("--video", default="carphone", help="natural signer video: a file or 'carphone' (default)")
    add_max_size_argument(parser)
    parser.add_argument("--out", type=Path, default=Path("signcast-out"), help="output folder (default ./signcast-out)")
    add_force_argument(parser)
    parser.add_argument("--size", default="352x288", help="rendered signer size WxH (default 352x288)")
    parser.add_argument("--backend", default="auto", help="kernels backend: auto, warp, opencl, numpy (default auto)")
    parser.add_argument("--no-progress", action="store_true", help="hide progress bars")


def run(args: argparse.Namespace) -> int:
    from pipeline.checks import parse_size, video_codecs
    from pipeline.compare import CompareSettings
    settings = CompareSettings(language=args.language, word=args.word, clip=args.video, video_qs=args.video_q,
                               frame_rates=args.fps, other_codecs=video_codecs(args.video_codecs, "--video-codecs"),
                               param_codecs=args.codecs, param_qs=args.param_q, size=parse_size(args.size),
                               backend=args.backend)
    return execute(settings, args)


def execute(settings, args: argparse.Namespace) -> int:
    from media.fingerspelling import fingerspell
    from media.render import check_backend
    from pipeline.checks import check_memory
    from pipeline.commands.video import parse_max_size
    from pipeline.compare import DISPLAY_FPS, check_settings, format_summary, run_compare
    check_backend(settings.backend)
    settings = replace(settings, max_clip_size=parse_max_size(args.max_size))
    check_settings(settings)
    n_frames = fingerspell(settings.language, settings.word, fps=DISPLAY_FPS).n_frames
    check_memory(n_frames, *settings.size, bytes_per_pixel(settings), args.command)
    with output_folder(args.out, force=args.force):
        result = run_compare(settings, args.out, progress=not args.no_progress,
                             notify=lambda line: print(f"signcast {args.command}: {line}", file=sys.stderr))
    print(format_summary(result.records))
    print(f"report: {result.report}")
    print(f"side by side: {result.side_by_side}")
    return 0


def bytes_per_pixel(settings) -> int:
    """What the comparison holds per pixel and frame of the rendered signer: the reference and its labels (4),
    the skin mask (1), the SSV study's working copies and operating picture (about 9), and every parameter point's
    re-rendered frames (3 each), which it keeps until the end."""
    points = len(settings.param_codecs) * (len(settings.param_qs) + len(settings.frame_rates) - 1)
    return 4 + 1 + 9 + 3 * points
