"""The run pipeline: frames -> detections -> tracks -> files and an overlay clip.

Frames are streamed twice (once to detect, once to draw) rather than held in memory, so the
clip's length does not bound what can be processed.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable

import numpy as np

from seedtrack.data.atomic import output_folder
from seedtrack.data.csvio import write_table
from seedtrack.data.errors import DataError, warn
from seedtrack.data.frames import FrameSource, open_frames, read_mask
from seedtrack.data.trackfile import write_tracks
from seedtrack.data.video import write_video
from seedtrack.detection.background import temporal_median
from seedtrack.detection.blobs import MEASUREMENT_COLUMNS, BlobOptions, background_of, choose_polarity, detect_blobs, to_gray
from seedtrack.detection.roi import Circle, circle_mask, dish_mask
from seedtrack.detection.spots import detect_spots
from seedtrack.tracking.goa import GOAConfig, goa_updown, pass_steps
from seedtrack.tracking.lifecycle import LifecycleConfig, drop_short, goa_updown_open
from seedtrack.tracking.regime import choose_motion, fit_motion, track_without_drift
from seedtrack.tracking.tracks import Tracks

from .errors import UsageError
from .drawing import FalseDetections, TrackLayer, View, annotate_frames, track_legend
from .progress import progress_bar
from .wording import counted

DETECTORS = {"blob": detect_blobs, "log": detect_spots}
# Frames whose per-pixel median is a static scene's background: spread over the clip.
_BACKGROUND_FRAMES = 64


@dataclass(frozen=True)
class DetectionSettings:
    """What the detector is asked to do on a clip.

    Attributes
    ----------
    options : BlobOptions
        Polarity ("auto" is decided once, on the first frame), background, threshold, areas.
    detector : {"blob", "log"}
        Threshold blobs (:func:`seedtrack.detection.blobs.detect_blobs`) or Laplacian-of-Gaussian spots
        (:func:`seedtrack.detection.spots.detect_spots`).
    roi : "auto", "none", Circle or Path
        Region of interest: the dish found on the first frame (whole frame if there is none
        clearly), the whole frame, a circle in pixels, or a mask image of the frames' size.
    start, end, step : int
        0-based frames processed: ``range(start, end, step)``, end None for the clip's end.
    """

    options: BlobOptions = BlobOptions()
    detector: str = "blob"
    roi: str | Circle | Path = "auto"
    start: int = 0
    end: int | None = None
    step: int = 1


@dataclass(frozen=True)
class Detections:
    """Measurements of every processed frame.

    Attributes
    ----------
    frame_indices : ndarray of int, shape (n_frames,)
        0-based index in the clip of each processed frame.
    columns : list of dict of str to ndarray
        Per processed frame, the detector's columns (``x``, ``y``, ``area``, ...).
    """

    frame_indices: np.ndarray
    columns: list[dict[str, np.ndarray]]

    @property
    def points(self) -> list[np.ndarray]:
        """Per frame, an (M_k, 2) array of (x, y) positions, pixels."""
        return [np.column_stack((c["x"], c["y"])) for c in self.columns]

    def to_rows(self) -> dict[str, np.ndarray]:
        """Columns of ``detections.csv``: frame, x, y, area, then the detector's other columns."""
        names = list(dict.fromkeys(("x", "y", "area", *MEASUREMENT_COLUMNS)))
        counts = [len(c["x"]) for c in self.columns]
        rows = {"frame": np.repeat(self.frame_indices, counts).astype(np.int64)}
        for name in names:
            rows[name] = np.concatenate([c[name] for c in self.columns]) if self.columns else np.empty(0)
        return rows


@dataclass(frozen=True, eq=False)
class ClipDetections:
    """What :func:`detect_clip` found.

    Attributes
    ----------
    detections : Detections
    fps : float
        The clip's frame rate, frames per second.
    roi : ndarray of uint8, shape (H, W), or None
        The region of interest used (255 inside), None for the whole frame.
    circle : Circle or None
        The dish found or the circle given, when the region is a circle.
    preview : ndarray of uint8, shape (H, W, 3), or None
        The frame asked for as a preview, as read.
    """

    detections: Detections
    fps: float
    roi: np.ndarray | None
    circle: Circle | None
    preview: np.ndarray | None


def detect_clip(path: Path, settings: DetectionSettings = DetectionSettings(), preview_frame: int | None = None) -> ClipDetections:
    """Detect objects in every frame of a clip, with a progress bar.

    A video that breaks off part way keeps the frames decoded before, and one line on standard
    error says where it stopped.

    Parameters
    ----------
    path : Path
        Video, image folder, glob pattern or TIFF stack.
    settings : DetectionSettings
    preview_frame : int, optional
        0-based index of a processed frame to keep as :attr:`ClipDetections.preview`.

    Raises
    ------
    DataError
        If the clip or the mask cannot be read, the mask is of another size, or no frame can
        be read.
    UsageError
        If the preview frame is not among the processed frames.
    """
    with open_frames(path, start=settings.start, end=settings.end, step=settings.step) as source:
        last = settings.start + settings.step * source.frame_count if source.frame_count is not None else settings.end
        processed = range(settings.start, last if last is not None else sys.maxsize, settings.step)
        if preview_frame is not None and preview_frame not in processed:
            step = f" every {settings.step}" if settings.step > 1 else ""
            span = f"{processed.start}..{processed[-1]}{step}" if len(processed) else "none"
            raise UsageError(f"preview frame {preview_frame} is not among the frames processed ({span})")
        roi, circle = _given_roi(settings.roi, source.size)
        background = _temporal_background(path, settings, source) if settings.options.background == "temporal" else None
        detect = DETECTORS[settings.detector]
        options = settings.options
        indices: list[int] = []
        columns: list[dict[str, np.ndarray]] = []
        preview = None
        with progress_bar(source.frame_count, "detecting") as bar:
            for index, image in source:
                gray = to_gray(image)
                if not indices:
                    if settings.roi == "auto":
                        roi, circle = dish_mask(gray)
                    if options.polarity == "auto":
                        # Once per clip: a frame with little in it must not flip it.
                        options = replace(options, polarity=choose_polarity(gray, background_of(gray, options, background), roi))
                indices.append(index)
                columns.append(detect(gray, options, background=background, roi=roi))
                if index == preview_frame:
                    preview = image.copy()
                bar.update(1)
        if not indices:
            raise DataError(path, source.stopped_early or "no frame could be read")
        if source.stopped_early:
            print(f"seedtrack: {path}: {source.stopped_early}; keeping the {counted(len(indices), 'frame')} before it", file=sys.stderr)
        return ClipDetections(Detections(np.array(indices), columns), source.fps, roi, circle, preview)


def _given_roi(roi: str | Circle | Path, size: tuple[int, int]) -> tuple[np.ndarray | None, Circle | None]:
    """The region of interest known before any frame is read ("auto" waits for the first)."""
    if isinstance(roi, Circle):
        mask = circle_mask(size, roi)
        if not mask.any():
            warn(f"--roi {roi.x:g},{roi.y:g},{roi.r:g}", f"the circle lies wholly outside the {size[0]}x{size[1]} frames; nothing will be detected")
        return mask, roi
    if isinstance(roi, Path):
        return read_mask(roi, size), None
    return None, None


def _temporal_background(path: Path, settings: DetectionSettings, source: FrameSource) -> np.ndarray:
    """Per-pixel median of up to 64 frames spread evenly over the processed range."""
    spread = settings.step * max(1, math.ceil((source.frame_count or _BACKGROUND_FRAMES) / _BACKGROUND_FRAMES))
    with open_frames(path, start=settings.start, end=settings.end, step=spread) as sample:
        total = min(sample.frame_count, _BACKGROUND_FRAMES) if sample.frame_count is not None else None
        with progress_bar(total, "background") as bar:

            def grey_frames():
                for _, image in sample:
                    bar.update(1)
                    yield to_gray(image)

            return temporal_median(grey_frames(), _BACKGROUND_FRAMES)


def track_with_motion(
    frames: list[np.ndarray],
    config: GOAConfig,
    motion: str,
    track: Callable[[list[np.ndarray], GOAConfig], Tracks],
    keep_model: bool = False,
    say: Callable[[str], None] = print,
) -> Tracks:
    """``track(frames, fitted)`` with ``config`` fitted to the motion of the points.

    The motion is measured by :func:`seedtrack.tracking.regime.choose_motion` (``motion`` is "auto",
    "smooth" or "random") and the choice said on one ``motion: ...`` line. Random motion with a
    common drift is tracked in a frame moving with the drift and returned in the image frame
    (:func:`seedtrack.tracking.regime.track_without_drift`). ``keep_model`` keeps ``config``'s individual
    model (the user chose it).
    """
    choice = choose_motion(frames, motion)
    fitted, drift = fit_motion(config, choice, keep_model)
    limit = "no speed limit" if fitted.d_max is None else f"speed limit {fitted.d_max:.2f} px/frame"
    if any(drift):
        limit += f" about the drift ({drift[0]:.2f}, {drift[1]:.2f}) px/frame"
    say(f"motion: {choice.reason}; tracking with {fitted.individual.name.upper()}, {limit}")
    return track_without_drift(frames, drift, lambda moved: track(moved, fitted))


def link_frames(frames: list[np.ndarray], config: GOAConfig, lifecycle: LifecycleConfig | None, first_frame: int = 0) -> Tracks:
    """GOA-updown with a progress bar: open (tracks start and end anywhere) or, with ``lifecycle``
    None, the paper's fixed count of tracks. ``first_frame`` is the 0-based index of ``frames[0]``."""
    with progress_bar(pass_steps(len(frames)), "tracking", unit="step") as bar:
        if lifecycle is None:
            return goa_updown(frames, config, first_frame, progress=bar.update)
        return goa_updown_open(frames, config, lifecycle, first_frame, progress=bar.update)


def render_overlay(
    path: Path, tracks: Tracks, detections: Detections, out: Path, fps: float, trail: int = 10, selection: DetectionSettings | None = None
) -> None:
    """Write an H.264 clip of the input with the tracks drawn over it (see :mod:`seedtrack.drawing`),
    of the frames ``selection.start``, ``end`` and ``step`` select, if given.

    Detections that no track holds are marked as false detections.
    """
    span = {} if selection is None else {"start": selection.start, "end": selection.end, "step": selection.step}
    with open_frames(path, **span) as source:
        view = View.of(source.size)
        layer = TrackLayer(tracks, view, trail=trail, frame_indices=detections.frame_indices)
        rows = detections.to_rows()
        false = FalseDetections(rows["frame"], rows["x"], rows["y"], tracks, view, frame_indices=detections.frame_indices)
        frames = annotate_frames(source, view, [layer], false_detections=false, legend=track_legend(True))
        with progress_bar(source.frame_count, "rendering") as bar:
            write_video(out, (image for _, image in frames), fps, progress=bar)


def run_pipeline(
    clip: Path,
    out: Path,
    settings: DetectionSettings,
    config: GOAConfig,
    lifecycle: LifecycleConfig | None = LifecycleConfig(),
    min_length: int = 0,
    motion: str = "auto",
) -> tuple[Detections, Tracks]:
    """Detect, track, and write ``detections.csv``, ``tracks.csv`` and ``overlay.mp4`` to ``out``.

    Tracking is :func:`link_frames` with ``lifecycle`` and ``config`` fitted to ``motion`` (see
    :func:`track_with_motion`); tracks spanning fewer than ``min_length`` frames are not written.

    Each file is written whole or not at all, in that order, so an interruption keeps what was
    finished; an output folder made here and still empty is removed again.
    """
    with output_folder(out):
        found = detect_clip(clip, settings)
        detections = found.detections
        write_table(out / "detections.csv", detections.to_rows())
        tracks = track_with_motion(detections.points, config, motion, lambda frames, fitted: link_frames(frames, fitted, lifecycle))
        tracks = drop_short(tracks, min_length)
        write_tracks(out / "tracks.csv", tracks, detections.frame_indices)
        render_overlay(clip, tracks, detections, out / "overlay.mp4", found.fps, selection=settings)
    return detections, tracks
