"""Detection over a whole clip: frames in, one table of measurements per frame out.

Some decisions hold for a clip, not a frame: whether objects are darker or lighter than the
background, the region of interest (the dish), and which detector suits the footage (blobs for
seeds, spots for beads; :func:`seedtrack.detection.choice.choose_detector`) with the spot size
and least mass. They are made once, on the first frame, so that a frame with little in it cannot
flip them; :class:`ClipDetector` holds them. Nothing here
reads files: :func:`seedtrack.pipeline.detect_clip` is the layer that reads a clip and calls this.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, replace
from typing import Callable, Iterable, Iterator, Sequence

import cv2
import numpy as np

from seedtrack.data.depth import to_uint8, value_range

from .background import temporal_median
from .blobs import MEASUREMENT_COLUMNS, BlobOptions, background_of, choose_polarity, detect_blobs, to_gray
from .choice import DETECTOR_NAMES, DetectorChoice, choose_detector
from .roi import Circle, circle_mask, dish_mask
from .spots import as_float_gray, detect_spots

DETECTORS = DETECTOR_NAMES
# Frames whose per-pixel median is a static scene's background: spread over the clip.
BACKGROUND_FRAMES = 64


def background_spacing(frame_count: int | None) -> int:
    """Every how many processed frames one is taken for the temporal background, so that up to
    :data:`BACKGROUND_FRAMES` of them spread over the clip (``frame_count`` None: unknown)."""
    return max(1, math.ceil((frame_count or BACKGROUND_FRAMES) / BACKGROUND_FRAMES))


def temporal_background(frames: Sequence[np.ndarray]) -> np.ndarray:
    """The per-pixel median of up to 64 of ``frames`` spread evenly over them.

    Parameters
    ----------
    frames : sequence of ndarray, each (H, W) or (H, W, 3) BGR
        uint8, or deeper: mapped to 8 bits as :class:`ClipDetector` maps them (see
        :func:`grey_levels`).

    Returns
    -------
    ndarray of uint8, shape (H, W)
    """
    return temporal_median(grey_levels(frames[:: background_spacing(len(frames))]), BACKGROUND_FRAMES)


def grey_levels(frames: Iterable[np.ndarray]) -> Iterator[np.ndarray]:
    """The uint8 (H, W) grey levels of each frame, deeper data mapped from the range of the first
    frame's (:func:`seedtrack.data.depth.value_range`), as :class:`ClipDetector` maps them.

    Example
    -------
    >>> [g.tolist() for g in grey_levels([np.array([[0, 4095]], np.uint16), np.array([[0, 5000]], np.uint16)])]
    [[[0, 255]], [[0, 255]]]
    """
    span = None
    for image in frames:
        span = value_range(image) if span is None else span
        yield to_gray(image if image.dtype == np.uint8 else to_uint8(image, span))


class ClipDetector:
    """Detect objects frame after frame, deciding polarity and region on the first frame.

    Parameters
    ----------
    options : BlobOptions
        Polarity "auto" is decided on the first frame (:func:`seedtrack.detection.blobs.choose_polarity`).
    detector : {"auto", "blob", "spot"}
        Threshold blobs (:func:`seedtrack.detection.blobs.detect_blobs`), Crocker-Grier spots
        (:func:`seedtrack.detection.spots.detect_spots`), or the one that suits the first frame.
    diameter : int, optional
        Spot diameter, pixels, odd; measured on the first frame when not given.
    min_mass : float, optional
        The spot detector's least mass (integrated brightness, data units times pixels, as
        :func:`seedtrack.detection.choice.describe` prints it); set from the first frame's
        noise when not given.
    snr : float, optional
        The spot detector's signal-to-background ratio (see
        :func:`seedtrack.detection.choice.choose_detector`); ``min_mass`` wins when both are given.
    roi : "auto", "none", Circle or ndarray of uint8 (H, W)
        "auto": the dish found on the first frame, or the whole frame if there is none clearly;
        "none": the whole frame; a circle in pixels; a mask, nonzero inside.
    background : ndarray of uint8, shape (H, W), optional
        The background image when ``options.background`` is "temporal".
    progress : callable, optional
        Called with a few words (such as ``"measuring the spots' size"``) as each of the first
        frame's once-per-clip decisions begins, and with ``"detecting"`` when they are made: on
        a 4000 x 3000 frame they take tens of seconds. Not kept after the first frame.

    Attributes
    ----------
    options : BlobOptions
        After the first frame, with the polarity decided.
    roi : ndarray of uint8 or None
        The region used (255 inside), None for the whole frame; known after the first frame.
    circle : Circle or None
        The dish found or the circle given.
    choice : DetectorChoice or None
        The detector that runs, its settings and why; known after the first frame.

    Examples
    --------
    A dark disc of radius 3 pixels on a light frame:

    >>> import numpy as np
    >>> frame = np.full((60, 80), 200, np.uint8)
    >>> yy, xx = np.mgrid[:60, :80]
    >>> frame[(xx - 30) ** 2 + (yy - 20) ** 2 <= 9] = 40
    >>> detector = ClipDetector(roi="none")
    >>> found = detector.detect(frame)
    >>> print(detector.options.polarity, round(float(found["x"][0]), 1), round(float(found["y"][0]), 1))
    dark 30.0 20.0
    """

    def __init__(
        self,
        options: BlobOptions = BlobOptions(),
        detector: str = "auto",
        roi: str | Circle | np.ndarray = "auto",
        background: np.ndarray | None = None,
        diameter: int | None = None,
        min_mass: float | None = None,
        snr: float | None = None,
        progress: Callable[[str], None] | None = None,
    ) -> None:
        if detector not in DETECTORS:
            raise ValueError(f"detector must be one of {', '.join(DETECTORS)}, got {detector!r}")
        if min_mass is not None and not (math.isfinite(min_mass) and min_mass >= 0):
            raise ValueError(f"min_mass must be finite and >= 0, got {min_mass:g}")
        if snr is not None and not (math.isfinite(snr) and snr > 0):
            raise ValueError(f"snr must be finite and > 0, got {snr:g}")
        if isinstance(roi, str) and roi not in ("auto", "none"):
            raise ValueError(f"roi must be 'auto', 'none', a Circle or a mask, got {roi!r}")
        self.options = options
        self.circle = roi if isinstance(roi, Circle) else None
        self.roi = roi if isinstance(roi, np.ndarray) else None
        self._pending_roi = roi
        self._detector, self._diameter, self._min_mass, self._snr = detector, diameter, min_mass, snr
        self.choice: DetectorChoice | None = None
        self._background = background
        self._progress = progress
        self._first = True

    def detect(self, image: np.ndarray) -> dict[str, np.ndarray]:
        """The measurements of one frame (see :func:`seedtrack.detection.blobs.detect_blobs` and
        :func:`seedtrack.detection.spots.detect_spots`).

        Parameters
        ----------
        image : ndarray, shape (H, W) or (H, W, 3) BGR
            uint8, or deeper (uint16, float): mapped to 8 bits for blobs by the range of the
            first frame's data, kept as it is for spots.
        """
        if image.dtype.kind == "f" and not np.isfinite(image).all():
            raise ValueError("the frame holds NaN or infinite pixels: nothing can be measured against them")
        if self._first:
            # Deeper data keep one map to 8 bits for the whole clip, from their range.
            self._span = value_range(image)
        gray = to_gray(image if image.dtype == np.uint8 else to_uint8(image, self._span))
        # Spots are found on the data's own values (of 8-bit frames, the grey levels just
        # made), unless a temporal background (8-bit) is taken off first.
        native = image if self._background is None and image.dtype != np.uint8 else gray
        if self._first:
            self._decide(gray, native)
            self._first = False
            if self._progress is not None:
                self._progress("detecting")
            # A hook bound to a progress bar would stop the decided detector being pickled.
            self._progress = None
        if self.choice.spots is not None:
            return detect_spots(native, self.choice.spots, roi=self.roi, background=self._background)
        return detect_blobs(gray, self.options, background=self._background, roi=self.roi, roi_box=self._roi_box)

    def _decide(self, gray: np.ndarray, native: np.ndarray) -> None:
        step = self._progress or (lambda _: None)
        if isinstance(self._pending_roi, Circle):
            self.roi = circle_mask((gray.shape[1], gray.shape[0]), self._pending_roi)
        elif isinstance(self._pending_roi, str) and self._pending_roi == "auto":
            step("looking for a dish")
            self.roi, self.circle = dish_mask(gray)
        if self.roi is not None and self.roi.shape != gray.shape:
            raise ValueError(f"the region of interest is {self.roi.shape[1]}x{self.roi.shape[0]}, the frame {gray.shape[1]}x{gray.shape[0]}")
        # Found once: at 1280x960 finding it took a third as long as detecting a frame.
        self._roi_box = cv2.boundingRect(self.roi) if self.roi is not None else None
        if self.options.polarity == "auto":
            step("telling dark objects from light")
            self.options = replace(self.options, polarity=choose_polarity(gray, background_of(gray, self.options, self._background), self.roi))
        scene = as_float_gray(native) if self._background is None else gray.astype(np.float32) - self._background
        self.choice = choose_detector(
            scene, self.options.polarity, detector=self._detector, diameter=self._diameter, roi=self.roi, min_mass=self._min_mass, snr=self._snr, progress=step
        )


# Frames whose columns are joined into one array each at a time while a clip is detected: a
# long clip then holds a few arrays per column instead of one per column and frame (at 20,000
# frames those small arrays and the heap around them were tens of megabytes).
_GATHERED_FRAMES = 1024


@dataclass(frozen=True, eq=False)
class Detections:
    """Measurements of every processed frame, as one table, frame after frame.

    Attributes
    ----------
    frame_indices : ndarray of int, shape (n_frames,)
        0-based index in the clip of each processed frame.
    counts : ndarray of int, shape (n_frames,)
        Detections in each processed frame.
    table : dict of str to ndarray
        ``x``, ``y`` (pixels), ``area`` (pixels) and the detector's other columns of
        ``detections.csv``, one entry per detection: those of frame ``frame_indices[0]`` first.

    Example
    -------
    >>> import numpy as np
    >>> found = Detections.gathered([4, 5], [{name: np.array([1.0, 2.0]) for name in MEASUREMENT_COLUMNS},
    ...                                     {name: np.array([3.0]) for name in MEASUREMENT_COLUMNS}])
    >>> found.counts.tolist(), found.frame(1)["x"].tolist(), found.to_rows()["frame"].tolist()
    ([2, 1], [3.0], [4, 4, 5])
    """

    frame_indices: np.ndarray
    counts: np.ndarray
    table: dict[str, np.ndarray]

    @classmethod
    def gathered(cls, frame_indices: Iterable[int], frames: Iterable[dict[str, np.ndarray]]) -> "Detections":
        """The detections of ``frames`` (each processed frame's detector columns, consumed one at
        a time, before ``frame_indices`` is read)."""
        names = list(dict.fromkeys(("x", "y", "area", *MEASUREMENT_COLUMNS)))
        counts: list[int] = []
        parts: dict[str, list[np.ndarray]] = {name: [] for name in names}
        pending: list[dict[str, np.ndarray]] = []

        def join() -> None:
            for name in names:
                parts[name].append(np.concatenate([columns[name] for columns in pending]))
            pending.clear()

        for columns in frames:
            counts.append(len(columns["x"]))
            pending.append({name: columns[name] for name in names})
            if len(pending) == _GATHERED_FRAMES:
                join()
        if pending:
            join()
        table = {name: np.concatenate(chunks) if chunks else np.empty(0) for name, chunks in parts.items()}
        return cls(np.array(list(frame_indices), dtype=np.int64), np.array(counts, dtype=np.int64), table)

    def frame(self, column: int) -> dict[str, np.ndarray]:
        """The columns of processed frame ``column`` (0-based among the processed frames)."""
        end = int(self.counts[: column + 1].sum())
        return {name: values[end - int(self.counts[column]) : end] for name, values in self.table.items()}

    def to_rows(self) -> dict[str, np.ndarray]:
        """Columns of ``detections.csv``: frame, x, y, area, then the detector's other columns."""
        return {"frame": np.repeat(self.frame_indices, self.counts).astype(np.int64), **self.table}


def detect_frames(
    frames: Iterable[tuple[int, np.ndarray]],
    detector: ClipDetector,
    map_frames: Callable[[Callable, Iterable[np.ndarray]], Iterable[dict[str, np.ndarray]]] = map,
) -> Detections:
    """Run ``detector`` on ``(frame index, image)`` pairs, in order.

    Parameters
    ----------
    frames : iterable of (int, ndarray)
        0-based frame index and image.
    detector : ClipDetector
        Decides polarity, region and detector on the first frame, here; the other frames are
        then independent of each other.
    map_frames : callable
        ``map_frames(function, images)`` yields ``function(image)`` for each image in order, such
        as the built-in ``map`` or a process pool's ordered map (``function`` is picklable once
        the first frame is decided).

    Examples
    --------
    >>> import numpy as np
    >>> blank = np.full((40, 40), 128, np.uint8)
    >>> detect_frames(enumerate([blank, blank]), ClipDetector(roi="none")).frame_indices.tolist()
    [0, 1]
    """
    frames = iter(frames)
    first = next(frames, None)
    if first is None:
        return Detections.gathered([], [])
    indices = [first[0]]
    columns = [detector.detect(first[1])]

    def rest():
        for index, image in frames:
            indices.append(index)
            # Both detectors see only the grey levels of an 8-bit colour frame: made here, they
            # are a third of the bytes to hand to a worker process.
            yield to_gray(image) if image.dtype == np.uint8 and image.ndim == 3 else image

    return Detections.gathered(indices, itertools.chain(columns, map_frames(detector.detect, rest())))


__all__ = ["DETECTORS", "BACKGROUND_FRAMES", "ClipDetector", "Detections", "background_spacing", "detect_frames", "grey_levels", "temporal_background"]
