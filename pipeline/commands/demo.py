"""`signcast demo`: the comparison on the bundled data with a small sweep (a few minutes on two cores)."""
from __future__ import annotations

import argparse

from pipeline.commands.compare import add_scenario_arguments, execute


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "demo", help="the main job on the bundled data: the avatar fingerspells a word, the carphone clip, a small sweep",
        description="Fingerspell a word with the avatar, take the bundled carphone clip, run the comparison of the six "
                    "solutions on a small sweep, write the report and print its path and a summary table.")
    add_scenario_arguments(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from pipeline.studies.compare import CompareSettings
    return execute(CompareSettings.demo(), args)
