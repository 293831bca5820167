"""The range of values a frame's data can take, from its type and its values, not assumed 8-bit.

Cameras store 10, 12, 14 or 16 bits in 16-bit words, and processed stacks are often float; the
range decides how frames are shown and measured in 8 bits, and must not depend on how bright one
frame happens to be.
"""

from __future__ import annotations

import cv2
import numpy as np

# Bit depths cameras store in 16-bit words.
_DEPTHS = (8, 10, 12, 14, 16)


def value_range(image: np.ndarray) -> tuple[float, float]:
    """(low, high): the values that stand for black and white in data like ``image``.

    Unsigned integers: 0 to the largest value of the fewest bits (8, 10, 12, 14 or 16, or the
    type's own) that hold the image's brightest pixel; floats: 0 to 1 when the image lies within
    them, else its own darkest and brightest finite values.

    Example
    -------
    >>> value_range(np.array([[0, 3000]], np.uint16))
    (0.0, 4095.0)
    >>> value_range(np.array([[0.2, 0.7]], np.float32))
    (0.0, 1.0)
    """
    if image.dtype.kind in "ub":
        brightest = int(image.max()) if image.size else 0
        bits = next((b for b in _DEPTHS if brightest < 1 << b and b <= 8 * image.dtype.itemsize), 8 * image.dtype.itemsize)
        return 0.0, float((1 << bits) - 1)
    finite = image[np.isfinite(image)] if image.dtype.kind == "f" else image
    if finite.size == 0:
        return 0.0, 1.0
    low, high = float(finite.min()), float(finite.max())
    if image.dtype.kind == "f" and 0.0 <= low and high <= 1.0:
        return 0.0, 1.0
    return (low, high) if high > low else (low, low + 1.0)


def to_uint8(image: np.ndarray, span: tuple[float, float]) -> np.ndarray:
    """``image`` mapped linearly from ``span`` onto 0..255 (rounded, clipped).

    Example
    -------
    >>> to_uint8(np.array([[0, 257, 65535]], np.uint16), (0.0, 65535.0)).tolist()
    [[0, 1, 255]]
    """
    if image.dtype == np.uint8 and span == (0.0, 255.0):
        return image
    low, high = span
    scaled = (np.nan_to_num(image.astype(np.float32), nan=low) - np.float32(low)) * np.float32(255.0 / (high - low))
    return np.clip(scaled + 0.5, 0, 255).astype(np.uint8)


def to_bgr8(image: np.ndarray, span: tuple[float, float]) -> np.ndarray:
    """A frame of any depth as drawing and picture files take it: uint8 (H, W, 3) BGR.

    Values are mapped linearly from ``span`` (the source's :func:`value_range`, so that every
    frame of a clip is shown on one scale) onto 0..255 (see :func:`to_uint8`); grey becomes three
    equal channels, an alpha channel is dropped. An 8-bit BGR frame comes back as it is.

    Example
    -------
    >>> to_bgr8(np.array([[0, 4095]], np.uint16), (0.0, 4095.0)).tolist()
    [[[0, 0, 0], [255, 255, 255]]]
    """
    image = to_uint8(image, span)
    if image.ndim == 3 and image.shape[2] == 3:
        return image
    if image.ndim == 3 and image.shape[2] == 4:
        return cv2.cvtColor(image, cv2.COLOR_BGRA2BGR)
    return cv2.cvtColor(image.reshape(image.shape[:2]), cv2.COLOR_GRAY2BGR)
