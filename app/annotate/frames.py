"""Frames of a clip on demand, as JPEG bytes, with the most recent ones kept.

A reviewer mostly steps forward one frame, sometimes back a few and now and then jumps. Frames
are read through :func:`seedtrack.data.frames.open_frames`, so any input ``run`` takes works;
a video is decoded forward from where the last request left it, and the encoded pictures of the
last frames shown are kept so that stepping back costs nothing.

A jump in a video seeks to the key frame before it when the video's packets say exactly which
frame is which: one timestamp per frame, all different, as many as the header's frame count.
Frame k is then the one with the k-th smallest timestamp, as sequential decoding numbers them.
Otherwise (broken timestamps, such as all zero, or no exact count) a jump back decodes from the
start, because seeking by time is not frame-exact there.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from pathlib import Path

import av
import cv2
import numpy as np

from seedtrack.data.errors import DataError
from seedtrack.data.frames import IMAGE_SUFFIXES, open_frames
from seedtrack.data.video import open_container

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
        self._seeker = _Seeker.of(target, self.frame_count) if self._sequential else None

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
            if self._seeker is not None:
                self._seeker.close()

    def _read(self, index: int) -> bytes:
        if index < 0 or (self.frame_count is not None and index >= self.frame_count):
            raise IndexError(index)
        if self._seeker is not None:
            image = self._seeker.read(index)
            if image is not None:
                return self._keep(index, image)
            self._seeker.close()
            self._seeker = None
        if self._iterator is None or index < self._next or (not self._sequential and index != self._next):
            self._drop_source()
            self._source = open_frames(self.path, start=index)
            self._iterator = self._source.shown()
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


class _Seeker:
    """Frame-exact random access to a video whose packet timestamps number its frames."""

    def __init__(self, path: Path, stamps: np.ndarray, keys: np.ndarray) -> None:
        self._path = path
        self._stamps = stamps  # timestamp of frame k, increasing
        self._keys = keys  # timestamps of the key frames, increasing
        self._container = None
        self._decoded = None
        self._last = None  # timestamp of the frame decoded last

    @classmethod
    def of(cls, path: Path, frame_count: int | None) -> "_Seeker | None":
        """A seeker for ``path``, or None if its timestamps cannot say which frame is which."""
        container = open_container(path)
        try:
            stream = container.streams.video[0]
            if not stream.frames or frame_count != stream.frames:
                return None
            stamps, keys = [], []
            for packet in container.demux(stream):
                if packet.size == 0:  # the flush packet at the end
                    continue
                if packet.pts is None:
                    return None
                stamps.append(packet.pts)
                if packet.is_keyframe:
                    keys.append(packet.pts)
        except av.FFmpegError:
            return None
        finally:
            container.close()
        stamps = np.sort(np.array(stamps, np.int64))
        if stamps.size != frame_count or np.unique(stamps).size != stamps.size or not keys or min(keys) != stamps[0]:
            return None
        return cls(path, stamps, np.sort(np.array(keys, np.int64)))

    def read(self, index: int) -> np.ndarray | None:
        """Frame ``index`` as BGR, or None if the video turns out not to be numbered as its packets say."""
        target = int(self._stamps[index])
        key = int(self._keys[np.searchsorted(self._keys, target, side="right") - 1])
        # Decoding on is cheaper than seeking while no key frame lies between here and there.
        if self._last is None or target <= self._last or key > self._last:
            if self._container is None:
                self._container = open_container(self._path)
            stream = self._container.streams.video[0]
            self._container.seek(key, stream=stream, backward=True, any_frame=False)
            self._decoded = self._container.decode(stream)
            self._last = None
        try:
            for frame in self._decoded:
                if frame.pts is None or (self._last is None and frame.pts > key):
                    return None
                self._last = frame.pts
                if frame.pts == target:
                    return frame.to_ndarray(format="bgr24")
                if frame.pts > target:
                    return None
        except av.FFmpegError:
            return None
        return None

    def close(self) -> None:
        if self._container is not None:
            self._container.close()
            self._container = None
