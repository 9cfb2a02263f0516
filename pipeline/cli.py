"""The `signcast` command line: parses arguments and calls library functions.

Each sub-command lives in its own module under `pipeline/commands/` exposing
`add_parser(subparsers)` (which registers the parser and sets `func`) and the
function it calls. Expected failures (SigncastError, KernelError) print one
line on stderr and exit with code 2; bugs keep their traceback.
"""
from __future__ import annotations

import argparse
import importlib
import sys

from kernels.errors import KernelError
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
]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="signcast",
        description="Measure what it costs to transmit sign language as video, a synthetic signer, or animation parameters.",
    )
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMAND_MODULES:
        importlib.import_module(name).add_parser(subparsers)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        result = args.func(args)
    except (SigncastError, KernelError) as error:
        print(f"signcast {args.command}: error: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"signcast {args.command}: interrupted", file=sys.stderr)
        return 130
    return int(result or 0)


if __name__ == "__main__":
    sys.exit(main())
