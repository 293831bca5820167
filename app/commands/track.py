"""``seedtrack track POINTS.csv --out tracks.csv``: link measured points into tracks."""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

import numpy as np

from seedtrack.data.atomic import check_target
from seedtrack.data.csvio import read_points as read_points_table
from seedtrack.data.csvio import read_table
from seedtrack.data.trackfile import output_format, write_rows
from seedtrack.data.errors import DataError
from seedtrack.tracking.goa import GOAConfig
from seedtrack.tracking.linking import GOA_FAMILY
from seedtrack.tracking.motion import COMBINED_MODELS, INDIVIDUAL_MODELS, CombinedModel, IndividualModel
from seedtrack.tracking.trackers import TRACKERS
from seedtrack.tracking.tracks import Tracks

from ..allocation import return_freed_memory
from ..errors import UsageError, option_name, output_file
from ..points import Points, group_points, point_rows, track_frames
from ..wording import counted
from .tracker_options import add_tracker_options, check_limits, lifecycle_config, tracking_settings
from .units import add_unit_options, calibration_from

# How a pass starts: our default, the paper's first links alone, and the paper's whole scheme.
FIRST_LINKS = {
    "lookahead": {},
    "nearest": {"initialisation": "im1"},
    "paper": {"initialisation": "im1", "restart_lost": False},
}
# Options that only the GOA family reads; the other trackers refuse them rather than ignore them.
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
that --first-links chooses, or those of a tracks file given as --first-links FILE. Points no track takes are left out. nn, ss, rs and ipan are the paper's
comparison trackers; they start and end tracks anywhere and take only --max-speed. --min-length
applies to every algorithm.

The GOA family first measures how the points move (--motion auto, the default; the first line of
output says what it found). A first pass tracks them as before: from the links no motion could make
wrong (mutual nearest neighbours much closer than any other point), chained over three frames, it
tells smooth motion (IM2, no speed limit) from random motion (nearest neighbour about the median
step). On its tracks it then measures how much of each velocity carries over to the next frame (0
for a random walk, 1 for smooth motion), how far velocities turn (a turning dish), and how the
noise grows with the speed, leaving out the links that fit worst; the final pass scores every link
by its distance from the position those statistics predict, in sigmas, in a frame moving with the
drift, within twice the fastest speed measured on the links that fit (or --max-speed, which only
removes links: it does not change the cost of the others); the statistics are measured once more on
those tracks and the points tracked again with them. Two tracks whose points pass too close
to tell apart in one frame then take the pairing that the frames around it make most likely.
--motion smooth or random, or --individual-model, skip the measurement and track as the first pass
does.

POINTS.csv must hold at least two frames; a file with only a header, a single frame, a missing
column, or a value that is not a finite number is an error (exit 2, nothing written)."""


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "track",
        description=DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("points", type=Path, metavar="POINTS.csv", help="measured points: frame,x,y[,other columns]")
    parser.add_argument("--out", type=output_file, required=True, metavar="TRACKS.csv", help="output tracks: .csv (ours, with the kept columns), .txt (MOTChallenge), .xml (TrackMate), .geff (GEFF) or .npy (napari)")
    parser.add_argument(
        "--algorithm",
        choices=("goa", *TRACKERS),
        default="goa-updown",
        help="tracker (default goa-updown)",
    )
    add_tracker_options(parser)
    add_unit_options(parser)
    group = parser.add_argument_group("GOA and GOA-updown only")
    group.add_argument(
        "--individual-model",
        choices=tuple(INDIVIDUAL_MODELS),
        default=None,
        help="cost of one link: im1 nearest neighbour, im2 smooth motion (default), im3 proximal uniformity",
    )
    group.add_argument(
        "--combined-model",
        choices=tuple(COMBINED_MODELS),
        default=None,
        help="how link costs add up in a frame: cm1 sum (default), cm2 conditioned on competitors",
    )
    group.add_argument("--min-speed", type=float, default=None, metavar="PX", help="smallest speed, pixels/frame (default 0)")
    group.add_argument(
        "--first-links",
        default=None,
        metavar="{lookahead,nearest,paper} or FILE",
        help="how tracks start: lookahead (default) scores each first link by the smoothest path it starts "
        "over the next five frames, and GOA-updown's backward pass also starts tracks from last-frame points "
        "its forward pass lost; nearest takes the first links by optimal nearest-neighbour assignment, as the "
        "paper does; paper is nearest with the paper's backward pass, which starts only from the forward "
        "pass's last links. With --algorithm goa, a FILE of tracks (track_id,frame,x,y, as tracks.csv) gives "
        "the first links instead, as the paper's experiments gave them: each of its tracks in the first frame "
        "(and the second, if it is there) must lie within 0.5 px of a point",
    )
    # phi_max left unset tells a GOA option given to another tracker from one left at its default.
    parser.set_defaults(run=run, phi_max=None, motion=None)


def read_points(path: Path) -> Points:
    """Read POINTS.csv and group its points by frame (see :func:`group_points`)."""
    return group_points(read_points_table(path, others_as_text=True), path)


# A given first link's point must lie this close to a measured point, pixels.
_GIVEN_TOLERANCE = 0.5


def _first_links_file(args: argparse.Namespace) -> bool:
    return args.first_links is not None and args.first_links not in FIRST_LINKS


def given_first_links(path: Path, points: Points) -> np.ndarray:
    """First links from a tracks file: per track with a point in the first frame, the index of
    that point in ``points.frames[0]`` and of its point in the second frame (-1 if none).

    Raises
    ------
    DataError
        If the file cannot be read, or one of its first- or second-frame points is not within
        0.5 px of a measured point, or two of its tracks claim one point.
    """
    from scipy.spatial import cKDTree

    table = read_table(path, required=("track_id", "frame", "x", "y"), integer=("track_id", "frame"))
    frames = (points.first_frame, points.first_frame + points.frame_step)
    index = {}
    for column, frame in enumerate(frames):
        rows = np.flatnonzero(table["frame"] == frame)
        xy = np.column_stack((table["x"][rows], table["y"][rows]))
        distance, found = cKDTree(points.frames[column]).query(xy) if len(rows) else (np.empty(0), np.empty(0, int))
        far = np.flatnonzero(distance > _GIVEN_TOLERANCE)
        if far.size:
            line = rows[far[0]] + 2
            raise DataError(path, f"line {line}: no point of frame {frame} lies within {_GIVEN_TOLERANCE} px of ({xy[far[0], 0]:g}, {xy[far[0], 1]:g})")
        if np.unique(found).size != found.size:
            raise DataError(path, f"two tracks start on the same point of frame {frame}")
        index[column] = dict(zip(table["track_id"][rows].tolist(), found.tolist()))
    if not index[0]:
        raise DataError(path, f"no track has a point in frame {frames[0]}, the first frame of the points")
    ids = sorted(index[0])
    return np.array([[index[0][i], index[1].get(i, -1)] for i in ids], dtype=np.int64)


def goa_config(args: argparse.Namespace) -> GOAConfig:
    """The GOA configuration the options ask for (defaults for options not given)."""
    options = {
        "individual": IndividualModel(args.individual_model or "im2"),
        "combined": CombinedModel(args.combined_model or "cm1"),
        "d_max": args.max_speed,
        **FIRST_LINKS[args.first_links if args.first_links in FIRST_LINKS else "lookahead"],
    }
    if args.phi_max is not None:
        options["phi_max"] = args.phi_max
    if args.min_speed is not None:
        options["d_min"] = args.min_speed
    try:
        return GOAConfig(**options)
    except ValueError as error:
        raise UsageError(str(error)) from None


def check_options(args: argparse.Namespace) -> None:
    """Refuse options out of range or given to a tracker that does not read them.

    Raises
    ------
    UsageError
    """
    check_limits(args, non_negative=("min_speed",))
    if args.min_speed is not None and args.max_speed is not None and args.min_speed >= args.max_speed:
        raise UsageError(f"--min-speed ({args.min_speed:g}) must be below --max-speed ({args.max_speed:g})")
    if args.algorithm not in GOA_FAMILY:
        given = [option_name(name) for name in _GOA_ONLY if getattr(args, name) is not None]
        if given:
            raise UsageError(f"{', '.join(given)} only apply to --algorithm goa or goa-updown, not {args.algorithm}")
    if _first_links_file(args) and args.algorithm != "goa":
        if args.first_links.startswith("-") or not Path(args.first_links).suffix:
            raise UsageError(f"--first-links takes lookahead, nearest, paper or a tracks file, not {args.first_links!r}")
        raise UsageError("--first-links FILE only applies to --algorithm goa (the single pass from given first links)")
    if _first_links_file(args) and not Path(args.first_links).is_file():
        raise UsageError(f"--first-links: {args.first_links}: no such file")
    if args.algorithm != "goa-updown":
        given = [option_name(name) for name in _OPEN_ONLY if getattr(args, name) is not None]
        if given:
            raise UsageError(f"{', '.join(given)} only apply to --algorithm goa-updown, not {args.algorithm}")
    lifecycle_config(args)


def track_points(points: Points, args: argparse.Namespace, say=print) -> Tracks:
    """Run the tracker the options name on the points (see :func:`seedtrack.points.track_frames`)."""
    settings = tracking_settings(args, goa_config(args))
    if _first_links_file(args):
        settings = replace(settings, first_links=given_first_links(Path(args.first_links), points))
    return track_frames(points.frames, settings, points.first_frame, say)


def track_rows(points: Points, tracks: Tracks) -> dict[str, np.ndarray]:
    """The columns of tracks.csv: the track columns, then the kept columns (blank when interpolated)."""
    rows, source = point_rows(points, tracks)
    measured = source >= 0
    for name, values in points.kept.items():
        out = np.full(source.size, "", dtype=object)
        out[measured] = values[source[measured]]
        rows[name] = out
    return rows


def run(args: argparse.Namespace) -> int:
    check_options(args)
    units = calibration_from(args)
    return_freed_memory()
    # Now rather than after a long tracking run.
    check_target(args.out)
    output_format(args.out)
    points = read_points(args.points)
    tracks = track_points(points, args)
    spacing = f" ({points.frame_step} frame numbers apart, tracked as consecutive)" if points.frame_step > 1 else ""
    counts = f"{len(points.frames)} frames{spacing}, {counted(sum(f.shape[0] for f in points.frames), 'point')}, {counted(tracks.n_tracks, 'track')}"
    rows = track_rows(points, tracks)
    # Only the rows are written: the points and tracks freed do not add to the writer's peak.
    del points, tracks
    write_rows(args.out, rows, units=units)
    print(f"{counts}, {counted(int(rows['interpolated'].sum()), 'interpolated position')}; wrote {args.out}")
    return 0
