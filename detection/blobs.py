"""Threshold blob detector: dark (or light) blobs become point measurements.

A frame goes in, a table of measurements comes out: threshold, connected components,
area limits, intensity-weighted centroids. Nothing here knows about tracking or files.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

MEASUREMENT_COLUMNS = ("x", "y", "area", "mean_intensity")


@dataclass(frozen=True)
class BlobOptions:
    """Options of :func:`detect_blobs`.

    Attributes
    ----------
    polarity : {"dark", "light"}
        Whether objects are darker or lighter than their surroundings.
    threshold : float or None
        Grey level (0-255) that separates objects from the background; None picks one per
        frame with Otsu's method.
    min_area_px, max_area_px : float or None
        Blobs with fewer or more pixels are dropped; None leaves that side open, except that
        blobs covering more than ``max_area_fraction`` of the frame are always background.
    max_area_fraction : float
        Largest blob, as a fraction of the frame's pixels, that can be an object.
    """

    polarity: str = "dark"
    threshold: float | None = None
    min_area_px: float | None = 3.0
    max_area_px: float | None = None
    max_area_fraction: float = 0.01

    def __post_init__(self) -> None:
        if self.polarity not in ("dark", "light"):
            raise ValueError(f"polarity must be 'dark' or 'light', got {self.polarity!r}")
        if self.threshold is not None and not 0 <= self.threshold <= 255:
            raise ValueError(f"threshold must lie in 0..255, got {self.threshold}")
        for name in ("min_area_px", "max_area_px"):
            value = getattr(self, name)
            if value is not None and value < 0:
                raise ValueError(f"{name} must not be negative, got {value}")
        if self.min_area_px is not None and self.max_area_px is not None and self.min_area_px > self.max_area_px:
            raise ValueError(f"min area {self.min_area_px} px exceeds max area {self.max_area_px} px")


def to_gray(image: np.ndarray) -> np.ndarray:
    """A uint8 grey-level view of an (H, W) or (H, W, 3) BGR frame."""
    if image.ndim == 3:
        return cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    return image


def detect_blobs(image: np.ndarray, options: BlobOptions = BlobOptions()) -> dict[str, np.ndarray]:
    """Find blobs in one frame and measure them.

    Parameters
    ----------
    image : ndarray of uint8, shape (H, W) or (H, W, 3) BGR
        The frame.
    options : BlobOptions
        Polarity, threshold and area limits.

    Returns
    -------
    dict of str to ndarray
        ``x``, ``y``: intensity-weighted centroid, pixels (x to the right, y down, pixel
        centres at integer coordinates); ``area``: pixels in the blob; ``mean_intensity``:
        mean grey level (0-255) of the blob. Sorted by y, then x. Empty arrays when the
        frame holds no blob.
    """
    gray = to_gray(image)
    # Work on "objectness": how far each pixel is on the object side of the background.
    # Kept in uint8 (exact, since 255 - gray is integral) so whole-frame passes stay cheap.
    signal = cv2.bitwise_not(gray) if options.polarity == "dark" else gray
    level = _threshold(signal, options.threshold, options.polarity)
    mask = (signal > level).astype(np.uint8)
    count, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    area = stats[1:, cv2.CC_STAT_AREA].astype(float)
    keep = area <= options.max_area_fraction * gray.size
    if options.min_area_px is not None:
        keep &= area >= options.min_area_px
    if options.max_area_px is not None:
        keep &= area <= options.max_area_px
    if count <= 1 or not keep.any():
        return {name: np.empty(0) for name in MEASUREMENT_COLUMNS}
    flat_labels = labels.ravel()
    inside = np.flatnonzero(flat_labels)
    rows, columns = np.divmod(inside, gray.shape[1])
    label = flat_labels[inside]
    w = signal.ravel()[inside] - level
    total = np.bincount(label, weights=w, minlength=count)[1:]
    x = np.bincount(label, weights=w * columns, minlength=count)[1:] / total
    y = np.bincount(label, weights=w * rows, minlength=count)[1:] / total
    intensity = np.bincount(label, weights=gray.ravel()[inside], minlength=count)[1:] / area
    table = {"x": x[keep], "y": y[keep], "area": area[keep], "mean_intensity": intensity[keep]}
    order = np.lexsort((table["x"], table["y"]))
    return {name: values[order] for name, values in table.items()}


def _threshold(signal: np.ndarray, threshold: float | None, polarity: str) -> float:
    """Objectness level that separates objects; a grey-level threshold is converted."""
    if threshold is not None:
        return 255.0 - threshold if polarity == "dark" else float(threshold)
    level, _ = cv2.threshold(signal, 0, 255, cv2.THRESH_BINARY + cv2.THRESH_OTSU)
    return float(level)
