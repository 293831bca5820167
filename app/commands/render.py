"""``seedtrack render INPUT TRACKS --out OUT``: the clip (or a frame, or a GIF) with the tracks drawn over it."""

from __future__ import annotations

import argparse
from pathlib import Path

from seedtrack.data.clip_units import tiff_calibration
from seedtrack.data.csvio import read_points
from seedtrack.data.trackfile import FORMATS, read_tracks

from ..outputs import refuse_replacing_inputs
from ..rendering import draw, output_checked
from ..settings import RenderSettings
from ..wording import CLIP_INPUT_HELP
from . import settings_of
from .units import add_unit_options, calibration_from

DEFAULT_TRAIL = RenderSettings().trail


def add_view_options(parser: argparse.ArgumentParser, out_required: bool) -> None:
    """The input, output, frame range and drawing options shared by ``render`` and ``compare``."""
    parser.add_argument(
        "--out",
        required=out_required,
        default=None,
        metavar="OUT",
        help="output: .mp4 (H.264 clip), .gif (animated), .png (one frame, see --frame) or a folder (no extension "
        "or ending in /: one PNG per frame)",
    )
    group = parser.add_argument_group("frames and drawing")
    group.add_argument("--start", type=int, default=0, metavar="F", help="first 0-based frame to draw (default 0)")
    group.add_argument("--end", type=int, default=None, metavar="F", help="stop before this frame (default: the end of INPUT)")
    group.add_argument("--step", type=int, default=1, metavar="N", help="draw every Nth frame (default 1)")
    group.add_argument("--frame", type=int, default=None, metavar="F", help="the frame a .png output shows (default: the last frame of the tracks)")
    group.add_argument("--trail", type=int, default=DEFAULT_TRAIL, metavar="N", help=f"past positions in each fading trail (default {DEFAULT_TRAIL})")
    group.add_argument("--labels", action=argparse.BooleanOptionalAction, default=True, help="write each track's id beside it (default: yes)")
    group.add_argument("--scale", type=float, default=1.0, metavar="S", help="enlarge (or shrink, below 1) the frames by S (default 1)")
    group.add_argument("--crop", default=None, metavar="x0,y0,x1,y1", help="draw only this box of the input frame, pixels (x1, y1 exclusive)")
    group.add_argument("--fps", type=float, default=None, metavar="F", help="frames per second of the output (default: that of INPUT)")


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "render",
        description="Draw each track over INPUT in its own colour (the same on every run): a fading trail, the id "
        "beside the head, interpolated positions hollow, starts and ends marked, detections that no track holds "
        "crossed out (with --detections), a legend and the frame number.",
    )
    parser.add_argument("input", type=Path, metavar="INPUT", help=CLIP_INPUT_HELP)
    parser.add_argument("tracks", type=Path, metavar="TRACKS", help="tracks to draw (csv, trackpy csv, MOT txt, TrackMate or ISBI xml, GEFF, napari npy)")
    add_view_options(parser, out_required=False)
    parser.add_argument("--summary", type=Path, default=None, metavar="PNG", help="also draw every whole trajectory over the first frame into this PNG")
    parser.add_argument("--detections", type=Path, default=None, metavar="CSV", help="detections.csv (frame,x,y,...): mark those that no track holds")
    parser.add_argument("--format", choices=sorted(FORMATS), default=None, help="format of TRACKS (default: from the extension and contents)")
    add_unit_options(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    settings = settings_of(RenderSettings, args)
    kind = output_checked(args.out, settings, args.summary)
    refuse_replacing_inputs([args.input, args.tracks, args.detections], [args.out, args.summary])
    tracks = read_tracks(args.tracks, args.format)
    detections = read_points(args.detections) if args.detections is not None else None
    # A calibrated TIFF, or --pixel-size, gives the frames a scale bar.
    units = calibration_from(args, tiff_calibration(args.input))
    print(draw(args.input, tracks, args.tracks, args.out, kind, settings, args.summary, detections, args.detections, units))
    return 0
