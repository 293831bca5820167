"""The tracker's options, shared by every command that tracks (track, run, demo, batch).

Apart from :mod:`seedtrack.commands.run` so that ``seedtrack track`` loads no video or
detection code.
"""

from __future__ import annotations

import argparse

from seedtrack.tracking.lifecycle import LifecycleConfig
from seedtrack.tracking.regime import MOTIONS

from ..points import TrackingSettings
from ..settings import LinkSettings
from . import settings_of


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
        help="GOA-updown as published: one track per point of the first frame, none starts or ends later",
    )
    group.add_argument(
        "--min-length",
        type=int,
        default=0,
        metavar="N",
        help="write only tracks spanning at least N frames, gaps included (default 0: every track)",
    )


def add_verbose_option(parser: argparse.ArgumentParser) -> None:
    """``--verbose``: how the points move in detail, below the one ``motion:`` line."""
    parser.add_argument(
        "--verbose",
        action="store_true",
        help="below the motion: line, what the first look at the motion found and all that a first pass measured",
    )


def tracking_settings(args: argparse.Namespace) -> TrackingSettings:
    """The tracking the options ask for (:meth:`seedtrack.settings.LinkSettings.tracking`; an
    OptionError names an option that makes no sense)."""
    return settings_of(LinkSettings, args).tracking()
