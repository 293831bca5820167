"""The ``seedtrack`` command: parse options, call the library, report.

Every subcommand lives in ``app.commands`` as a module with ``add_parser(subparsers)`` and
``run(args) -> int``. Errors a user can fix are reported here in one line with exit status 2.
"""

from __future__ import annotations

import argparse
import sys
from typing import Sequence

from data.errors import DataError

from .commands import compare, correct, demo, evaluate, experiment, render, review, run
from .errors import UsageError

COMMANDS = (run, demo, render, compare, evaluate, correct, review, experiment)

EXIT_USAGE = 2
EXIT_INTERRUPTED = 130


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every subcommand registered."""
    parser = argparse.ArgumentParser(
        prog="seedtrack",
        description="Track many small look-alike objects through video by their motion (GOA-updown).",
    )
    subparsers = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for command in COMMANDS:
        command.add_parser(subparsers)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``seedtrack`` with the given arguments; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.run(args)
    except (DataError, UsageError) as error:
        print(f"seedtrack {args.command}: error: {error}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print(f"seedtrack {args.command}: interrupted; files already written are complete", file=sys.stderr)
        return EXIT_INTERRUPTED
