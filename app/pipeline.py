"""The run pipeline: frames -> detections -> tracks -> files and an overlay clip.

The layer between files and the library that every command and the Python API
(:mod:`seedtrack.api`) call: :func:`detect_clip` reads a clip for
:class:`seedtrack.detection.clip.ClipDetector`, :func:`group_points` and :func:`track_frames`
give points to :func:`seedtrack.tracking.linking.link_goa` (or another tracker) as ``seedtrack
track`` does. Frames are streamed twice (once to detect, once to draw) rather than held in memory, so the
clip's length does not bound what can be processed.
"""

from __future__ import annotations

import functools
import importlib
import itertools
import sys
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from seedtrack.data.atomic import output_folder
from seedtrack.data.csvio import write_table
from seedtrack.data.errors import DataError, warn
from seedtrack.data.depth import to_bgr8
from seedtrack.data.frames import FrameSource, open_frames, read_mask
from seedtrack.data.trackfile import write_tracks
from seedtrack.data.video import PREVIEW_PRESET
from seedtrack.detection.background import temporal_median
from seedtrack.detection.blobs import BlobOptions, to_gray
from seedtrack.detection.choice import DetectorChoice
from seedtrack.detection.clip import BACKGROUND_FRAMES, DETECTORS, ClipDetector, Detections, background_spacing, detect_frames, grey_levels
from seedtrack.detection.roi import Circle, circle_mask
from seedtrack.tracking.tracks import Tracks

from .errors import UsageError
from .points import TrackingSettings, group_points, track_frames
from .parallel import VideoEncoder, read_ahead, threaded_map
from .drawing import FalseDetections, TrackLayer, View, annotate, track_legend
from .progress import progress_bar
from .wording import counted

__all__ = [
    "DETECTORS", "Detections", "DetectionSettings", "ClipDetections",
    "detect_clip", "render_overlay", "run_pipeline",
]

# Past positions in each track's fading trail on the overlay of `run`.
TRAIL = 10
# Decoded frames waiting for detection: enough that decoding goes on while the first frame's
# decisions are made (a tenth of a second on a 640x512 dish, 30 frames' decoding), little enough
# for memory to stay flat.
_READ_AHEAD_BYTES = 64 * 2**20


@dataclass(frozen=True)
class DetectionSettings:
    """What the detector is asked to do on a clip.

    Attributes
    ----------
    options : BlobOptions
        Polarity ("auto" is decided once, on the first frame), background, threshold, areas.
    detector : {"auto", "blob", "spot"}
        Threshold blobs (:func:`seedtrack.detection.blobs.detect_blobs`), Crocker-Grier spots
        (:func:`seedtrack.detection.spots.detect_spots`), or the one that suits the first frame
        (:func:`seedtrack.detection.choice.choose_detector`).
    diameter : int or None
        Spot diameter, pixels, odd; None measures it on the first frame.
    roi : "auto", "none", Circle or Path
        Region of interest: the dish found on the first frame (whole frame if there is none
        clearly), the whole frame, a circle in pixels, or a mask image of the frames' size.
    start, end, step : int
        0-based frames processed: ``range(start, end, step)``, end None for the clip's end.
    min_mass : float or None
        The spot detector's least mass (integrated brightness, data units times pixels, as the
        ``detector:`` line prints it); None sets it from the first frame's noise.
    """

    options: BlobOptions = BlobOptions()
    detector: str = "auto"
    diameter: int | None = None
    roi: str | Circle | Path = "auto"
    start: int = 0
    end: int | None = None
    step: int = 1
    min_mass: float | None = None


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
        The frame asked for as a preview, as shown (:func:`seedtrack.data.depth.to_bgr8`).
    choice : DetectorChoice
        The detector that ran, its settings and why.
    """

    detections: Detections
    fps: float
    roi: np.ndarray | None
    circle: Circle | None
    preview: np.ndarray | None
    choice: DetectorChoice


def detect_clip(
    path: Path,
    settings: DetectionSettings = DetectionSettings(), preview_frame: int | None = None,
    say: Callable[[str], None] | None = print,
    workers: int = 1,
) -> ClipDetections:
    """Detect objects in every frame of a clip, with a progress bar
    (:class:`seedtrack.detection.clip.ClipDetector` on the frames read).

    The detector, chosen on the first frame, is said on one ``detector: ...`` line (``say``
    None: nothing is said).

    A video that breaks off part way keeps the frames decoded before, and one line on standard
    error says where it stopped.

    Parameters
    ----------
    path : Path
        Video, image folder, glob pattern or TIFF stack.
    settings : DetectionSettings
    preview_frame : int, optional
        0-based index of a processed frame to keep as :attr:`ClipDetections.preview`.
    workers : int
        Threads detecting frames (see :func:`seedtrack.parallel.threaded_map`); the result is
        the same for any number.

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
        background = _temporal_background(path, settings, source) if settings.options.background == "temporal" else None
        detector = ClipDetector(settings.options, settings.detector, _given_roi(settings.roi, source.size), background, settings.diameter, settings.min_mass)
        preview = None

        def decoded():
            nonlocal preview
            for index, image in source:
                if index == preview_frame:
                    preview = to_bgr8(image, source.span).copy()
                # Both detectors see only the grey levels of an 8-bit colour frame: made here,
                # beside decoding, they are a third of the bytes to wait in the queue, so three
                # times the frames decode ahead while the first frame's decisions are made
                # (half a second at 1280x960).
                yield index, to_gray(image) if image.dtype == np.uint8 and image.ndim == 3 else image

        def counted_off(read):
            for item in read:
                yield item
                bar.update(1)

        frames = decoded()
        first = next(frames, None)
        ahead = _frames_ahead(first[1].nbytes if first is not None else 0)
        # The next frames decode beside detection, on another core if there is one. Frames are
        # detected in threads, not processes: both detectors spend most of their time in OpenCV
        # and numpy without Python's lock, and a clip of a few hundred frames took longer to
        # detect in two processes than in one (starting them, pickling frames).
        with progress_bar(source.frame_count, "detecting") as bar:
            with read_ahead(itertools.chain([first] if first is not None else [], frames), depth=ahead) as read:
                detections = detect_frames(counted_off(read), detector, functools.partial(threaded_map, workers=workers))
        if not detections.frame_indices.size:
            raise DataError(path, source.stopped_early or "no frame could be read")
        if say is not None:
            say(f"detector: {detector.choice.reason}{_unused_options(settings, detector.choice)}")
        if source.stopped_early:
            print(f"seedtrack: {path}: {source.stopped_early}; keeping the {counted(detections.frame_indices.size, 'frame')} before it", file=sys.stderr)
        return ClipDetections(detections, source.fps, detector.roi, detector.circle, preview, detector.choice)


def _frames_ahead(frame_bytes: int) -> int:
    """How many frames of ``frame_bytes`` each may wait decoded: about 64 MB, between 4 and 64."""
    return int(np.clip(_READ_AHEAD_BYTES // max(frame_bytes, 1), 4, 64))


def _unused_options(settings: DetectionSettings, choice: DetectorChoice) -> str:
    """What to add to the ``detector:`` line when options were given for the detector that did
    not run, so that they are never ignored silently ("" when there are none)."""
    defaults = BlobOptions()
    if choice.spots is None:
        return "; --min-mass applies to the spot detector only (not used)" if settings.min_mass is not None else ""
    given = settings.options
    unused = [
        option
        for option, differs in (
            ("--threshold", given.threshold != defaults.threshold),
            ("--min-area", given.min_area_px != defaults.min_area_px),
            ("--max-area", given.max_area_px != defaults.max_area_px),
            ("--no-split", given.split != defaults.split),
        )
        if differs
    ]
    if not unused:
        return ""
    return f"; {', '.join(unused)} {'apply' if len(unused) > 1 else 'applies'} to the blob detector only (not used)"


def _given_roi(roi: str | Circle | Path, size: tuple[int, int]) -> str | Circle | np.ndarray:
    """The region of interest as :class:`seedtrack.detection.clip.ClipDetector` takes it: a mask
    file read, anything else as it is (a circle wholly outside the frames is warned of)."""
    if isinstance(roi, Circle) and not circle_mask(size, roi).any():
        warn(f"--roi {roi.x:g},{roi.y:g},{roi.r:g}", f"the circle lies wholly outside the {size[0]}x{size[1]} frames; nothing will be detected")
    return read_mask(roi, size) if isinstance(roi, Path) else roi


def _temporal_background(path: Path, settings: DetectionSettings, source: FrameSource) -> np.ndarray:
    """Per-pixel median of up to 64 frames spread evenly over the processed range (as
    :func:`seedtrack.detection.clip.temporal_background` takes them from frames in memory)."""
    spread = settings.step * background_spacing(source.frame_count)
    with open_frames(path, start=settings.start, end=settings.end, step=spread) as sample:
        total = min(sample.frame_count, BACKGROUND_FRAMES) if sample.frame_count is not None else None
        with progress_bar(total, "background") as bar:

            def frames():
                for _, image in sample:
                    bar.update(1)
                    yield image

            return temporal_median(grey_levels(frames()), BACKGROUND_FRAMES)



def render_overlay(
    path: Path,
    tracks: Tracks,
    detections: Detections,
    out: Path,
    fps: float,
    trail: int = TRAIL,
    selection: DetectionSettings | None = None,
    workers: int = 1,
) -> None:
    """Write an H.264 clip of the input with the tracks drawn over it (see :mod:`seedtrack.drawing`),
    of the frames ``selection.start``, ``end`` and ``step`` select, if given.

    Detections that no track holds are marked as false detections. ``workers`` threads draw
    and, with more than one, the encoder has a process of its own; the file is the same for any
    number.
    """
    with VideoEncoder(out, fps, workers) as encoder:
        _render(path, tracks, detections, encoder, trail, selection, workers)


def _render(path: Path, tracks: Tracks, detections: Detections, encoder: VideoEncoder, trail: int, selection: DetectionSettings | None, workers: int) -> None:
    """:func:`render_overlay` into an encoder already started."""
    span = {} if selection is None else {"start": selection.start, "end": selection.end, "step": selection.step}
    with open_frames(path, **span) as source:
        view = View.of(source.size)
        layer = TrackLayer(tracks, view, trail=trail, frame_indices=detections.frame_indices)
        rows = detections.to_rows()
        false = FalseDetections(rows["frame"], rows["x"], rows["y"], tracks, view, frame_indices=detections.frame_indices)
        draw = functools.partial(_annotate_pair, span=source.span, view=view, layers=[layer], false_detections=false, legend=track_legend(True))
        # The next frames decode beside drawing, as in detection.
        with progress_bar(source.frame_count, "rendering") as bar, read_ahead(source) as read:
            encoder.write(threaded_map(draw, read, workers), progress=bar)


def _annotate_pair(frame: tuple[int, np.ndarray], span: tuple[float, float], **options) -> np.ndarray:
    """:func:`seedtrack.drawing.annotate` of a frame source's ``(frame_index, image)``, shown
    from the source's ``span`` (:func:`seedtrack.data.depth.to_bgr8`)."""
    index, image = frame
    return annotate(to_bgr8(image, span), index, **options)


def run_pipeline(clip: Path, out: Path, detection: DetectionSettings = DetectionSettings(), tracking: TrackingSettings = TrackingSettings(), workers: int = 1) -> tuple[Detections, Tracks]:
    """Detect, track, and write ``detections.csv``, ``tracks.csv`` and ``overlay.mp4`` to ``out``.

    Detection is :func:`detect_clip`, tracking :func:`track_frames`; the overlay is a preview,
    encoded with x264's :data:`~seedtrack.data.video.PREVIEW_PRESET`. Detection and drawing use
    ``workers`` threads, and with more than one the encoder a process of its own, started before
    tracking; the files are the same for any number.

    Each file is written whole or not at all, in that order, so an interruption keeps what was
    finished; an output folder made here and still empty is removed again.
    """
    with output_folder(out):
        # pandas, which writes the tables (a third of run's imports), loads in a thread beside
        # detection, whose threads leave part of a core free, rather than alone on one core.
        threading.Thread(target=importlib.import_module, args=("pandas",), daemon=True).start()
        found = detect_clip(clip, detection, workers=workers)
        detections = found.detections
        rows = detections.to_rows()
        write_table(out / "detections.csv", rows)
        # Grouped as `seedtrack track` groups detections.csv, so that run = detect + track; the
        # columns of the tracks are the processed frames, as the overlay and the writer take them.
        # The encoder's process starts beside tracking, which runs on one core.
        with VideoEncoder(out / "overlay.mp4", found.fps, workers, PREVIEW_PRESET) as encoder:
            tracks = track_frames(group_points(rows, clip, detections.frame_indices).frames, tracking)
            write_tracks(out / "tracks.csv", tracks, detections.frame_indices)
            _render(clip, tracks, detections, encoder, TRAIL, detection, workers)
    return detections, tracks
