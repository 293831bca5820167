"""Frames of a clip on demand, as JPEG bytes, with the most recent ones kept.

A reviewer mostly steps forward one frame, sometimes back a few and now and then jumps. Frames
are read through :func:`seedtrack.data.frames.open_frames`, so any input ``run`` takes works;
a video is decoded forward from where the last request left it (decoding from the start for a
jump back, because seeking is not frame-exact in every format), and the encoded pictures of the
last frames shown are kept so that stepping back costs nothing.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from pathlib import Path

import cv2

from seedtrack.data.errors import DataError
from seedtrack.data.frames import IMAGE_SUFFIXES, open_frames

# 256 JPEGs of a 1080p frame at quality 90 are about 100 MB at worst.
CACHE_FRAMES = 256
JPEG_QUALITY = 90


class FrameCache:
    """JPEG pictures of the frames of one clip, decoded on demand.

    Parameters
    ----------
    path : path-like
        Any input :func:`seedtrack.data.frames.open_frames` takes.
    capacity : int
        How many encoded frames to keep.

    Attributes
    ----------
    size : tuple of int
        (width, height), pixels.
    fps : float
    frame_count : int or None
        Frames in the clip, when the source says.

    Example
    -------
    >>> cache = FrameCache("clip.mp4")  # doctest: +SKIP
    >>> cache.jpeg(0)[:2]  # doctest: +SKIP
    b'\\xff\\xd8'
    """

    def __init__(self, path, capacity: int = CACHE_FRAMES) -> None:
        self.path = path
        self._capacity = capacity
        self._cache: OrderedDict[int, bytes] = OrderedDict()
        self._lock = threading.Lock()
        source = open_frames(path)
        self.size, self.fps, self.frame_count = source.size, source.fps, source.frame_count
        source.close()
        target = Path(path)
        # A video can only be decoded forward; image files can be opened at any frame.
        self._sequential = target.is_file() and target.suffix.lower() not in IMAGE_SUFFIXES and target.suffix.lower() not in (".tif", ".tiff")
        self._source = None
        self._iterator = None
        self._next = 0

    def jpeg(self, index: int) -> bytes:
        """The JPEG picture of 0-based frame ``index``.

        Raises
        ------
        IndexError
            If the clip has no frame ``index``.
        DataError
            If the clip cannot be decoded there.
        """
        with self._lock:
            if index in self._cache:
                self._cache.move_to_end(index)
                return self._cache[index]
            return self._read(index)

    def close(self) -> None:
        """Release the open clip."""
        with self._lock:
            self._drop_source()

    def _read(self, index: int) -> bytes:
        if index < 0 or (self.frame_count is not None and index >= self.frame_count):
            raise IndexError(index)
        if self._iterator is None or index < self._next or (not self._sequential and index != self._next):
            self._drop_source()
            self._source = open_frames(self.path, start=index)
            self._iterator = iter(self._source)
            self._next = index
        for got, image in self._iterator:
            self._next = got + 1
            if got == index:
                return self._keep(index, image)
            if got > index:
                break
        problem = self._source.stopped_early
        self._drop_source()
        if problem:
            raise DataError(self.path, problem)
        raise IndexError(index)

    def _keep(self, index: int, image) -> bytes:
        ok, encoded = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY])
        picture = encoded.tobytes()
        self._cache[index] = picture
        while len(self._cache) > self._capacity:
            self._cache.popitem(last=False)
        return picture

    def _drop_source(self) -> None:
        if self._source is not None:
            self._source.close()
        self._source, self._iterator = None, None
