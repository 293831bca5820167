"""One module per ``seedtrack`` subcommand, each with ``add_parser`` and ``run``.

A command parses its arguments, hands them to the stage's settings (:mod:`seedtrack.settings`)
and calls the library with them, as the Python API does; then prints and writes.
"""

from __future__ import annotations

import argparse
import dataclasses


def settings_of(kind: type, args: argparse.Namespace, **given):
    """``kind``, a settings dataclass, made of the options in ``args`` that it holds (by the same
    names) and ``given``; those it holds that the command has not keep their defaults."""
    names = (f.name for f in dataclasses.fields(kind) if f.init and f.name not in given)
    return kind(**{name: getattr(args, name) for name in names if hasattr(args, name)}, **given)
