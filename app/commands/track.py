"""``seedtrack track POINTS.csv --out tracks.csv``: link measured points into tracks."""

from __future__ import annotations

import argparse
from pathlib import Path

from seedtrack.data.atomic import check_target
from seedtrack.data.csvio import read_points as read_points_table
from seedtrack.data.trackfile import output_format, write_rows
from seedtrack.tracking.trackers import TRACKERS

from ..allocation import return_freed_memory
from ..errors import output_file
from ..outputs import refuse_replacing_inputs
from ..points import Points, group_points, link_points, track_rows
from ..settings import COMBINED_CHOICES, INDIVIDUAL_CHOICES, LinkSettings
from ..wording import counted
from . import settings_of
from .tracker_options import add_tracker_options, add_verbose_option
from .units import add_unit_options, calibration_from

DESCRIPTION = """\
Link the points of POINTS.csv (columns frame,x,y in pixels, 0-based frames; any other columns are
kept) into tracks and write tracks.csv with columns track_id,frame,x,y,interpolated followed by the
kept columns. A measured row carries its point's kept values unchanged; a row with interpolated=1 is
a position filled in for a missed point (a bound slave) and leaves them blank. Input columns named
track_id or interpolated are not kept. A column ep (each point's localisation error, pixels per
axis, as detect writes it and trackpy names it; blank, NaN or negative for none) sets the least
noise of the measured motion: sqrt(6) times its median, what such errors put on a velocity change.

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
    add_verbose_option(parser)
    add_unit_options(parser)
    group = parser.add_argument_group("GOA and GOA-updown only")
    group.add_argument(
        "--individual-model",
        choices=INDIVIDUAL_CHOICES,
        default=None,
        help="cost of one link: im1 nearest neighbour, im2 smooth motion (default), im3 proximal uniformity",
    )
    group.add_argument(
        "--combined-model",
        choices=COMBINED_CHOICES,
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
    parser.set_defaults(run=run)


def read_points(path: Path) -> Points:
    """Read POINTS.csv and group its points by frame (see :func:`group_points`)."""
    return group_points(read_points_table(path, others_as_text=True), path)


def run(args: argparse.Namespace) -> int:
    settings = settings_of(LinkSettings, args)
    units = calibration_from(args)
    return_freed_memory()
    # Now rather than after a long tracking run.
    check_target(args.out)
    output_format(args.out)
    refuse_replacing_inputs([args.points], [args.out])
    points = read_points(args.points)
    tracks = link_points(points, settings, verbose=args.verbose)
    spacing = f" ({points.frame_step} frame numbers apart, tracked as consecutive)" if points.frame_step > 1 else ""
    counts = f"{len(points.frames)} frames{spacing}, {counted(sum(f.shape[0] for f in points.frames), 'point')}, {counted(tracks.n_tracks, 'track')}"
    rows = track_rows(points, tracks)
    # Only the rows are written: the points and tracks freed do not add to the writer's peak.
    del points, tracks
    write_rows(args.out, rows, units=units)
    print(f"{counts}, {counted(int(rows['interpolated'].sum()), 'interpolated position')}; wrote {args.out}")
    return 0
