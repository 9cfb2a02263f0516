"""`signcast lexicon [--language ase]`: the sign languages and letters the fingerspelling lexicon holds."""
from __future__ import annotations

import argparse

from media import lexicon


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "lexicon", help="list the sign languages and letters of the fingerspelling lexicon",
        description="List the fingerspelling lexicon (spoken-to-signed): languages, clip counts and letters.")
    parser.add_argument("--language", metavar="CODE", help="only this sign language (ISO 639-3, e.g. ase)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    codes = [lexicon.check_language(args.language)] if args.language else lexicon.languages()
    for code in codes:
        entries = lexicon.entries(code)
        spoken = sorted({entry.spoken_language for entry in entries})
        print(f"{code} ({'/'.join(spoken)}, {len(entries)} letters): {' '.join(entry.unit for entry in entries)}")
    return 0
