"""`signcast demo`: the comparison on the bundled data with a small sweep (under 5 minutes on two cores).

The avatar fingerspells a word (default ase HELLO); its lossless render is the reference every solution carries
(the NSV family codes it as a natural video); pipeline.studies.compare.CompareSettings.demo is the sweep."""
from __future__ import annotations

import argparse

from pipeline.commands.compare import add_scenario_arguments, execute


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "demo", help="the main job on the bundled data: the avatar fingerspells a word through the six solutions, "
                     "a small sweep",
        description="Fingerspell a word with the avatar and carry its lossless render through the six solutions on a "
                    "small sweep (video Q 4, 12, 31; frame rates 25 and 12.5; fba-pred and bba-key at parameter Q 1, "
                    "4, 31; one more Q inside each matched bracket; landmarks measured on every 3rd frame, 4 "
                    "extractions each), measure what a viewer can read, match the "
                    "solutions, write the report and print its path and a summary table.")
    add_scenario_arguments(parser, natural=False)
    parser.set_defaults(func=run, size=None)


def run(args: argparse.Namespace) -> int:
    from pipeline.studies.compare import CompareSettings
    settings = CompareSettings.demo()
    if args.size is None:                   # the demo's own size unless --size is given
        args.size = "x".join(str(v) for v in settings.size)
    return execute(settings, args)
