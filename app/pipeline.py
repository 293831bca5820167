"""The run pipeline: frames -> detections -> tracks -> files and an overlay clip.

The layer between files and the library that every command and the Python API
(:mod:`seedtrack.api`) call: :func:`detect_clip` reads a clip for
:class:`seedtrack.detection.clip.ClipDetector`, :func:`group_points` and :func:`track_frames`
give points to :func:`seedtrack.tracking.linking.link_goa` (or another tracker) as ``seedtrack
track`` does. Frames are streamed twice (once to detect, once to draw) rather than held in memory, so the
clip's length does not bound what can be processed (with more than one worker, the last 256 MB of
frames decoded for detection are kept for the overlay and not decoded again).
"""

from __future__ import annotations

import collections
import contextlib
import dataclasses
import functools
import importlib
import itertools
import math
import os
import re
import sys
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterable, Iterator

import numpy as np

from seedtrack.data.csvio import write_table
from seedtrack.data.errors import DataError, warn
from seedtrack.data.depth import to_bgr8
from seedtrack.data.frames import IMAGE_SUFFIXES, FrameSource, open_frames, read_mask
from seedtrack.data.outputset import MANIFEST, RUN_FILES, output_set
from seedtrack.data.trackfile import write_tracks
from seedtrack.data.video import PREVIEW_CRF, PREVIEW_PRESET
from seedtrack.detection.background import temporal_median
from seedtrack.detection.blobs import BlobOptions, to_gray
from seedtrack.detection.choice import DetectorChoice
from seedtrack.detection.clip import BACKGROUND_FRAMES, DETECTORS, ClipDetector, Detections, background_spacing, detect_frames, grey_levels, temporal_background
from seedtrack.detection.roi import Circle, circle_mask
from seedtrack.tracking.tracks import Tracks

from .errors import OptionError, UsageError
from .outputs import refuse_replacing_inputs
from .points import TrackingSettings, group_points, localised, track_frames
from .parallel import VideoEncoder, read_ahead, threaded_map
from .drawing import FalseDetections, TrackLayer, View, annotate, track_legend
from .progress import progress_bar
from .wording import counted

__all__ = [
    "DETECTORS", "Detections", "DetectSettings", "ClipDetections",
    "detect_clip", "render_overlay", "run_pipeline",
]

# Past positions in each track's fading trail on the overlay of `run`.
TRAIL = 10
# Decoded frames waiting for detection: enough that decoding goes on while the first frame's
# decisions are made (a tenth of a second on a 640x512 dish, 30 frames' decoding), little enough
# for memory to stay flat.
_READ_AHEAD_BYTES = 64 * 2**20


_BLOB = BlobOptions()
_CIRCLE = re.compile(r"^\s*([-+0-9.eE]+)\s*,\s*([-+0-9.eE]+)\s*,\s*([-+0-9.eE]+)\s*$")
# BlobOptions' fields by the names of the options that set them.
_BLOB_FIELDS = {"min_area_px": "min_area", "max_area_px": "max_area"}


@dataclass(frozen=True)
class DetectSettings:
    """What the detector is asked to do on a clip: the options of ``seedtrack detect``.

    Attributes
    ----------
    detector : {"auto", "blob", "spot"}
        Threshold blobs (:func:`seedtrack.detection.blobs.detect_blobs`), Crocker-Grier spots
        (:func:`seedtrack.detection.spots.detect_spots`), or the one that suits the first frame.
    diameter : int or None
        Spot diameter, pixels, odd, >= 3; None measures it on the first frame.
    min_mass : float or None
        The spot detector's least mass (integrated brightness, grey levels times pixels); None
        sets it from the first frame's noise.
    snr : float or None
        The spot detector's signal-to-background ratio: the least mass is this many times the
        typical mass of the background's own maxima; None decides from the first frame.
    polarity, background, background_size, threshold, split
        As :class:`seedtrack.detection.blobs.BlobOptions` takes them; ``threshold`` may also be
        the text of a number.
    min_area, max_area : float or None
        Smallest and largest object, pixels (max_area None: 1% of the frame).
    roi : "auto", "none", Circle, (x, y, r), "X,Y,R", or path of a mask image
        Where to look; held as "auto", "none", a :class:`Circle` or a :class:`~pathlib.Path`.
    start, end, step : int
        0-based frames processed: ``range(start, end, step)``, end None for the clip's end.
    options : BlobOptions
        Made from the blob detector's settings (not an argument).

    Raises
    ------
    OptionError
        Naming the option that makes no sense.

    Examples
    --------
    >>> DetectSettings(threshold="25", roi="160,120,90").roi
    Circle(x=160.0, y=120.0, r=90.0)
    >>> DetectSettings(diameter=4)
    Traceback (most recent call last):
    ...
    seedtrack.errors.OptionError: diameter must be an odd number of pixels >= 3, got 4
    """

    detector: str = "auto"
    diameter: int | None = None
    min_mass: float | None = None
    snr: float | None = None
    polarity: str = _BLOB.polarity
    background: str = _BLOB.background
    background_size: float = _BLOB.background_size
    threshold: str | float = _BLOB.threshold
    min_area: float = _BLOB.min_area_px
    max_area: float | None = None
    roi: str | Circle | Path = "auto"
    split: bool = _BLOB.split
    start: int = 0
    end: int | None = None
    step: int = 1
    options: BlobOptions = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if self.detector not in DETECTORS:
            raise OptionError(f"detector must be one of {', '.join(DETECTORS)}, got {self.detector!r}", "detector")
        threshold = self.threshold
        if threshold not in ("otsu", "adaptive"):
            try:
                threshold = float(threshold)
            except (TypeError, ValueError):
                raise OptionError(f"threshold must be otsu, adaptive or a number of grey levels, got {self.threshold!r}", "threshold") from None
        if threshold == "adaptive" and self.detector == "spot":
            raise OptionError("threshold adaptive works with detector blob only", "threshold", "detector")
        if self.diameter is not None and (self.diameter < 3 or self.diameter % 2 == 0):
            raise OptionError(f"diameter must be an odd number of pixels >= 3, got {self.diameter}", "diameter")
        if self.min_mass is not None and not (math.isfinite(self.min_mass) and self.min_mass >= 0):
            raise OptionError(f"min_mass must be a finite number >= 0, got {self.min_mass:g}", "min_mass")
        if self.snr is not None and not (math.isfinite(self.snr) and self.snr > 0):
            raise OptionError(f"snr must be a finite number > 0, got {self.snr:g}", "snr")
        try:
            options = BlobOptions(
                polarity=self.polarity,
                background=self.background,
                background_size=self.background_size,
                threshold=threshold,
                min_area_px=self.min_area,
                max_area_px=self.max_area,
                split=self.split,
            )
        except ValueError as error:
            message = re.sub(r"^bad \w+: ", "", str(error))
            for blob_name, name in _BLOB_FIELDS.items():
                message = re.sub(rf"\b{blob_name}\b", name, message)
            raise OptionError(message, *(_BLOB_FIELDS.get(f.name, f.name) for f in dataclasses.fields(BlobOptions))) from None
        object.__setattr__(self, "options", options)
        object.__setattr__(self, "threshold", threshold)
        for name in ("start", "end", "step"):
            value = getattr(self, name)
            if value is not None and value < (1 if name == "step" else 0):
                raise OptionError(f"{name} must be {'>= 1' if name == 'step' else 'a frame index >= 0'}, got {value}", name)
        if self.end is not None and self.end <= self.start:
            raise OptionError(f"end ({self.end}) must come after start ({self.start})", "end", "start")
        object.__setattr__(self, "roi", _roi(self.roi))


def _roi(roi) -> str | Circle | Path:
    """The region of interest as :class:`DetectSettings` holds it."""
    if isinstance(roi, (tuple, list)) and len(roi) == 3:
        roi = Circle(*(float(value) for value in roi))
    if isinstance(roi, Circle):
        if not all(math.isfinite(value) for value in (roi.x, roi.y, roi.r)) or roi.r <= 0:
            raise OptionError(f"roi circle needs finite X,Y and a radius > 0, got {roi.x:g},{roi.y:g},{roi.r:g}", "roi")
        return roi
    if isinstance(roi, os.PathLike):
        roi = os.fspath(roi)
    if not isinstance(roi, str):
        raise OptionError(f"roi takes auto, none, a circle (x, y, r) in pixels, or a mask image file; got {roi!r}", "roi")
    if roi in ("auto", "none"):
        return roi
    circle = _CIRCLE.match(roi)
    if circle:
        x, y, r = (float(value) for value in circle.groups())
        if not all(math.isfinite(value) for value in (x, y, r)) or r <= 0:
            raise OptionError(f"roi circle needs finite X,Y and a radius > 0, got {roi!r}", "roi")
        return Circle(x, y, r)
    if not Path(roi).is_file():
        if Path(roi).suffix.lower() in IMAGE_SUFFIXES or "/" in roi or os.sep in roi:
            raise OptionError(f"roi {roi}: no such mask image file", "roi")
        raise OptionError(f"roi takes auto, none, a circle X,Y,R in pixels, or a mask image file; {roi!r} is none of these", "roi")
    return Path(roi)


@dataclass(frozen=True, eq=False)
class ClipDetections:
    """What :func:`detect_clip` found.

    Attributes
    ----------
    detections : Detections
    fps : float or None
        The clip's frame rate, frames per second (None for frames in memory).
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
    path: Path | Iterable[np.ndarray],
    settings: DetectSettings = DetectSettings(), preview_frame: int | None = None,
    say: Callable[[str], None] | None = print,
    workers: int = 1,
    keep: Callable[[int, np.ndarray], None] | None = None,
) -> ClipDetections:
    """Detect objects in every frame of a clip, with a progress bar
    (:class:`seedtrack.detection.clip.ClipDetector` on the frames read).

    The detector, chosen on the first frame, is said on one ``detector: ...`` line (``say``
    None: nothing is said).

    A video that breaks off part way keeps the frames decoded before, and one line on standard
    error says where it stopped.

    Parameters
    ----------
    path : Path or iterable of ndarray
        Video, image folder, glob pattern or TIFF stack; or frames in memory, each an (H, W)
        grey or (H, W, 3) BGR array of uint8, uint16 or float, read once (kept in memory with
        the temporal background).
    settings : DetectSettings
    preview_frame : int, optional
        0-based index of a processed frame to keep as :attr:`ClipDetections.preview`.
    workers : int
        Threads detecting frames (see :func:`seedtrack.parallel.threaded_map`); the result is
        the same for any number.
    keep : callable, optional
        Called with each processed frame's 0-based index and image as decoded, in order (in
        the decoding thread), so that a caller may keep frames rather than decode them again.

    Raises
    ------
    DataError
        If the clip or the mask cannot be read, the mask is of another size, or no frame can
        be read.
    UsageError
        If the preview frame is not among the processed frames.
    ValueError
        If a frame in memory is not an image, or of another size than the first, or there is
        none.
    """
    on_file = isinstance(path, (str, os.PathLike))
    opened = open_frames(path, start=settings.start, end=settings.end, step=settings.step) if on_file else _FramesInMemory(path, settings)
    with opened as source:
        last = settings.start + settings.step * source.frame_count if source.frame_count is not None else settings.end
        processed = range(settings.start, last if last is not None else sys.maxsize, settings.step)
        if preview_frame is not None and preview_frame not in processed:
            step = f" every {settings.step}" if settings.step > 1 else ""
            span = f"{processed.start}..{processed[-1]}{step}" if len(processed) else "none"
            raise UsageError(f"preview frame {preview_frame} is not among the frames processed ({span})")
        background = None
        if settings.options.background == "temporal":
            background = _temporal_background(path, settings, source) if on_file else source.background()
        # On a 4000 x 3000 frame the first frame's decisions take tens of seconds before the bar
        # first moves: they say on it what they measure meanwhile.
        detector = ClipDetector(
            settings.options, settings.detector, _given_roi(settings.roi, source.size), background, settings.diameter, settings.min_mass, settings.snr,
            progress=lambda step: bar.set_postfix_str(f"first frame: {step}"),
        )
        preview = None

        def decoded():
            nonlocal preview
            for index, image in source:
                if keep is not None:
                    keep(index, image)
                if index == preview_frame:
                    preview = to_bgr8(image, source.span).copy()
                # Both detectors see only the grey levels of an 8-bit colour frame: made here,
                # beside decoding, they are a third of the bytes to wait in the queue, so three
                # times the frames decode ahead while the first frame's decisions are made
                # (half a second at 1280x960).
                yield index, to_gray(image) if image.dtype == np.uint8 and image.ndim == 3 else image

        def counted_off(read):
            for number, item in enumerate(read):
                yield item
                if number == 0:
                    bar.set_postfix_str("", refresh=False)
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
        if detector.choice.spots is not None and detector.choice.spots.unusual:
            warn(str(path), detector.choice.spots.unusual)
        if source.stopped_early:
            print(f"seedtrack: {path}: {source.stopped_early}; keeping the {counted(detections.frame_indices.size, 'frame')} before it", file=sys.stderr)
        return ClipDetections(detections, source.fps, detector.roi, detector.circle, preview, detector.choice)


# Frame data the detectors take: 8 or 16 bits, or float (their range read from the first frame).
_FRAME_TYPES = (np.dtype(np.uint8), np.dtype(np.uint16), np.dtype(np.float32), np.dtype(np.float64))


class _FramesInMemory:
    """Frames given as arrays, selected and read as :func:`seedtrack.data.frames.open_frames`
    reads a clip (no frame rate, length or range known beforehand)."""

    fps = None
    frame_count = None
    span = None
    stopped_early = None

    def __init__(self, frames: Iterable[np.ndarray], settings: DetectSettings) -> None:
        self._checked = self._check(itertools.islice(enumerate(frames), settings.start, settings.end, settings.step))
        first = next(self._checked, None)
        if first is None:
            raise ValueError("no frame to detect in (after start, end and step)")
        self.size = (first[1].shape[1], first[1].shape[0])
        self._frames = itertools.chain([first], self._checked)
        if settings.options.background == "temporal":
            self._frames = list(self._frames)

    def _check(self, selected: Iterator[tuple[int, np.ndarray]]) -> Iterator[tuple[int, np.ndarray]]:
        shape = None
        for index, image in selected:
            image = np.asarray(image)
            if image.dtype not in _FRAME_TYPES or not (image.ndim == 2 or (image.ndim == 3 and image.shape[2] == 3)):
                raise ValueError(
                    f"frame {index} must be an (H, W) or (H, W, 3) array of uint8, uint16 or float, got {image.dtype} of shape {image.shape}"
                )
            if shape is not None and image.shape[:2] != shape:
                raise ValueError(f"frame {index} is {image.shape[1]}x{image.shape[0]}, the first {shape[1]}x{shape[0]}")
            shape = image.shape[:2]
            yield index, image

    def background(self) -> np.ndarray:
        """:func:`seedtrack.detection.clip.temporal_background` of the frames selected."""
        return temporal_background([image for _, image in self._frames])

    def __iter__(self) -> Iterator[tuple[int, np.ndarray]]:
        return iter(self._frames)

    def __enter__(self) -> "_FramesInMemory":
        return self

    def __exit__(self, *exc_info) -> None:
        pass


def _frames_ahead(frame_bytes: int) -> int:
    """How many frames of ``frame_bytes`` each may wait decoded: about 64 MB, between 4 and 64."""
    return int(np.clip(_READ_AHEAD_BYTES // max(frame_bytes, 1), 4, 64))


def _unused_options(settings: DetectSettings, choice: DetectorChoice) -> str:
    """What to add to the ``detector:`` line when options were given for the detector that did
    not run, so that they are never ignored silently ("" when there are none)."""
    defaults = BlobOptions()
    if choice.spots is None:
        given = [option for option, value in (("--min-mass", settings.min_mass), ("--snr", settings.snr)) if value is not None]
        return f"; {', '.join(given)} {'apply' if len(given) > 1 else 'applies'} to the spot detector only (not used)" if given else ""
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


def _temporal_background(path: Path, settings: DetectSettings, source: FrameSource) -> np.ndarray:
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
    selection: DetectSettings | None = None,
    workers: int = 1,
) -> None:
    """Write an H.264 clip of the input with the tracks drawn over it (see :mod:`seedtrack.drawing`),
    of the frames ``selection.start``, ``end`` and ``step`` select, if given.

    Detections that no track holds are marked as false detections. ``workers`` threads draw
    and, with more than one, the encoder has a process of its own; the file is the same for any
    number.
    """
    with VideoEncoder(out, fps, workers) as encoder, _overlay_frames(path, selection) as frames:
        _render(frames, tracks, detections, encoder, trail, workers)


# Frames kept from detection's decoding for the overlay, with more than one worker: tracking is
# one thread's work, and decoding the overlay's frames again beside it took the other core for
# the whole of tracking (a 640x512 dish: 300 frames, about 1.1 s of CPU). About 270 frames of
# 640x512 BGR; larger frames, fewer.
_KEPT_FOR_OVERLAY_BYTES = 256 * 2**20


class _LastFrames:
    """The last ``(frame_index, image)`` pairs handed to it, as many as ``limit`` bytes hold
    (``dropped`` says whether earlier ones were let go)."""

    def __init__(self, limit: int) -> None:
        self.frames: collections.deque = collections.deque()
        self.dropped = False
        self._limit, self._bytes = limit, 0

    def __call__(self, index: int, image: np.ndarray) -> None:
        self.frames.append((index, image))
        self._bytes += image.nbytes
        while self._bytes > self._limit:
            self._bytes -= self.frames.popleft()[1].nbytes
            self.dropped = True

    def taken(self) -> Iterator[tuple[int, np.ndarray]]:
        """The frames kept, each let go once taken."""
        while self.frames:
            yield self.frames.popleft()


@contextlib.contextmanager
def _overlay_frames(path: Path, selection: DetectSettings | None, kept: _LastFrames | None = None) -> Iterator[tuple[FrameSource, Iterator[tuple[int, np.ndarray]]]]:
    """The clip opened over the selected frames and ``(frame_index, image)`` pairs decoding a
    few ahead in a thread from now on; with ``kept``, only the frames before those kept are
    decoded, and the kept ones follow. Leaving stops the thread and closes the clip."""
    span = {} if selection is None else {"start": selection.start, "end": selection.end, "step": selection.step}
    with open_frames(path, **span) as source:
        frames: Iterable[tuple[int, np.ndarray]] = source
        if kept is not None:
            first = kept.frames[0][0] if kept.frames else sys.maxsize
            before = itertools.takewhile(lambda frame: frame[0] < first, source) if kept.dropped else ()
            frames = itertools.chain(before, kept.taken())
        with read_ahead(frames) as read:
            yield source, read


def _render(frames: tuple[FrameSource, Iterator[tuple[int, np.ndarray]]], tracks: Tracks, detections: Detections, encoder: VideoEncoder, trail: int, workers: int) -> None:
    """:func:`render_overlay` of frames from :func:`_overlay_frames` into an encoder already started."""
    source, read = frames
    view = View.of(source.size)
    layer = TrackLayer(tracks, view, trail=trail, frame_indices=detections.frame_indices)
    rows = detections.to_rows()
    false = FalseDetections(rows["frame"], rows["x"], rows["y"], tracks, view, frame_indices=detections.frame_indices)
    draw = functools.partial(_annotate_pair, span=source.span, view=view, layers=[layer], false_detections=false, legend=track_legend(True))
    with progress_bar(source.frame_count, "rendering") as bar:
        encoder.write(threaded_map(draw, read, workers), progress=bar)


def _annotate_pair(frame: tuple[int, np.ndarray], span: tuple[float, float], **options) -> np.ndarray:
    """:func:`seedtrack.drawing.annotate` of a frame source's ``(frame_index, image)``, shown
    from the source's ``span`` (:func:`seedtrack.data.depth.to_bgr8`)."""
    index, image = frame
    return annotate(to_bgr8(image, span), index, **options)


def run_pipeline(
    clip: Path, out: Path, detection: DetectSettings = DetectSettings(), tracking: TrackingSettings = TrackingSettings(), workers: int = 1, verbose: bool = False
) -> tuple[Detections, Tracks]:
    """Detect, track, and write ``detections.csv``, ``tracks.csv`` and ``overlay.mp4`` to ``out``.

    Detection is :func:`detect_clip`, tracking :func:`track_frames` (``verbose``: the motion in
    detail); the overlay is a preview, encoded with x264's
    :data:`~seedtrack.data.video.PREVIEW_PRESET` at :data:`~seedtrack.data.video.PREVIEW_CRF`. Detection and drawing use
    ``workers`` threads, and with more than one the encoder a process of its own, started before
    tracking, and the overlay takes the last 256 MB of frames detection decoded rather than
    decoding them again; the files are the same for any number.

    The three files and ``manifest.json`` replace an earlier run's as one set
    (:func:`seedtrack.data.outputset.output_set`): stopped at any point, the folder holds the
    earlier set or this one, never a mix; an output folder made here and still empty is removed again.
    """
    inputs = [clip, *([detection.roi] if isinstance(detection.roi, Path) else [])]
    refuse_replacing_inputs(inputs, [Path(out) / name for name in (*RUN_FILES, MANIFEST)])
    with output_set(out, "seedtrack run", inputs) as files:
        # Named now: a folder in a file's place is found before the clip is read, not after.
        paths = {name: files.path(name) for name in RUN_FILES}
        # pandas, which writes the tables (a third of run's imports), loads in a thread beside
        # detection, whose threads leave part of a core free, rather than alone on one core.
        threading.Thread(target=importlib.import_module, args=("pandas",), daemon=True).start()
        kept = _LastFrames(_KEPT_FOR_OVERLAY_BYTES) if workers > 1 else None
        found = detect_clip(clip, detection, workers=workers, keep=kept)
        detections = found.detections
        rows = detections.to_rows()
        write_table(paths["detections.csv"], rows)
        # Grouped as `seedtrack track` groups detections.csv, so that run = detect + track; the
        # columns of the tracks are the processed frames, as the overlay and the writer take them.
        # The encoder's process starts, and the overlay's first frames decode, beside tracking,
        # which runs on one core.
        with VideoEncoder(paths["overlay.mp4"], found.fps, workers, PREVIEW_PRESET, PREVIEW_CRF) as encoder, _overlay_frames(clip, detection, kept) as frames:
            points = group_points(rows, clip, detections.frame_indices)
            tracks = track_frames(points.frames, localised(tracking, points), verbose=verbose)
            write_tracks(paths["tracks.csv"], tracks, detections.frame_indices)
            _render(frames, tracks, detections, encoder, TRAIL, workers)
    return detections, tracks
