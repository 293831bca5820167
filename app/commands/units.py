"""The physical-unit options (``--pixel-size``, ``--frame-interval`` and their units), shared by
the commands that write or show lengths and times (analyze, track, run, render)."""

from __future__ import annotations

import argparse

from seedtrack.data.calibration import LARGEST, SMALLEST, Calibration

from ..errors import UsageError


def add_unit_options(parser: argparse.ArgumentParser) -> None:
    """Add the unit options; all default to what the input says, else pixels and frames."""
    group = parser.add_argument_group("units (default: read from the input, else pixels and frames)")
    group.add_argument("--pixel-size", type=float, default=None, metavar="LENGTH", help="length of a pixel, in --space-unit (default unit um)")
    group.add_argument("--space-unit", default=None, metavar="UNIT", help="unit of --pixel-size, e.g. um, micron, mm")
    group.add_argument("--frame-interval", type=float, default=None, metavar="TIME", help="time between frames, in --time-unit (default unit s)")
    group.add_argument("--time-unit", default=None, metavar="UNIT", help="unit of --frame-interval, e.g. s, ms, min")


def calibration_from(args: argparse.Namespace, read: Calibration | None = None) -> Calibration:
    """The calibration the input carries (``read``), with the options given in place of its values.

    Raises
    ------
    UsageError
        If a size or interval is not a positive number.
    """
    try:
        return (read or Calibration()).overridden(args.pixel_size, args.space_unit, args.frame_interval, args.time_unit)
    except ValueError as error:
        option = "--pixel-size" if "pixel_size" in str(error) else "--frame-interval"
        raise UsageError(f"{option} must be a positive number from {SMALLEST:g} to {LARGEST:g}") from None
