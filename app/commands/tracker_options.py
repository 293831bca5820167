"""The tracker's options, shared by every command that tracks (track, run, demo, batch).

Apart from :mod:`seedtrack.commands.run` so that ``seedtrack track`` loads no video or
detection code.
"""

from __future__ import annotations

import argparse
import math

from seedtrack.data.numbers import MAX_COORDINATE_PX
from seedtrack.tracking.goa import GOAConfig
from seedtrack.tracking.lifecycle import LifecycleConfig
from seedtrack.tracking.regime import MOTIONS

from ..errors import UsageError, option_name
from ..points import TrackingSettings


def add_tracker_options(parser: argparse.ArgumentParser) -> None:
    """Options of the GOA-updown tracker, shared by every command that tracks."""
    group = parser.add_argument_group("tracker")
    group.add_argument(
        "--max-speed",
        type=float,
        default=None,
        metavar="PX",
        help="largest speed in pixels/frame (d_max); it only removes faster links (about the measured drift, at "
        "this plus the drift); default: twice the fastest speed measured on a first pass (--motion auto), no limit "
        "with --motion smooth, one estimated from the data with --motion random",
    )
    group.add_argument(
        "--motion",
        choices=MOTIONS,
        default="auto",
        help="how the points move: smooth (keep their direction; smooth-motion model IM2), random (Brownian "
        "or jitter; nearest neighbour IM1 within a speed limit estimated from the data unless --max-speed), "
        "or auto (default): velocity persistence, turning and noise measured on a first pass and used to score "
        "every link, printed on the first line",
    )
    group.add_argument(
        "--phi-max",
        type=float,
        default=0.1,
        metavar="X",
        help="largest smoothness cost of a link (IM2, 0..1.1); also the cost of a missed or false point (default 0.1)",
    )
    group.add_argument(
        "--max-gap",
        type=int,
        default=None,
        metavar="N",
        help=f"a track ends after N missed frames in a row (in the passes with the measured motion, from 3 for a random walk to N for smooth motion); "
        f"gaps up to N frames are filled by interpolation (interpolated=1) and a track end is joined to a track start at most N frames later "
        f"(default {LifecycleConfig().max_gap})",
    )
    group.add_argument(
        "--fixed-count",
        action="store_true",
        default=None,
        help="GOA-updown as published: one track per point of the first frame, none starts or ends later",
    )
    group.add_argument(
        "--min-length",
        type=int,
        default=0,
        metavar="N",
        help="write only tracks spanning at least N frames, gaps included (default 0: every track)",
    )


# The largest value of a limit that still limits, and why.
_LARGEST = {
    "phi_max": (1.1, "IM2's smoothness cost lies in 0..1.1; a larger limit admits every link"),
    "max_speed": (MAX_COORDINATE_PX, "no point moves farther than the largest coordinate read"),
    "min_speed": (MAX_COORDINATE_PX, "no point moves farther than the largest coordinate read"),
}


def check_limits(args: argparse.Namespace, positive: tuple[str, ...] = ("max_speed", "phi_max"), non_negative: tuple[str, ...] = ()) -> None:
    """Refuse a tracker limit given that is not a finite number above zero (``positive``) or at
    least zero (``non_negative``).

    Raises
    ------
    UsageError
        Naming the option as typed.
    """
    for options, kind, allowed in ((positive, "a positive", lambda v: v > 0), (non_negative, "a non-negative", lambda v: v >= 0)):
        for option in options:
            value = getattr(args, option)
            if value is not None and not (math.isfinite(value) and allowed(value)):
                raise UsageError(f"{option_name(option)} must be {kind} finite number, got {value:g}")
            if value is not None and option in _LARGEST and value > _LARGEST[option][0]:
                largest, why = _LARGEST[option]
                raise UsageError(f"{option_name(option)} must be at most {largest:g} ({why}), got {value:g}")


def tracker_config(args: argparse.Namespace) -> GOAConfig:
    """The tracker configuration the options ask for.

    Raises
    ------
    UsageError
        If the options make no sense.
    """
    check_limits(args)
    try:
        return GOAConfig(phi_max=args.phi_max, d_max=args.max_speed)
    except ValueError as error:
        raise UsageError(str(error)) from None


def lifecycle_config(args: argparse.Namespace) -> LifecycleConfig | None:
    """When tracks open and end, or None for the fixed-count scheme (``--fixed-count``).

    Raises
    ------
    UsageError
        If --max-gap or --min-length is negative, or --max-gap comes with --fixed-count.
    """
    for option in ("max_gap", "min_length"):
        value = getattr(args, option)
        if value is not None and value < 0:
            raise UsageError(f"{option_name(option)} must be a whole number of frames >= 0, got {value}")
    if args.fixed_count:
        if args.max_gap is not None:
            raise UsageError("--max-gap does not apply with --fixed-count (no track ends)")
        return None
    return LifecycleConfig() if args.max_gap is None else LifecycleConfig(max_gap=args.max_gap)


def tracking_settings(args: argparse.Namespace, config: GOAConfig | None = None) -> TrackingSettings:
    """The tracking the options ask for; ``config`` (default :func:`tracker_config`) is the GOA
    configuration before it is fitted to the motion.

    Raises
    ------
    UsageError
        If the options make no sense.
    """
    lifecycle = lifecycle_config(args)
    algorithm = getattr(args, "algorithm", "goa-updown")
    if algorithm == "goa-updown-fixed":
        lifecycle = None
    keep_model = getattr(args, "individual_model", None) is not None
    return TrackingSettings(
        algorithm, config if config is not None else tracker_config(args), lifecycle, args.motion or "auto", keep_model, args.min_length
    )
