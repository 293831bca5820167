"""The ``seedtrack`` command: parse options, call the library, report.

Every subcommand lives in ``seedtrack.commands`` as a module with ``add_parser(subparsers)`` and
``run(args) -> int``, and has a row in :data:`COMMANDS`. Only the module of the command given is
imported, so ``seedtrack --help`` and ``--version`` start in the time Python itself takes rather
than after numpy, scipy, OpenCV and PyAV have loaded.

:func:`main` is the one boundary where failures become what a user sees: an error a user can fix
(bad input, bad options, a file that cannot be read or written, a full disk) is one line on stderr
naming the file and the cause, exit status 2; a warning (a :class:`DataWarning` from the library:
input it can use but a user should hear about) is one line and the work goes on; Ctrl-C at any moment, start-up included, is one line
and exit status 130.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import warnings
from typing import Sequence

from seedtrack.data.errors import DataError, DataWarning

from .errors import OptionError, UsageError, in_option_names, one_line
from .processes import default_workers, start_fork_server

# Command name -> the line ``seedtrack --help`` lists it with, in the order listed.
COMMANDS = {
    "run": "detect, track and draw a clip",
    "batch": "run many clips, on this machine or a Dask cluster",
    "demo": "generate a rotating-dish clip, track it and score the tracks against the truth",
    "detect": "measure objects in every frame (detections.csv), with a preview image to tune the options",
    "track": "link measured points (frame,x,y) into tracks",
    "render": "draw tracks over the clip: an MP4, a GIF, a PNG or a folder of PNGs",
    "compare": "draw two track sets over the clip, where they disagree in a warning colour",
    "evaluate": "score tracks against ground truth",
    "analyze": "MSD, drift and velocity of tracks, as tables and plots",
    "correct": "apply hand edits to tracks, to make ground truth",
    "review": "draw track ids on frames, to write corrections from",
    "annotate": "make or fix ground truth by pointing, in a local web page",
    "synth": "generate synthetic points with ground truth",
    "experiment": "rerun one of the paper's PSMG experiments with every tracker",
}

EXIT_USAGE = 2
EXIT_INTERRUPTED = 130
# What a shell reports for a command killed by SIGPIPE (128 + 13).
EXIT_BROKEN_PIPE = 141


class _Version(argparse.Action):
    """``--version``, reading the installed version only when asked (importlib.metadata is slow to load)."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS, help="show the version and exit"):
        super().__init__(option_strings, dest, nargs=0, default=default, help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        from importlib.metadata import version

        print(f"{parser.prog} {version('seedtrack')}")
        parser.exit()


class _Registrar:
    """What a command module's ``add_parser`` is given: adds its parser with the line :data:`COMMANDS` lists it with."""

    def __init__(self, subparsers, summary: str) -> None:
        self._subparsers, self._summary = subparsers, summary

    def add_parser(self, name: str, **options) -> argparse.ArgumentParser:
        return self._subparsers.add_parser(name, help=self._summary, **options)


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The argument parser: every command listed, ``command``'s options registered (its module imported).

    Example
    -------
    >>> build_parser("track").parse_args(["track", "points.csv", "--out", "t.csv"]).algorithm
    'goa-updown'
    """
    parser = argparse.ArgumentParser(
        prog="seedtrack",
        description="Track many small look-alike objects through video by their motion (GOA-updown).",
    )
    parser.add_argument("--version", action=_Version)
    subparsers = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, summary in COMMANDS.items():
        if name == command:
            importlib.import_module(f"seedtrack.commands.{name}").add_parser(_Registrar(subparsers, summary))
        else:
            # Listed by name only: argparse dispatches to the one command given, never to these.
            subparsers.add_parser(name, help=summary, add_help=False)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``seedtrack`` with the given arguments; returns the exit status.

    Example
    -------
    >>> main(["evaluate", "missing.csv", "--truth", "missing.csv"])
    2
    """
    argv = sys.argv[1:] if argv is None else [str(a) for a in argv]
    # The top level takes no option with a value, so the first word that is not an option is the command.
    command = next((word for word in argv if not word.startswith("-")), None)
    command = command if command in COMMANDS else None
    prefix = f"seedtrack {command}" if command else "seedtrack"
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("always", DataWarning)
            warnings.showwarning = lambda message, *_, **__: print(f"{prefix}: warning: {one_line(str(message))}", file=sys.stderr)
            if command == "run" and _workers_asked(argv) > 1:
                # run's encoder process comes from the fork server: started before run's own
                # imports, the server's imports (numpy, OpenCV, PyAV) run beside them.
                start_fork_server()
            args = build_parser(command).parse_args(argv)
            return args.run(args)
    except (DataError, UsageError) as error:
        return _fail(prefix, str(error))
    except OptionError as error:
        return _fail(prefix, in_option_names(str(error), error.names))
    except KeyboardInterrupt:
        print(f"{prefix}: interrupted; files already written are complete", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:
        # The reader (e.g. `| head`) has gone; files are written before anything is printed, and
        # pointing stdout at devnull keeps Python's exit-time flush from raising a second time.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_BROKEN_PIPE
    except OSError as error:
        # A file the library opened itself (a video, a frame, a font): its name is in the error.
        cause = error.strerror or str(error) or type(error).__name__
        return _fail(prefix, f"{error.filename}: {cause}" if error.filename else cause)
    except MemoryError:
        return _fail(prefix, "not enough memory for this input; use fewer frames or points, or a smaller --scale")


def _workers_asked(argv: Sequence[str]) -> int:
    """The number of workers ``argv`` asks for, read before the command's parser reads it: 1 if
    ``--workers`` is not a number (the parser says why) or with ``--help`` (nothing runs)."""
    early = argparse.ArgumentParser(add_help=False)
    early.add_argument("-h", "--help", action="store_true")
    early.add_argument("--workers")
    known, _ = early.parse_known_args(argv)
    if known.help:
        return 1
    try:
        return int(known.workers) if known.workers is not None else default_workers()
    except ValueError:
        return 1


def _fail(prefix: str, message: str) -> int:
    # One line whatever the message: a cause quoted from a library may hold a newline, a file's
    # content quoted in it control characters.
    print(f"{prefix}: error: {one_line(message)}", file=sys.stderr)
    return EXIT_USAGE
