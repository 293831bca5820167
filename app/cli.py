"""The ``seedtrack`` command: parse options, call the library, report.

Every subcommand lives in ``seedtrack.commands`` as a module with ``add_parser(subparsers)`` and
``run(args) -> int``. Errors a user can fix are reported here in one line with exit status 2.
"""

from __future__ import annotations

import argparse
import importlib.metadata
import os
import sys
from typing import Sequence

from seedtrack.data.errors import DataError

from .commands import annotate, batch, compare, correct, demo, detect, evaluate, experiment, render, review, run, synth, track
from .errors import UsageError

COMMANDS = (run, batch, demo, detect, track, render, compare, evaluate, correct, review, annotate, synth, experiment)

EXIT_USAGE = 2
EXIT_INTERRUPTED = 130
# What a shell reports for a command killed by SIGPIPE (128 + 13).
EXIT_BROKEN_PIPE = 141


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every subcommand registered."""
    parser = argparse.ArgumentParser(
        prog="seedtrack",
        description="Track many small look-alike objects through video by their motion (GOA-updown).",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {importlib.metadata.version('seedtrack')}")
    subparsers = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for command in COMMANDS:
        command.add_parser(subparsers)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``seedtrack`` with the given arguments; returns the exit status."""
    try:
        return _run(build_parser().parse_args(argv))
    except BrokenPipeError:
        # The reader (e.g. `| head`) has gone; files are written before anything is printed, and
        # pointing stdout at devnull keeps Python's exit-time flush from raising a second time.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_BROKEN_PIPE


def _run(args: argparse.Namespace) -> int:
    try:
        return args.run(args)
    except (DataError, UsageError) as error:
        print(f"seedtrack {args.command}: error: {error}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print(f"seedtrack {args.command}: interrupted; files already written are complete", file=sys.stderr)
        return EXIT_INTERRUPTED
