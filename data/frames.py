"""Stream frames from a video, an image folder, a glob pattern or a multi-page TIFF.

Every source yields ``(frame_index, image)`` one frame at a time: ``frame_index`` is the 0-based
index in the original clip, ``image`` the frame at its own depth, so that a file and the same
frames handed to :func:`seedtrack.detect` as arrays are detected alike:

- 8-bit data (images, and video of 8 bits a component): a uint8 (height, width, 3) BGR array
  (OpenCV layout);
- deeper data (16-bit, float TIFF or PNG): the values as stored, uint16, float32 or float64
  (other number types as float32), (height, width) for grey, (height, width, 3) BGR for colour;
  an alpha channel is dropped. Video of more bits a component (10-bit H.264, 16-bit grey FFV1)
  is decoded to uint16, grey (height, width) or BGR (height, width, 3).

Drawing needs 8 bits: :attr:`FrameSource.span` is the source's range of values, read from its
first frame (:func:`seedtrack.data.depth.value_range`: 0..4095 for 12-bit data in 16-bit
words, 0..1 for float images within it), and :func:`seedtrack.data.depth.to_bgr8` maps any
frame of it from that range (:meth:`FrameSource.shown` yields the frames so mapped), so that a
frame's own brightness does not stretch it.
"""

from __future__ import annotations

import abc
import glob
import os
import re
from pathlib import Path
from typing import Iterator

import av
import cv2
import numpy as np

from .depth import to_bgr8, value_range
from .errors import DataError
from .video import ffmpeg_reason, open_container, video_info

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp")
TIFF_SUFFIXES = (".tif", ".tiff")
DEFAULT_IMAGE_FPS = 25.0

Frame = tuple[int, np.ndarray]


class FrameSource:
    """Frames of one clip between ``start`` and ``end``, read lazily; see :func:`open_frames`.

    Attributes
    ----------
    path : Path or str
        The video, folder, TIFF or glob pattern given.
    fps : float
        Frames per second (from the video; 25.0 for images).
    frame_count : int or None
        Number of frames iteration will yield if the source is intact; None if unknown.
    clip_length : int or None
        Frames in the whole clip if the source vouches for the count (not an estimate), else None.
    size : tuple of int
        (width, height) in pixels.
    span : tuple of float
        (low, high): the values that stand for black and white in this clip, as
        :func:`seedtrack.data.depth.to_bgr8` takes it to show a frame: for images, from the
        first frame (:func:`seedtrack.data.depth.value_range`; (0.0, 255.0) for 8-bit data);
        for video, (0.0, 255.0), or (0.0, 65535.0) for video decoded to 16 bits.
    stopped_early : str or None
        After iteration: None, or why it ended before the end of the clip, e.g.
        ``"decoding stopped at frame 57: <reason>"``.
    """

    def __init__(self, path, reader: "_Reader", start: int, end: int | None, step: int) -> None:
        self.path = path
        self._reader = reader
        self._start, self._step = start, step
        # Only a count the source vouches for may cut reading short; an estimate might drop
        # the last frames.
        self._stop = end if not reader.exact else min(reader.length, end if end is not None else reader.length)
        if reader.exact and start >= reader.length:
            raise DataError(path, f"start {start} is past the last frame ({reader.length - 1})")
        self.fps = reader.fps
        self.size = reader.size
        self.span = reader.span
        self.frame_count = _count(start, end, step, reader.length)
        self.clip_length = reader.length if reader.exact else None
        self.stopped_early: str | None = None

    def __iter__(self) -> Iterator[Frame]:
        self.stopped_early = None
        for index, image, problem in self._reader.read(self._start, self._stop, self._step):
            if problem is not None:
                self.stopped_early = f"decoding stopped at frame {index}: {problem}"
                return
            yield index, image

    def shown(self) -> Iterator[Frame]:
        """Iterate as ``(frame_index, picture)``, each frame as drawing takes it: uint8 (H, W, 3)
        BGR, mapped from :attr:`span` (:func:`seedtrack.data.depth.to_bgr8`)."""
        for index, image in self:
            yield index, to_bgr8(image, self.span)

    def close(self) -> None:
        """Release the open file, if any; iterating again reopens it."""
        self._reader.close()

    def __enter__(self) -> "FrameSource":
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()


def open_frames(path: str | os.PathLike, *, start: int = 0, end: int | None = None, step: int = 1) -> FrameSource:
    """Open a clip for streaming.

    Parameters
    ----------
    path : path-like
        A video file PyAV can read (mp4, avi, mov, mkv, ...); a folder of images (png, jpg,
        jpeg, tif, tiff, bmp; natural order, so ``img2`` comes before ``img10``); a glob
        pattern such as ``"frames/*.png"``; a single image; or a (multi-page) TIFF.
    start : int
        First 0-based frame index to yield.
    end : int, optional
        Frame index to stop before (exclusive); past the end of the clip means the end.
    step : int
        Yield every ``step``-th frame from ``start``.

    Returns
    -------
    FrameSource
        Iterable of ``(frame_index, image)``, each image at the data's own depth (see the
        module's description); a context manager.

    Raises
    ------
    DataError
        If the path does not exist, is not a readable video or image, a folder or pattern
        holds no images, or start/end/step make no sense.

    Example
    -------
    A 12-bit frame in a 16-bit TIFF comes as it is stored, and is shown from its range:

    >>> import cv2, numpy as np, tempfile
    >>> from seedtrack.data.depth import to_bgr8
    >>> path = tempfile.mkdtemp() + "/frame.tif"
    >>> _ = cv2.imwrite(path, np.array([[0, 4095]], np.uint16))
    >>> with open_frames(path) as source:
    ...     (index, image), = source
    ...     print(index, image.dtype, image.tolist(), source.span, to_bgr8(image, source.span)[0, 1].tolist())
    0 uint16 [[0, 4095]] (0.0, 4095.0) [255, 255, 255]
    """
    _check_arguments(path, start, end, step)
    return FrameSource(path, _reader_for(path), start, end, step)


def _check_arguments(path, start, end, step) -> None:
    def is_int(value) -> bool:
        return isinstance(value, (int, np.integer)) and not isinstance(value, bool)

    if not is_int(start) or start < 0:
        raise DataError(path, f"start must be a frame index >= 0, got {start!r}")
    if end is not None and (not is_int(end) or end <= start):
        raise DataError(path, f"end must be a frame index after start ({start}), got {end!r}")
    if not is_int(step) or step < 1:
        raise DataError(path, f"step must be a whole number >= 1, got {step!r}")


def _count(start: int, end: int | None, step: int, length: int | None) -> int | None:
    if length is None:
        return None
    return len(range(start, length if end is None else min(end, length), step))


def _reader_for(path) -> "_Reader":
    text = os.fspath(path)
    target = Path(text)
    if target.is_dir():
        return _ImageListReader(target, _images_in_folder(target))
    if target.is_file():
        suffix = target.suffix.lower()
        if suffix in TIFF_SUFFIXES:
            return _TiffReader(target)
        if suffix in IMAGE_SUFFIXES:
            return _ImageListReader(target, [target])
        return _VideoReader(target)
    if glob.has_magic(text):
        files = [Path(name) for name in glob.glob(text) if Path(name).suffix.lower() in IMAGE_SUFFIXES]
        if not files:
            raise DataError(path, "no images (png, jpg, tif) match this pattern")
        return _ImageListReader(path, sorted(files, key=_natural_key))
    raise DataError(path, "no such file or folder")


def _images_in_folder(folder: Path) -> list[Path]:
    files = [entry for entry in folder.iterdir() if entry.is_file() and entry.suffix.lower() in IMAGE_SUFFIXES]
    if not files:
        raise DataError(folder, "no images (png, jpg, tif) in folder")
    return sorted(files, key=_natural_key)


def _natural_key(path: Path) -> tuple:
    """Sort key that compares digit runs as numbers, so ``img2`` < ``img10``."""
    # re.split with a group alternates text and digits starting with text, so keys of any two
    # names hold the same type at each position and compare without error.
    parts = re.split(r"(\d+)", path.name.lower())
    return tuple(int(part) if i % 2 else part for i, part in enumerate(parts))


class _Reader(abc.ABC):
    """A source backend: ``length`` (frames, or None), ``exact``, ``fps``, ``size``, ``span`` and ``read``."""

    length: int | None
    exact: bool = True
    fps: float
    size: tuple[int, int]
    span: tuple[float, float] = (0.0, 255.0)

    @abc.abstractmethod
    def read(self, start: int, stop: int | None, step: int) -> Iterator[tuple[int, np.ndarray | None, str | None]]:
        """Yield ``(index, image, None)`` for index in range(start, stop, step), up to a last
        ``(index, None, problem)`` if the source breaks off at ``index``."""

    def close(self) -> None:
        """Release open files."""


class _VideoReader(_Reader):
    def __init__(self, path: Path) -> None:
        self.path = path
        self._container = open_container(path)
        stream = self._container.streams.video[0]
        info = video_info(stream)
        self.length, self.exact, self.fps, self.size = info.frame_count, info.exact, info.fps, info.size
        self._format = _decoded_format(stream.format)
        # The decoder scales deeper video to the whole 16 bits, as it scales it to 8 for bgr24.
        self.span = (0.0, 255.0) if self._format == "bgr24" else (0.0, 65535.0)
        self._used = False

    def read(self, start, stop, step):
        # Each pass decodes from a fresh container: seeking back is not exact in every format.
        if self._used or self._container is None:
            self.close()
            self._container = open_container(self.path)
        self._used = True
        stream = self._container.streams.video[0]
        stream.thread_type = "AUTO"
        index = 0
        try:
            # Decoding from the start rather than seeking keeps frame indices exact whatever
            # the container's timestamps; frames not wanted are decoded but not converted.
            for frame in self._container.decode(stream):
                if stop is not None and index >= stop:
                    return
                if (frame.width, frame.height) != self.size:
                    # A stream may change size part way (joined recordings); its frames are
                    # then no longer of the clip the first frame's decisions were made on.
                    yield index, None, f"frame {index} is {frame.width}x{frame.height}, the first frames {self.size[0]}x{self.size[1]}"
                    return
                if index >= start and (index - start) % step == 0:
                    yield index, frame.to_ndarray(format=self._format), None
                index += 1
        except av.FFmpegError as error:
            if index == 0:
                raise DataError(self.path, f"cannot decode this video ({ffmpeg_reason(error)})") from None
            yield index, None, ffmpeg_reason(error)
            return
        if self.exact and index < self.length:
            yield index, None, f"the file ends before the {self.length} frames its header lists"

    def close(self) -> None:
        if self._container is not None:
            self._container.close()
            self._container = None


def _decoded_format(video_format) -> str:
    """The pixel format frames of a video in ``video_format`` are decoded to: 8-bit BGR, or for
    more bits a component 16-bit grey or BGR, so that 10- and 12-bit video keeps its depth."""
    components = list(video_format.components) if video_format is not None else []
    if not components or max(component.bits for component in components) <= 8:
        return "bgr24"
    return "gray16le" if len(components) == 1 else "bgr48le"


class _ImageListReader(_Reader):
    def __init__(self, path, files: list[Path]) -> None:
        self.path = path
        self._files = files
        first = _read_image(files[0])
        if first is None:
            raise DataError(files[0], "not an image this program can read")
        first = _as_frame(first)
        self.span, self._dtype = value_range(first), first.dtype
        self.length = len(files)
        self.fps = DEFAULT_IMAGE_FPS
        self.size = (first.shape[1], first.shape[0])

    def read(self, start, stop, step):
        for index in range(start, len(self._files) if stop is None else stop, step):
            image = _as_frame(_read_image(self._files[index]))
            problem = _image_problem(image, self.size, self._dtype, self._files[index].name)
            if problem:
                yield index, None, problem
                return
            yield index, image, None


class _TiffReader(_Reader):
    """Pages of one TIFF, read one at a time so that a long stack never sits in memory."""

    def __init__(self, path: Path) -> None:
        self.path = path
        try:
            self.length = cv2.imcount(str(path))
        except cv2.error:
            self.length = 0
        first = self._page(0) if self.length > 0 else None
        if first is None:
            raise DataError(path, "not a TIFF this program can read")
        first = _as_frame(first)
        self.span, self._dtype = value_range(first), first.dtype
        self.fps = DEFAULT_IMAGE_FPS
        self.size = (first.shape[1], first.shape[0])

    def _page(self, index: int) -> np.ndarray | None:
        ok, pages = cv2.imreadmulti(str(self.path), index, 1, flags=cv2.IMREAD_UNCHANGED)
        return pages[0] if ok and pages else None

    def read(self, start, stop, step):
        for index in range(start, self.length if stop is None else stop, step):
            image = _as_frame(self._page(index))
            problem = _image_problem(image, self.size, self._dtype, f"page {index}")
            if problem:
                yield index, None, problem
                return
            yield index, image, None


def _read_image(path: Path) -> np.ndarray | None:
    return cv2.imread(str(path), cv2.IMREAD_UNCHANGED)


def _image_problem(image: np.ndarray | None, size: tuple[int, int], dtype: np.dtype, name: str) -> str | None:
    if image is None:
        return f"cannot read {name}"
    if (image.shape[1], image.shape[0]) != size:
        return f"{name} is {image.shape[1]}x{image.shape[0]}, the first frame {size[0]}x{size[1]}"
    if image.dtype != dtype:
        # One range holds for the whole clip; data of another depth would be measured on it.
        return f"{name} holds {image.dtype} data, the first frame {dtype}"
    if image.dtype.kind == "f" and not np.isfinite(image).all():
        # Nothing can be measured against a background that is not a number.
        return f"{name} holds NaN or infinite pixels"
    return None


# Number types the detectors take as they are; others become float32.
_DEEP_TYPES = (np.dtype(np.uint16), np.dtype(np.float32), np.dtype(np.float64))


def _as_frame(image: np.ndarray | None) -> np.ndarray | None:
    """An image as read (None: unreadable), as a source yields it (see the module's description)."""
    if image is None or image.dtype == np.uint8:
        return _to_bgr(image)
    if image.dtype not in _DEEP_TYPES:
        image = image.astype(np.float32)
    # Deeper grey stays one channel: three would triple a 16-bit stack's bytes, and the grey
    # weights applied to float channels need not give back the values stored.
    if image.ndim == 3 and image.shape[2] == 1:
        return image[..., 0]
    if image.ndim == 3 and image.shape[2] == 4:
        return np.ascontiguousarray(image[..., :3])
    return image


def _to_bgr(image: np.ndarray | None) -> np.ndarray | None:
    if image is None:
        return None
    if image.ndim == 2:
        return cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
    if image.shape[2] == 4:
        return cv2.cvtColor(image, cv2.COLOR_BGRA2BGR)
    if image.shape[2] == 1:
        return cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
    return image


def read_mask(path: str | os.PathLike, size: tuple[int, int]) -> np.ndarray:
    """A region-of-interest mask image: nonzero (any channel) marks where to look.

    Parameters
    ----------
    path : path-like
        An image file (png, tif, ...).
    size : tuple of int
        (width, height) the frames have, pixels.

    Returns
    -------
    ndarray of uint8, shape (height, width)
        255 inside the region, 0 outside.

    Raises
    ------
    DataError
        If the file is not a readable image, is of another size, or marks no pixel.
    """
    image = cv2.imread(os.fspath(path), cv2.IMREAD_UNCHANGED) if Path(path).is_file() else None
    if image is None:
        raise DataError(path, "not a mask image this program can read")
    if (image.shape[1], image.shape[0]) != tuple(size):
        raise DataError(path, f"mask is {image.shape[1]}x{image.shape[0]}, the frames {size[0]}x{size[1]}")
    marked = image.any(axis=2) if image.ndim == 3 else image != 0
    if not marked.any():
        raise DataError(path, "mask marks no pixel (all black)")
    return np.where(marked, np.uint8(255), np.uint8(0))
