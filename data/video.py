"""Video files through PyAV: write H.264 MP4 that plays in a browser, and probe a clip's header.

Frames are uint8 numpy arrays in OpenCV layout: (height, width, 3) BGR or (height, width) gray.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path
from typing import Callable, Iterable

import av
import cv2
import numpy as np
from av.video.reformatter import ColorPrimaries, ColorRange, ColorTrc, Colorspace

from .atomic import atomic_path
from .errors import DataError

# One encoder thread: x264's output depends on its thread count, so a fixed count is what
# makes the same frames give the same bytes on every machine.
_ENCODER_THREADS = "1"
# x264's veryfast preset at crf 16 matches the default preset (medium) at crf 18 in quality on
# drawn overlays (PSNR 34.5 dB both, dish overlay at 1280x960) at 2.4 times the speed (70 against
# 171 ms a frame on one thread), for files about 30% larger: encoding was most of `run`'s time.
_ENCODER_PRESET = "veryfast"
# The preset of the overlay `run` writes, a preview: on a 640x424 overlay ultrafast took 2.5 ms a
# frame against veryfast's 7.6 (one thread, crf 16), of the same PSNR against the drawn frames
# (26.1 and 26.2 dB, both bound by 4:2:0 chroma on thin coloured lines), in files 1.8 times
# larger; superfast saved a fifth of the time in files twice as large.
PREVIEW_PRESET = "ultrafast"
# And its constant rate factor. On the 300-frame 640x512 dish overlay at ultrafast, against the
# drawn frames (grey levels; colour is bound near 28 dB by 4:2:0 chroma on thin lines): crf 16
# 39.5 dB, 4.9 MB, 2.3 ms a frame; 20: 37.1 dB, 3.6 MB, 1.9 ms; 23 (x264's default): 35.6 dB,
# 2.9 MB, 1.9 ms. 20 keeps every line and label sharp in a file a quarter smaller.
PREVIEW_CRF = 20
# glibc's mallopt setting that fills memory handed out, and the byte it fills with.
_M_PERTURB = -6
_FILL_BYTE = 0x5A
_FILLED = False
# Frame rates such as 30000/1001 survive as exact fractions; anything finer is float noise.
_MAX_RATE_DENOMINATOR = 1001 * 1000


@dataclass(frozen=True)
class VideoInfo:
    """What a video's header says about its first video stream.

    Attributes
    ----------
    frame_count : int or None
        Number of frames, from the header, or estimated from duration and frame rate; None if
        neither is known.
    exact : bool
        Whether ``frame_count`` is the header's count rather than an estimate.
    fps : float
        Frames per second (FFmpeg's guess, else the average rate; 25.0 if the file does not say).
    size : tuple of int
        (width, height) in pixels.
    codec : str
        Decoder name, e.g. ``"h264"``.
    """

    frame_count: int | None
    exact: bool
    fps: float
    size: tuple[int, int]
    codec: str


def write_video(
    path: str | os.PathLike,
    frames: Iterable[np.ndarray],
    fps: float,
    *,
    crf: int = 16,
    progress: Callable[[int], object] | object | None = None,
    preset: str = _ENCODER_PRESET,
) -> int:
    """Encode frames as an H.264 (libx264, yuv420p) MP4, atomically and deterministically.

    Parameters
    ----------
    path : path-like
        Output file; it is an MP4 whatever its suffix. Nothing appears under this name unless
        the whole clip is written.
    frames : iterable of ndarray of uint8
        (H, W, 3) BGR or (H, W) gray, all the same size; consumed one at a time. An odd width
        or height is padded by one pixel (copying the last column or row) on the right or
        bottom, because yuv420p needs even sizes.
    fps : float
        Frames per second, > 0.
    crf : int
        x264 constant rate factor, 0 (lossless luma) to 51; 16 at the veryfast preset used here
        is visually lossless.
    progress : tqdm-like or callable, optional
        Called with 1 (``progress.update(1)`` if it has ``update``) after each frame.
    preset : str
        x264 preset: "veryfast" (default) or, for a preview, :data:`PREVIEW_PRESET` (with
        :data:`PREVIEW_CRF`).

    Returns
    -------
    int
        Number of frames written.

    Raises
    ------
    ValueError
        If ``fps`` or ``crf`` is out of range, there are no frames, or a frame has the wrong
        type or size.
    DataError
        If the output folder does not exist or cannot be written.
    """
    if not fps > 0:
        raise ValueError(f"fps must be > 0, got {fps}")
    if not 0 <= crf <= 51:
        raise ValueError(f"crf must be in 0..51, got {crf}")
    tick = _ticker(progress)
    _fill_new_memory()
    with atomic_path(path) as temporary:
        # faststart puts the index before the data: browsers start playing at once, and a
        # truncated file still opens and decodes up to where it was cut.
        with av.open(str(temporary), "w", format="mp4", options={"movflags": "+faststart"}) as container:
            count = _encode_all(container, frames, fps, crf, tick, preset)
    return count


def _fill_new_memory() -> None:
    """Have glibc fill memory it hands out with one fixed byte, from now on in this process.

    The bundled x264 reads some memory it has not written: the same frames gave other bytes
    depending on what the process had done before (a Dask worker, a process fed through a pipe).
    A fixed fill makes what it reads, and so the file, the same everywhere.
    """
    global _FILLED
    if _FILLED:
        return
    _FILLED = True
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        libc.mallopt(_M_PERTURB, _FILL_BYTE)
    except (OSError, AttributeError):
        pass  # not glibc


def _ticker(progress) -> Callable[[], None]:
    if progress is None:
        return lambda: None
    update = progress.update if hasattr(progress, "update") else progress
    return lambda: update(1)


def _encode_all(container, frames: Iterable[np.ndarray], fps: float, crf: int, tick, preset: str) -> int:
    stream = None
    shape = None
    count = 0
    for frame in frames:
        frame = np.asarray(frame)
        _check_frame(frame, shape, count)
        if stream is None:
            shape = frame.shape
            stream = _add_stream(container, shape, fps, crf, preset)
        container.mux(stream.encode(av.VideoFrame.from_ndarray(_to_yuv420p(frame), format="yuv420p")))
        count += 1
        tick()
    if stream is None:
        raise ValueError("no frames to write")
    container.mux(stream.encode(None))
    return count


def _check_frame(frame: np.ndarray, shape: tuple[int, ...] | None, index: int) -> None:
    """Raise ValueError unless ``frame`` is uint8 gray or BGR of the first frame's ``shape``."""
    if frame.dtype != np.uint8:
        raise ValueError(f"frame {index}: dtype must be uint8, got {frame.dtype}")
    if not (frame.ndim == 2 or (frame.ndim == 3 and frame.shape[2] == 3)):
        raise ValueError(f"frame {index}: shape must be (H, W, 3) or (H, W), got {frame.shape}")
    if shape is not None and frame.shape != shape:
        raise ValueError(f"frame {index}: shape {frame.shape} differs from the first frame's {shape}")


def _add_stream(container, shape: tuple[int, ...], fps: float, crf: int, preset: str):
    rate = Fraction(fps).limit_denominator(_MAX_RATE_DENOMINATOR)
    stream = container.add_stream("libx264", rate=rate)
    stream.width = shape[1] + shape[1] % 2
    stream.height = shape[0] + shape[0] % 2
    stream.pix_fmt = "yuv420p"
    stream.options = {"crf": str(crf), "preset": preset, "threads": _ENCODER_THREADS}
    # Tag the BT.601 limited-range conversion of _to_yuv420p; untagged HD video is decoded as
    # BT.709 by browsers, which would shift colours.
    context = stream.codec_context
    context.colorspace = Colorspace.ITU601
    context.color_primaries = ColorPrimaries.SMPTE170M
    context.color_trc = ColorTrc.SMPTE170M
    context.color_range = ColorRange.MPEG
    return stream


def _to_yuv420p(frame: np.ndarray) -> np.ndarray:
    """BT.601 limited-range I420 planes stacked as ((H * 3) // 2, W) uint8, padded to even size."""
    bgr = _pad_even(frame if frame.ndim == 3 else cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR))
    # OpenCV rounds correctly; swscale's default BGR-to-YUV path truncates luma and shifts
    # chroma, which tints and darkens grey by several levels. FFmpeg's decoder undoes this
    # conversion exactly.
    return cv2.cvtColor(bgr, cv2.COLOR_BGR2YUV_I420)


def _pad_even(frame: np.ndarray) -> np.ndarray:
    pad_rows, pad_columns = frame.shape[0] % 2, frame.shape[1] % 2
    if not (pad_rows or pad_columns):
        return frame
    widths = ((0, pad_rows), (0, pad_columns)) + ((0, 0),) * (frame.ndim - 2)
    return np.pad(frame, widths, mode="edge")


def probe_video(path: str | os.PathLike) -> VideoInfo:
    """Read a video's header: frame count, frame rate, size and codec of its first video stream.

    Raises
    ------
    DataError
        If the file is missing, is not a video PyAV can open, or has no video stream.
    """
    container = open_container(path)
    try:
        return video_info(container.streams.video[0])
    finally:
        container.close()


def open_container(path: str | os.PathLike):
    """Open a video for reading with PyAV, turning failures into one-line ``DataError``.

    Returns
    -------
    av.container.InputContainer
        Open container with at least one video stream; the caller closes it.
    """
    path = Path(path)
    if not path.exists():
        raise DataError(path, "no such file or folder")
    try:
        container = av.open(str(path))
    except av.FFmpegError as error:
        raise DataError(path, f"not a video this program can read ({ffmpeg_reason(error)})") from None
    if not container.streams.video:
        container.close()
        raise DataError(path, "has no video stream")
    return container


def video_info(stream) -> VideoInfo:
    """Header facts of an open PyAV video stream; see :class:`VideoInfo`."""
    # FFmpeg's guess (the container's nominal rate) first: the average over the stream's
    # duration is wild when timestamps are broken (bulk-water-240-479.mp4 averages 5754/s).
    rate = stream.guessed_rate or stream.average_rate
    fps = float(rate) if rate else 25.0
    return VideoInfo(
        frame_count=_frame_count(stream, fps),
        exact=bool(stream.frames),
        fps=fps,
        size=(stream.codec_context.width, stream.codec_context.height),
        codec=stream.codec_context.name,
    )


def _frame_count(stream, fps: float) -> int | None:
    if stream.frames:
        return int(stream.frames)
    # Containers such as raw streams or some AVIs do not store a count; the duration is the
    # next best thing and may be off by a frame.
    duration = stream.duration * stream.time_base if stream.duration and stream.time_base else None
    if duration is None and stream.container.duration:
        duration = stream.container.duration / av.time_base
    return int(round(float(duration) * fps)) if duration else None


def ffmpeg_reason(error: Exception) -> str:
    """The FFmpeg message of a PyAV error without the file name PyAV appends, for one-line errors."""
    return getattr(error, "strerror", None) or str(error)
