"""Tracks drawn over their clip, as ``seedtrack render`` and ``compare`` and
:func:`seedtrack.render` draw them: which frames, checked against the tracks, into which output.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from seedtrack.data.atomic import check_target
from seedtrack.data.calibration import Calibration
from seedtrack.data.clip_units import tiff_calibration
from seedtrack.data.errors import DataError
from seedtrack.data.frames import FrameSource, open_frames
from seedtrack.tracking.tracks import Tracks

from .drawing import FalseDetections, TrackLayer, View, annotate_frames, summary_picture, track_legend
from .error_plot import write_png
from .errors import OptionError
from .frame_output import output_kind, write_frames
from .scale_bar import with_scale_bar
from .settings import RenderSettings
from .wording import counted

__all__ = ["output_checked", "open_range", "check_fits", "draw"]


def output_checked(out: str | None, settings: RenderSettings, summary: Path | None = None) -> str | None:
    """The output kind (see :func:`seedtrack.frame_output.output_kind`), after checking that it
    suits the settings and that the outputs' folders exist.

    Raises
    ------
    OptionError
        If no output is asked for, or ``frame`` is given for an output other than a .png.
    DataError
        If an output file's folder does not exist.
    """
    if out is None and summary is None:
        raise OptionError("give out or summary", "out", "summary")
    kind = output_kind(out) if out is not None else None
    if settings.frame is not None and kind != "png":
        raise OptionError("frame chooses the frame of a .png output; use start/end/step for clips", "frame", "start", "end", "step")
    # A missing folder is found now rather than after the whole clip has been drawn.
    if kind not in (None, "folder"):
        check_target(out)
    if summary is not None:
        check_target(summary)
    return kind


def open_range(clip: Path, settings: RenderSettings, kind: str | None, track_sets: list[tuple[Path, Tracks]]) -> FrameSource:
    """Open the clip over the frames asked for, after checking that the tracks lie within it.

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
        frame = settings.frame if settings.frame is not None else max(last_frames)
        with open_frames(clip) as whole:
            length = whole.clip_length
        if length is not None and frame >= length:
            if settings.frame is not None:
                raise OptionError(f"frame {frame} is past the last frame of {clip} ({length - 1})", "frame")
            # The tracks' last frame is past the clip: the check below says so in those terms.
            frame = length - 1
        source = open_frames(clip, start=frame, end=frame + 1)
    else:
        source = open_frames(clip, start=settings.start, end=settings.end, step=settings.step)
    try:
        for path, tracks in track_sets:
            rows = tracks.to_rows()
            check_fits(path, rows["frame"], rows["x"], rows["y"], source, clip)
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




def draw(
    clip: Path,
    tracks: Tracks,
    tracks_name,
    out: str | None,
    kind: str | None,
    settings: RenderSettings = RenderSettings(),
    summary: Path | None = None,
    detections: dict[str, np.ndarray] | None = None,
    detections_name=None,
    units: Calibration | None = None,
) -> str:
    """Draw ``tracks`` over ``clip`` into ``out``, of ``kind`` (see :func:`output_checked`), and
    ``summary``, as the settings say; ``tracks_name`` and ``detections_name`` name them in
    errors. Detections (columns frame, x, y) that no track holds are crossed out. A scale bar is
    drawn when ``units`` (by default the clip's own: a calibrated TIFF's) has a length unit.

    Returns
    -------
    str
        What was written, in one line.
    """
    if summary is not None and Path(summary).suffix.lower() != ".png":
        raise OptionError(f"summary must be a .png file, got {summary}", "summary")
    units = units if units is not None else tiff_calibration(clip)
    with open_range(clip, settings, kind, [(tracks_name, tracks)]) as source:
        view = View.of(source.size, settings.crop, settings.scale)
        enlarged = view.size[0] / (view.box[2] - view.box[0])
        layer = TrackLayer(tracks, view, trail=settings.trail, labels=settings.labels)
        if summary is not None:
            _, first = next(open_frames(clip, start=settings.start, end=settings.start + 1).shown())
            picture = summary_picture(first, view, [layer], counted(tracks.n_tracks, "track"))
            write_png(summary, next(with_scale_bar([(0, picture)], units, enlarged))[1])
        if kind is None:
            return f"wrote {summary}"
        false = None
        if detections is not None:
            check_fits(detections_name, detections["frame"], detections["x"], detections["y"], source, clip, "detections")
            false = FalseDetections(detections["frame"], detections["x"], detections["y"], tracks, view)
        frames = with_scale_bar(annotate_frames(source.shown(), view, [layer], false_detections=false, legend=track_legend(false is not None)), units, enlarged)
        count = write_frames(out, frames, settings.fps or source.fps, source.frame_count)
    return f"wrote {out}: {counted(count, 'frame')} of {counted(tracks.n_tracks, 'track')}, {view.size[0]}x{view.size[1]}" + (f", and {summary}" if summary else "")
