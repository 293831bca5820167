"""``seedtrack compare INPUT A B --out OUT``: two track sets over one clip, their disagreements in a warning colour."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from seedtrack.data.trackfile import FORMATS, read_tracks
from seedtrack.tracking.tracks import Tracks

from ..frame_output import write_frames
from ..drawing import COMPARE_A_BGR, COMPARE_B_BGR, WARNING_BGR, TrackLayer, View, annotate, track_links
from ..rendering import open_range, output_checked
from ..scoring import DEFAULT_TOLERANCE, disagreeing_links
from ..settings import RenderSettings, check_tolerance
from ..wording import CLIP_INPUT_HELP, counted
from . import settings_of
from .render import add_view_options


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "compare",
        description="Draw track sets A and B (truth and result, or two trackers; any track format) over INPUT, side by "
        "side or overlaid. Points of the two sets are matched frame by frame within --tol; a link of one set "
        "(a point to the same track's next point) disagrees with the other set when its two points are not matched to one and the same "
        "track there, and is drawn in yellow.",
    )
    parser.add_argument("input", type=Path, metavar="INPUT", help=CLIP_INPUT_HELP)
    parser.add_argument("a", type=Path, metavar="A", help="first track set (csv, trackpy csv, MOT txt, TrackMate or ISBI xml), drawn blue")
    parser.add_argument("b", type=Path, metavar="B", help="second track set, drawn vermillion")
    add_view_options(parser, out_required=True)
    parser.add_argument("--tol", type=float, default=DEFAULT_TOLERANCE, metavar="PX", help=f"matching distance in pixels (default {DEFAULT_TOLERANCE:g})")
    layout = parser.add_mutually_exclusive_group()
    layout.add_argument("--side-by-side", dest="overlay", action="store_false", help="A on the left, B on the right (default)")
    layout.add_argument("--overlay", dest="overlay", action="store_true", help="A and B drawn over the same frame")
    parser.add_argument("--format-a", choices=sorted(FORMATS), default=None, help="format of A (default: from the extension and contents)")
    parser.add_argument("--format-b", choices=sorted(FORMATS), default=None, help="format of B (default: from the extension and contents)")
    parser.set_defaults(run=run, overlay=False)


def _short_name(path: Path, other: Path) -> str:
    """The file name, with its folder when the other file has the same name (run1/tracks.csv)."""
    return f"{path.parent.name}/{path.name}" if path.name == other.name and path.parent.name else path.name


def run(args: argparse.Namespace) -> int:
    settings = settings_of(RenderSettings, args)
    kind = output_checked(args.out, settings)
    check_tolerance(args.tol)
    a = read_tracks(args.a, args.format_a)
    b = read_tracks(args.b, args.format_b)
    warnings_a = disagreeing_links(a, b, args.tol)
    warnings_b = disagreeing_links(b, a, args.tol)
    with open_range(args.input, settings, kind, [(args.a, a), (args.b, b)]) as source:
        view = View.of(source.size, settings.crop, settings.scale)
        layer_a = TrackLayer(a, view, trail=settings.trail, labels=settings.labels, colour=COMPARE_A_BGR, warnings=warnings_a)
        layer_b = TrackLayer(b, view, trail=settings.trail, labels=settings.labels, colour=COMPARE_B_BGR, warnings=warnings_b)
        legend_a = ("line", COMPARE_A_BGR, f"A: {_short_name(args.a, args.b)}")
        legend_b = ("line", COMPARE_B_BGR, f"B: {_short_name(args.b, args.a)}")
        warning = ("line", WARNING_BGR, "link the other lacks")
        if args.overlay:
            frames = ((index, annotate(image, index, view, [layer_a, layer_b], legend=[legend_a, legend_b, warning])) for index, image in source.shown())
        else:
            frames = _side_by_side(source, view, (layer_a, [legend_a, warning]), (layer_b, [legend_b, warning]))
        count = write_frames(args.out, frames, settings.fps or source.fps, source.frame_count)
    print(
        f"wrote {args.out}: {counted(count, 'frame')}; links disagreeing within {args.tol:g} px: "
        f"A {int(warnings_a.sum())} of {_links(a)}, B {int(warnings_b.sum())} of {_links(b)}"
    )
    return 0


def _links(tracks: Tracks) -> int:
    return len(track_links(tracks.present)[0])


def _side_by_side(source, view: View, left, right):
    """Yield ``(frame_index, A panel | gap | B panel)`` for every frame of ``source``."""
    gap = np.zeros((view.size[1], max(2, view.size[0] // 200), 3), np.uint8)
    for index, image in source.shown():
        panels = [annotate(image, index, view, [layer], legend=legend, title=f"{name} ") for (layer, legend), name in ((left, "A"), (right, "B"))]
        yield index, np.hstack([panels[0], gap, panels[1]])
