"""Background estimates and the statistics that set a threshold on what stands out of them.

The detector never thresholds grey levels directly: it thresholds the *contrast* of each pixel
against a background estimate, so that uneven light, vignetting and slow gradients do not
decide what is an object.
"""

from __future__ import annotations

from typing import Iterable

import cv2
import numpy as np

# The local background is a median over a window; it is taken on a copy shrunk by this factor
# (a median of a 5x5 window there spans 40x40 pixels of the frame) because a large median at
# full size costs more than the rest of the detector together.
_SHRINK = 8
# A pixel belongs to no object unless its contrast exceeds this many noise standard deviations.
NOISE_FLOOR_SIGMAS = 4.0
# Quantile of the contrast above the noise floor that stands for the strongest objects.
_STRONG_QUANTILE = 0.99
# Median absolute deviation of a normal distribution, in standard deviations.
_MAD_TO_SIGMA = 1.4826


def local_background(gray: np.ndarray, size: float) -> np.ndarray:
    """Large-scale background of a frame: a median over windows of about ``size`` pixels.

    Objects smaller than about half the window leave the median untouched, so the estimate
    follows the light and the dish but not the seeds.

    Parameters
    ----------
    gray : ndarray of uint8, shape (H, W)
    size : float
        Window side in pixels.

    Returns
    -------
    ndarray of uint8, shape (H, W)
    """
    height, width = gray.shape
    shrink = max(1, min(_SHRINK, int(size) // 3, height // 3, width // 3))
    small = cv2.resize(gray, (max(1, width // shrink), max(1, height // shrink)), interpolation=cv2.INTER_AREA)
    window = max(3, int(round(size / shrink)) | 1)
    # medianBlur needs an odd window of at most the image's size (it pads by replication).
    small = cv2.medianBlur(small, min(window, 255))
    return cv2.resize(small, (width, height), interpolation=cv2.INTER_LINEAR)


def flat_background(gray: np.ndarray) -> np.ndarray:
    """A background equal everywhere to the frame's median grey level (no correction)."""
    histogram = np.bincount(gray[::4, ::4].ravel(), minlength=256)
    median = int(np.searchsorted(np.cumsum(histogram), histogram.sum() / 2))
    return np.full_like(gray, median)


def temporal_median(frames: Iterable[np.ndarray], max_frames: int = 64) -> np.ndarray:
    """Background of a static scene: the per-pixel median of up to ``max_frames`` frames.

    Parameters
    ----------
    frames : iterable of ndarray of uint8, shape (H, W)
        Grey frames spread over the clip; moving objects must not sit still in most of them.
    max_frames : int
        At most this many are used (the first ones), which bounds memory.

    Returns
    -------
    ndarray of uint8, shape (H, W)
    """
    stack = []
    for frame in frames:
        stack.append(frame)
        if len(stack) == max_frames:
            break
    if not stack:
        raise ValueError("no frame to take a median of")
    return np.median(np.stack(stack), axis=0).round().astype(np.uint8)


def contrast_histogram(signal: np.ndarray, roi: np.ndarray | None) -> np.ndarray:
    """Counts of each contrast level 0..255 over the region of interest (every other row and
    column: a statistic, not worth every pixel)."""
    mask = None if roi is None else roi[::2, ::2]
    return cv2.calcHist([signal[::2, ::2]], [0], mask, [256], [0, 256]).ravel()


def noise_floor(histogram: np.ndarray) -> float:
    """Contrast below which a pixel is indistinguishable from background noise.

    The contrast is the positive part of a residual that is symmetric about zero on the
    background, so a quarter of the background pixels exceed the residual's median absolute
    deviation: that level, read off the histogram with linear interpolation, gives the noise
    standard deviation without any object pixels being counted as noise.

    Returns
    -------
    float
        ``NOISE_FLOOR_SIGMAS`` noise standard deviations, grey levels, at least 1.
    """
    total = histogram.sum()
    if total == 0:
        return 1.0
    # exceed[v] = pixels with contrast > v
    exceed = total - np.cumsum(histogram)
    quarter = total / 4
    k = int(np.searchsorted(-exceed, -quarter, side="left"))  # first v with exceed[v] <= quarter
    # Below one grey level the quantised residual cannot tell noise apart: call it zero.
    mad = 0.0 if k == 0 else (k - 1) + (exceed[k - 1] - quarter) / max(exceed[k - 1] - exceed[k], 1.0)
    return max(1.0, NOISE_FLOOR_SIGMAS * _MAD_TO_SIGMA * mad)


def otsu_above(histogram: np.ndarray, floor: float) -> float:
    """Otsu's threshold among the contrast levels above ``floor``.

    Otsu over the whole frame splits the background's own noise when objects are few; among
    the pixels that stand out of the noise it separates objects from faint clutter (out of
    focus particles, texture) instead. It is capped at half the contrast of the strongest
    objects (the 99th percentile), so that objects of different contrast are all kept.

    Returns
    -------
    float
        A level >= ``floor``; pixels with contrast above it are object pixels.
    """
    first = int(np.floor(floor)) + 1
    counts = histogram[first:].astype(float)
    total = counts.sum()
    if np.count_nonzero(counts) < 2:
        # Nothing, or a single level, stands out: all of it is object.
        return float(floor)
    levels = np.arange(first, 256, dtype=float)
    weight_low = np.cumsum(counts)
    mass_low = np.cumsum(counts * levels)
    weight_high = total - weight_low
    mean_low = mass_low / np.maximum(weight_low, 1e-12)
    mean_high = (mass_low[-1] - mass_low) / np.maximum(weight_high, 1e-12)
    between = weight_low * weight_high * (mean_low - mean_high) ** 2
    between[weight_high == 0] = -1
    otsu = levels[int(np.argmax(between))]
    # When every pixel above the floor belongs to an object, Otsu splits strong objects from
    # weak ones; half the contrast of the strongest objects keeps the weak ones.
    strong = levels[min(int(np.searchsorted(weight_low, _STRONG_QUANTILE * total)), levels.size - 1)]
    return float(max(floor, min(otsu, strong / 2)))
