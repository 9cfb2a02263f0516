"""`signcast motion LANGUAGE WORD -o out.bvh [--fps 25]` or `signcast motion --pose clip.pose -o out.bvh`: the
avatar fingerspelling a word from real signers' letters, or any .pose of MediaPipe Holistic keypoints, retargeted
to the avatar and written as BVH (the study is pipeline.studies.motion)."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from pipeline.outputs import add_force_argument

JITTER_FILTERS = ("one-euro", "binomial", "off")


def add_source_arguments(parser: argparse.ArgumentParser, verb: str) -> None:
    """LANGUAGE WORD (optional positionals) or --pose FILE, and --jitter-filter (also used by `render`)."""
    parser.add_argument("language", nargs="?", help="sign language code, e.g. ase (with WORD; or use --pose)")
    parser.add_argument("word", nargs="?", help=f"word to {verb}, e.g. HELLO")
    parser.add_argument("--pose", type=Path, metavar="FILE",
                        help="instead of LANGUAGE WORD: a .pose file of MediaPipe Holistic keypoints (e.g. from "
                             "`signcast pose`), retargeted like the lexicon's letters")
    parser.add_argument("--jitter-filter", choices=JITTER_FILTERS,
                        help="with --pose: the temporal filter against keypoint jitter (default one-euro)")


def check_source(args: argparse.Namespace) -> None:
    """Exactly one source: LANGUAGE WORD or --pose (an argparse error with the usage otherwise)."""
    parser = args.command_parser
    if args.pose is not None:
        if args.language is not None:
            parser.error("give either LANGUAGE WORD or --pose FILE, not both")
    elif args.language is None or args.word is None:
        parser.error("give LANGUAGE WORD (e.g. ase HELLO) or --pose FILE")
    if args.jitter_filter is not None and args.pose is None:
        parser.error("--jitter-filter applies to --pose (lexicon words use the lexicon's retargeting)")


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "motion", help="fingerspell a word (or retarget a .pose) on the avatar and write the motion as BVH",
        description="Fingerspell WORD in sign language LANGUAGE (see `signcast lexicon`) from the real "
                    "lexicon clips retargeted to the avatar, or retarget any .pose file of MediaPipe Holistic "
                    "keypoints (--pose), and write the motion as a BVH file.")
    add_source_arguments(parser, "fingerspell")
    parser.add_argument("-o", "--output", required=True, type=Path, help="BVH file to write")
    parser.add_argument("--fps", type=float,
                        help="frame rate of the motion (default 25 for a word, the .pose file's own for --pose)")
    add_force_argument(parser, files=True)
    parser.add_argument("--no-progress", action="store_true", help="hide progress bars (motion shows none)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from pipeline.outputs import output_files
    from pipeline.studies import motion
    check_source(args)
    settings = motion.MotionSettings(args.language, args.word, args.output, args.fps, args.pose, args.jitter_filter)
    motion.check(settings)
    with output_files((args.output, "BVH"), force=args.force):
        line = motion.run(settings, notify=lambda note: print(note, file=sys.stderr))
    print(line)
    return 0
