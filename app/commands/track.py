"""``seedtrack track POINTS.csv --out tracks.csv``: link measured points into tracks."""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from seedtrack.data.atomic import check_target
from seedtrack.data.csvio import TRACK_COLUMNS
from seedtrack.data.csvio import read_points as read_points_table
from seedtrack.data.trackfile import output_format, write_rows
from seedtrack.data.errors import DataError
from seedtrack.tracking.goa import GOAConfig, goa, initial_links
from seedtrack.tracking.lifecycle import drop_short
from seedtrack.tracking.motion import CombinedModel, IndividualModel
from seedtrack.tracking.trackers import TRACKERS, run_tracker
from seedtrack.tracking.tracks import Tracks

from ..errors import UsageError, option_name, output_file
from ..pipeline import link_frames, track_with_motion
from ..progress import progress_bar
from ..wording import counted
from .run import add_tracker_options, check_limits, lifecycle_config

POINT_COLUMNS = ("frame", "x", "y")
# How a pass starts: our default, the paper's first links alone, and the paper's whole scheme.
FIRST_LINKS = {
    "lookahead": {},
    "nearest": {"initialisation": "im1"},
    "paper": {"initialisation": "im1", "restart_lost": False},
}
# Options that only the GOA family reads; the other trackers refuse them rather than ignore them.
_GOA_FAMILY = ("goa", "goa-updown", "goa-updown-fixed")
_GOA_ONLY = ("individual_model", "combined_model", "min_speed", "phi_max", "first_links", "motion")
# Options of the open GOA-updown (the default) alone.
_OPEN_ONLY = ("max_gap", "fixed_count")

DESCRIPTION = """\
Link the points of POINTS.csv (columns frame,x,y in pixels, 0-based frames; any other columns are
kept) into tracks and write tracks.csv with columns track_id,frame,x,y,interpolated followed by the
kept columns. A measured row carries its point's kept values unchanged; a row with interpolated=1 is
a position filled in for a missed point (a bound slave) and leaves them blank. Input columns named
track_id or interpolated are not kept.

Frame numbers are the input's. A frame number missing between the first and the last is a frame in
which nothing was measured: speeds are per frame number, and tracks bridge it with interpolated
rows; but frame numbers all N apart (0, 2, 4, ... as run --step 2 writes them, or any two frames)
are consecutive measurements, as in run --step N: speeds are then per N frames, and --max-gap and
--min-length count measured frames. Points are sorted by (frame, x, y) before tracking, so the order
of the rows does not matter.

Algorithms: goa-updown (default) tracks forwards, then backwards in time, and lets tracks come and
go: at each frame the running tracks take their points first (GOA's optimal assignment, with slaves
for missed points), then the points left over open new tracks when they chain smoothly over three
frames in a row, so that a false point does not open one. A track ends after --max-gap missed
frames in a row; afterwards a track end is joined to a later track start when the motion model says
they are one object. Gaps inside a track are filled by interpolation (interpolated=1).
goa-updown-fixed (or goa-updown --fixed-count) is GOA-updown as published: it initialises itself,
tracks forwards, then backwards from the forward pass's last links (and from last-frame points the
forward pass lost, see --first-links), one track per point of the first frame. goa is the paper's
single forward pass from given first links; here they are the links between the first two frames
that --first-links chooses. Points no track takes are left out. nn, ss, rs and ipan are the paper's
comparison trackers; they start and end tracks anywhere and take only --max-speed. --min-length
applies to every algorithm.

The GOA family first measures how the points move (--motion auto, the default; the first line of
output says what it found): from the links no motion could make wrong (mutual nearest neighbours
much closer than any other point), chained over three frames, it tells smooth motion (steps keep
their direction and speed: seeds on a turning dish) from noisy or random motion (Brownian beads,
jitter, flow with diffusion). Smooth motion is tracked with the smooth-motion model IM2 and, without
--max-speed, no speed limit: the smoothness limit --phi-max bounds a moving point and the first
links are chosen among each point's nearest neighbours. Noisy or random motion is tracked by nearest
neighbour (IM1 on squared distances, the likelihood of Gaussian steps) in a frame moving with the
median step (the drift), within a speed limit of 5 sigma of the step noise about it, both estimated
from those links, unless --max-speed or --individual-model says otherwise. When too few links are
unambiguous to tell (fast or crowded scenes), smooth motion is assumed. --motion smooth or random
skips the measurement.

POINTS.csv must hold at least two frames; a file with only a header, a single frame, a missing
column, or a value that is not a finite number is an error (exit 2, nothing written)."""


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "track",
        description=DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("points", type=Path, metavar="POINTS.csv", help="measured points: frame,x,y[,other columns]")
    parser.add_argument("--out", type=output_file, required=True, metavar="TRACKS.csv", help="output tracks: .csv (ours, with the kept columns), .txt (MOTChallenge) or .xml (TrackMate)")
    parser.add_argument(
        "--algorithm",
        choices=("goa", *TRACKERS),
        default="goa-updown",
        help="tracker (default goa-updown)",
    )
    add_tracker_options(parser)
    group = parser.add_argument_group("GOA and GOA-updown only")
    group.add_argument(
        "--individual-model",
        choices=("im1", "im2", "im3"),
        default=None,
        help="cost of one link: im1 nearest neighbour, im2 smooth motion (default), im3 proximal uniformity",
    )
    group.add_argument(
        "--combined-model",
        choices=("cm1", "cm2"),
        default=None,
        help="how link costs add up in a frame: cm1 sum (default), cm2 conditioned on competitors",
    )
    group.add_argument("--min-speed", type=float, default=None, metavar="PX", help="smallest speed, pixels/frame (default 0)")
    group.add_argument(
        "--first-links",
        choices=tuple(FIRST_LINKS),
        default=None,
        help="how tracks start: lookahead (default) scores each first link by the smoothest path it starts "
        "over the next five frames, and GOA-updown's backward pass also starts tracks from last-frame points "
        "its forward pass lost; nearest takes the first links by optimal nearest-neighbour assignment, as the "
        "paper does; paper is nearest with the paper's backward pass, which starts only from the forward "
        "pass's last links",
    )
    # phi_max left unset tells a GOA option given to another tracker from one left at its default.
    parser.set_defaults(run=run, phi_max=None, motion=None)


@dataclass(frozen=True)
class Points:
    """Measured points grouped by frame.

    Attributes
    ----------
    frames : list of ndarray, each (M_k, 2)
        Positions (x, y), pixels, of frame ``first_frame + k * frame_step``, sorted by x then y.
    first_frame : int
        0-based frame index of ``frames[0]``.
    frame_step : int
        Spacing of the frame numbers: 1, or N when every frame number present is a multiple
        of N apart (every Nth frame measured, as ``run --step N`` writes them).
    order : ndarray of int
        0-based data row of POINTS.csv of each point, frame after frame.
    offset : ndarray of int
        Position in ``order`` of each frame's first point.
    kept : dict of str to ndarray
        The input's other columns, as text, one entry per data row.
    """

    frames: list[np.ndarray]
    first_frame: int
    frame_step: int
    order: np.ndarray
    offset: np.ndarray
    kept: dict[str, np.ndarray]


def read_points(path: Path) -> Points:
    """Read POINTS.csv and group its points by frame.

    Raises
    ------
    DataError
        If a column is missing or a value not a number in range (see :mod:`seedtrack.data.numbers`), or
        fewer than two frames hold points.
    """
    table = read_points_table(path, others_as_text=True)
    frame, x, y = (table[name] for name in POINT_COLUMNS)
    if frame.size == 0:
        raise DataError(path, "no points (only a header); tracking needs points in at least two frames")
    present = np.unique(frame)
    if present.size < 2:
        raise DataError(path, f"all points are in frame {frame[0]}; tracking needs points in at least two frames")
    # Frames numbered 0, 2, 4, ... are consecutive measurements, not measurements with every
    # other frame missed (which no track would survive).
    step = int(np.gcd.reduce(np.diff(present)))
    # Sorting by position makes the result independent of the order of the rows.
    order = np.lexsort((y, x, frame))
    first = int(present[0])
    offset = np.concatenate(([0], np.cumsum(np.bincount((frame - first) // step))))
    xy = np.column_stack((x, y))[order]
    frames = [xy[start:end] for start, end in zip(offset[:-1], offset[1:])]
    kept = {name: values for name, values in table.items() if name not in POINT_COLUMNS + TRACK_COLUMNS}
    return Points(frames, first, step, order, offset[:-1], kept)


def goa_config(args: argparse.Namespace) -> GOAConfig:
    """The GOA configuration the options ask for (defaults for options not given)."""
    options = {
        "individual": IndividualModel(args.individual_model or "im2"),
        "combined": CombinedModel(args.combined_model or "cm1"),
        "d_max": args.max_speed,
        **FIRST_LINKS[args.first_links or "lookahead"],
    }
    if args.phi_max is not None:
        options["phi_max"] = args.phi_max
    if args.min_speed is not None:
        options["d_min"] = args.min_speed
    try:
        return GOAConfig(**options)
    except ValueError as error:
        raise UsageError(str(error)) from None


def _check_options(args: argparse.Namespace) -> None:
    check_limits(args, non_negative=("min_speed",))
    if args.min_speed is not None and args.max_speed is not None and args.min_speed >= args.max_speed:
        raise UsageError(f"--min-speed ({args.min_speed:g}) must be below --max-speed ({args.max_speed:g})")
    if args.algorithm not in _GOA_FAMILY:
        given = [option_name(name) for name in _GOA_ONLY if getattr(args, name) is not None]
        if given:
            raise UsageError(f"{', '.join(given)} only apply to --algorithm goa or goa-updown, not {args.algorithm}")
    if args.algorithm != "goa-updown":
        given = [option_name(name) for name in _OPEN_ONLY if getattr(args, name) is not None]
        if given:
            raise UsageError(f"{', '.join(given)} only apply to --algorithm goa-updown, not {args.algorithm}")
    lifecycle_config(args)


def track_points(points: Points, args: argparse.Namespace) -> Tracks:
    """Run the tracker the options name on the points (progress bar for GOA), then drop the
    tracks shorter than --min-length."""
    frames, first = points.frames, points.first_frame
    if args.algorithm not in _GOA_FAMILY:
        return drop_short(run_tracker(args.algorithm, frames, args.max_speed, first), args.min_length)
    if args.algorithm == "goa":

        def track(moved: list[np.ndarray], config: GOAConfig) -> Tracks:
            with progress_bar(len(moved) - 2, "tracking", unit="step") as bar:
                return goa(moved, initial_links(moved, config), config, first, progress=bar.update)

    else:
        lifecycle = None if args.algorithm == "goa-updown-fixed" else lifecycle_config(args)

        def track(moved: list[np.ndarray], config: GOAConfig) -> Tracks:
            return link_frames(moved, config, lifecycle, first)

    keep_model = args.individual_model is not None
    tracks = track_with_motion(frames, goa_config(args), args.motion or "auto", track, keep_model)
    return drop_short(tracks, args.min_length)


def track_rows(points: Points, tracks: Tracks) -> dict[str, np.ndarray]:
    """The columns of tracks.csv: the track columns, then the kept columns (blank when interpolated)."""
    rows = tracks.to_rows()
    measurement = tracks.measurement[tracks.present]  # same row order as to_rows
    column = rows["frame"] - tracks.first_frame
    rows["frame"] = tracks.first_frame + column * points.frame_step
    measured = measurement >= 0
    source = points.order[points.offset[column[measured]] + measurement[measured]]
    for name, values in points.kept.items():
        out = np.full(measurement.size, "", dtype=object)
        out[measured] = values[source]
        rows[name] = out
    return rows


def run(args: argparse.Namespace) -> int:
    _check_options(args)
    # Now rather than after a long tracking run.
    check_target(args.out)
    output_format(args.out)
    points = read_points(args.points)
    tracks = track_points(points, args)
    rows = track_rows(points, tracks)
    write_rows(args.out, rows)
    spacing = f" ({points.frame_step} frame numbers apart, tracked as consecutive)" if points.frame_step > 1 else ""
    print(
        f"{len(points.frames)} frames{spacing}, {counted(sum(f.shape[0] for f in points.frames), 'point')}, "
        f"{counted(tracks.n_tracks, 'track')}, {counted(int(rows['interpolated'].sum()), 'interpolated position')}; wrote {args.out}"
    )
    return 0
