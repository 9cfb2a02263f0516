"""`signcast motion LANGUAGE WORD -o out.bvh [--fps 25]`: fingerspell a word with real signers'
letters retargeted to the avatar and write the motion as BVH."""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from media.errors import SigncastError


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
    if not (math.isfinite(args.fps) and 0 < args.fps <= 240):
        raise SigncastError(f"bad --fps {args.fps}: choose a frame rate in (0, 240], e.g. 10, 15, 20 or 25")
    from media.avatar import load_avatar
    from media.bvh import write_bvh
    from media.fingerspelling import fingerspell
    from pipeline.outputs import output_files

    with output_files((args.output, "BVH")):
        motion = fingerspell(args.language, args.word, fps=args.fps)
        try:
            write_bvh(args.output, motion, load_avatar().skeleton)
        except OSError as error:
            raise SigncastError(f"cannot write {args.output}: {error.strerror or error}") from None
    print(f"{args.output}: {args.language} {args.word!r}, {motion.n_frames} frames at {motion.fps:g} fps "
          f"({motion.duration_s:.2f} s), {len(motion.bone_names)} bones", file=sys.stdout)
    return 0
