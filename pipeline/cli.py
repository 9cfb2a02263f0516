"""The `signcast` command line: parses arguments and calls library functions.

Each sub-command lives in its own module under `pipeline/commands/` exposing
`add_parser(subparsers)` (which registers the parser and sets `func`) and the
function it calls. Expected failures (SigncastError, which KernelError derives from) print one
line on stderr and exit with code 2; bugs keep their traceback. Argument errors
(argparse) are one line too, naming the sub-command and where its usage is (`--help`), and exit with code 2.
"""
from __future__ import annotations

import argparse
import importlib
import sys
from importlib import metadata

from media.errors import SigncastError

COMMAND_MODULES = [
    "pipeline.commands.demo",
    "pipeline.commands.compare",
    "pipeline.commands.report",
    "pipeline.commands.lexicon",
    "pipeline.commands.motion",
    "pipeline.commands.video",
    "pipeline.commands.render",
    "pipeline.commands.params",
    "pipeline.commands.lab",
    "pipeline.commands.analyze",
    "pipeline.commands.pose",
    "pipeline.commands.sweep",
    "pipeline.commands.live",
    "pipeline.commands.send",
    "pipeline.commands.receive",
]


class OneLineParser(argparse.ArgumentParser):
    """An argparse parser whose errors are one line on stderr (exit code 2), like every other signcast error;
    sub-command parsers are of the same class."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(
        prog="signcast",
        description="Measure what it costs to transmit sign language as video, a synthetic signer, or animation parameters.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMAND_MODULES:
        importlib.import_module(name).add_parser(subparsers)
    for command_parser in subparsers.choices.values():
        command_parser.set_defaults(command_parser=command_parser)
    return parser


def _version() -> str:
    try:
        return metadata.version("signcast")
    except metadata.PackageNotFoundError:
        return "(not installed)"


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args, unknown = parser.parse_known_args(argv)
    if unknown:  # reported by the sub-command's parser, with its usage, not the top level's
        getattr(args, "command_parser", parser).error(f"unrecognized arguments: {' '.join(unknown)}")
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        result = args.func(args)
    except SigncastError as error:
        print(f"signcast {args.command}: error: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"signcast {args.command}: interrupted", file=sys.stderr)
        return 130
    return int(result or 0)


if __name__ == "__main__":
    sys.exit(main())
