"""``seedtrack render INPUT TRACKS --out OUT``: the clip (or a frame, or a GIF) with the tracks drawn over it."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from seedtrack.data.atomic import check_target
from seedtrack.data.clip_units import tiff_calibration
from seedtrack.data.csvio import read_points
from seedtrack.data.errors import DataError
from seedtrack.data.frames import FrameSource, open_frames
from seedtrack.data.trackfile import FORMATS, read_tracks
from seedtrack.tracking.tracks import Tracks

from ..error_plot import write_png
from ..errors import UsageError
from ..frame_output import output_kind, write_frames
from ..drawing import FalseDetections, TrackLayer, View, annotate_frames, summary_picture, track_legend
from ..scale_bar import with_scale_bar
from ..wording import CLIP_INPUT_HELP, counted
from .units import add_unit_options, calibration_from

DEFAULT_TRAIL = 10
# Beyond what any player shows, or GIF's 1/100 s frame delays can hold.
_MAX_FPS = 1000
# A GIF holds a frame's delay as a 16-bit count of hundredths of a second (at most 655 s), and a
# rate near zero overflowed it; one frame per 100 s is slower than anyone plays a clip.
_MIN_FPS = 0.01


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


def check_view_options(args: argparse.Namespace) -> str | None:
    """The output kind (see :func:`seedtrack.frame_output.output_kind`), after checking the options.

    Raises
    ------
    UsageError
        If an option is out of range or no output is asked for.
    DataError
        If an output file's folder does not exist.
    """
    if args.out is None and getattr(args, "summary", None) is None:
        raise UsageError("give --out or --summary")  # compare requires --out; only render gets here
    for name in ("start", "end", "frame"):
        value = getattr(args, name)
        if value is not None and value < 0:
            raise UsageError(f"--{name} must be a 0-based frame index >= 0, got {value}")
    if args.step < 1:
        raise UsageError(f"--step must be at least 1, got {args.step}")
    if args.trail < 0:
        raise UsageError(f"--trail must be >= 0, got {args.trail}")
    if args.fps is not None and not _MIN_FPS <= args.fps <= _MAX_FPS:
        raise UsageError(f"--fps must be at least {_MIN_FPS:g} and at most {_MAX_FPS} frames per second, got {args.fps:g}")
    kind = output_kind(args.out) if args.out is not None else None
    if args.frame is not None and kind != "png":
        raise UsageError("--frame chooses the frame of a .png output; use --start/--end/--step for clips")
    # A missing folder is found now rather than after the whole clip has been drawn.
    if kind not in (None, "folder"):
        check_target(args.out)
    if getattr(args, "summary", None) is not None:
        check_target(args.summary)
    return kind


def open_range(args: argparse.Namespace, kind: str | None, track_sets: list[tuple[Path, Tracks]]) -> FrameSource:
    """Open INPUT over the frames asked for, after checking that the tracks lie within it.

    Raises
    ------
    DataError
        If the input cannot be read, or a track set does not fit it (see :func:`check_fits`).
    """
    for path, tracks in track_sets:
        if tracks.n_frames == 0:
            raise DataError(path, "holds no track points")
    last_frames = [tracks.first_frame + tracks.n_frames - 1 for _, tracks in track_sets]
    if kind == "png":
        frame = args.frame if args.frame is not None else max(last_frames)
        with open_frames(args.input) as whole:
            length = whole.clip_length
        if length is not None and frame >= length:
            if args.frame is not None:
                raise UsageError(f"--frame {frame} is past the last frame of {args.input} ({length - 1})")
            # The tracks' last frame is past the clip: the check below says so in those terms.
            frame = length - 1
        source = open_frames(args.input, start=frame, end=frame + 1)
    else:
        source = open_frames(args.input, start=args.start, end=args.end, step=args.step)
    try:
        for path, tracks in track_sets:
            rows = tracks.to_rows()
            check_fits(path, rows["frame"], rows["x"], rows["y"], source, args.input)
    except BaseException:
        source.close()
        raise
    return source


# A point this far outside the frame, as a share of the frame's larger side, is not of this clip.
_OUTSIDE_SHARE = 0.1


def check_fits(path: Path, frame, x, y, source: FrameSource, clip: Path, what: str = "tracks") -> None:
    """Refuse points (of tracks or detections) that cannot be of the clip: a frame past its end,
    or a position well outside its frames.

    Parameters
    ----------
    path : Path
        The points' file, for the message.
    frame, x, y : ndarray
        0-based frame index and position (pixels) of each point.
    source : FrameSource
        The clip, opened; its length may be unknown (a stream), and then only the size is checked.
    clip : Path
        The clip's name, for the message.
    what : str
        What the points are, for the message.

    Raises
    ------
    DataError
        Naming both files and what does not fit.
    """
    if len(frame) == 0:
        return
    length = source.clip_length
    if length is not None and int(max(frame)) >= length:
        raise DataError(
            path,
            f"frames {int(min(frame))}..{int(max(frame))} lie outside the video {clip} (frames 0..{length - 1}); are these the {what} of this clip?",
        )
    width, height = source.size
    margin = _OUTSIDE_SHARE * max(width, height)
    outside = (x < -0.5 - margin) | (x > width - 0.5 + margin) | (y < -0.5 - margin) | (y > height - 0.5 + margin)
    if outside.any():
        i = int(np.flatnonzero(outside)[0])
        raise DataError(
            path,
            f"{int(outside.sum())} point(s) lie well outside the {width}x{height} frames of {clip} (first: frame {int(frame[i])} at "
            f"x={float(x[i]):.1f}, y={float(y[i]):.1f}); are these the {what} of this clip?",
        )


def run(args: argparse.Namespace) -> int:
    kind = check_view_options(args)
    tracks = read_tracks(args.tracks, args.format)
    detections = read_points(args.detections) if args.detections is not None else None
    print(draw(args, kind, tracks, detections))
    return 0


def draw(args: argparse.Namespace, kind: str | None, tracks: Tracks, detections: dict[str, np.ndarray] | None) -> str:
    """Draw ``tracks`` over ``args.input`` into ``args.out`` (``kind``, see
    :func:`check_view_options`) and ``args.summary``, as the options say; ``args.tracks`` names
    the tracks in errors. Detections (columns frame, x, y) that no track holds are crossed out.
    A scale bar is drawn when the clip (a calibrated TIFF) or ``--pixel-size`` gives a length unit.

    Returns
    -------
    str
        What was written, in one line.
    """
    if args.summary is not None and Path(args.summary).suffix.lower() != ".png":
        raise UsageError(f"--summary must be a .png file, got {args.summary}")
    units = calibration_from(args, tiff_calibration(args.input))
    with open_range(args, kind, [(args.tracks, tracks)]) as source:
        view = View.of(source.size, args.crop, args.scale)
        enlarged = view.size[0] / (view.box[2] - view.box[0])
        layer = TrackLayer(tracks, view, trail=args.trail, labels=args.labels)
        if args.summary is not None:
            _, first = next(open_frames(args.input, start=args.start, end=args.start + 1).shown())
            picture = summary_picture(first, view, [layer], counted(tracks.n_tracks, "track"))
            write_png(args.summary, next(with_scale_bar([(0, picture)], units, enlarged))[1])
        if kind is None:
            return f"wrote {args.summary}"
        false = None
        if detections is not None:
            check_fits(args.detections, detections["frame"], detections["x"], detections["y"], source, args.input, "detections")
            false = FalseDetections(detections["frame"], detections["x"], detections["y"], tracks, view)
        frames = with_scale_bar(annotate_frames(source.shown(), view, [layer], false_detections=false, legend=track_legend(false is not None)), units, enlarged)
        count = write_frames(args.out, frames, args.fps or source.fps, source.frame_count)
    return f"wrote {args.out}: {counted(count, 'frame')} of {counted(tracks.n_tracks, 'track')}, {view.size[0]}x{view.size[1]}" + (f", and {args.summary}" if args.summary else "")
