"""`signcast motion LANGUAGE WORD -o out.bvh [--fps 25]`: fingerspell a word with real signers'
letters retargeted to the avatar and write the motion as BVH (the study is pipeline.studies.motion)."""
from __future__ import annotations

import argparse
from pathlib import Path


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "motion", help="fingerspell a word on the avatar and write the motion as BVH",
        description="Fingerspell WORD in sign language LANGUAGE (see `signcast lexicon`) from the real "
                    "lexicon clips retargeted to the avatar, and write the motion as a BVH file.")
    parser.add_argument("language", help="sign language code, e.g. ase")
    parser.add_argument("word", help="word to fingerspell, e.g. HELLO")
    parser.add_argument("-o", "--output", required=True, type=Path, help="BVH file to write")
    parser.add_argument("--fps", type=float, default=25.0, help="frame rate of the motion (default 25)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from pipeline.outputs import output_files
    from pipeline.studies import motion
    settings = motion.MotionSettings(args.language, args.word, args.output, args.fps)
    motion.check(settings)
    with output_files((args.output, "BVH")):
        line = motion.run(settings)
    print(line)
    return 0
