"""Laplacian-of-Gaussian detector for small round spots (particles, beads, fluorescent dots).

Spots are the scale-space maxima of the scale-normalised Laplacian of Gaussian of the contrast
(scikit-image's ``blob_log``), between the sizes the area limits allow; each is then measured
on the contrast around it like a blob, for a sub-pixel centre. It copes with spots too faint or
too crowded for one threshold to separate, at some hundred times the cost of the blob detector.
"""

from __future__ import annotations

import numpy as np
from skimage.feature import blob_log

from .background import contrast_histogram, noise_floor, otsu_above
from .blobs import BlobOptions, _empty, contrast, eccentricity, to_gray

# Radius of the largest spot looked for when no largest area is given, pixels.
_DEFAULT_LARGEST_RADIUS = 6.0
# Scales tried between the smallest and the largest spot.
_SCALES = 5
# A spot of contrast C gives a scale-normalised LoG response of about C/2 at its own scale
# (exactly so for a Gaussian spot): the bar for a spot whose contrast reaches the threshold.
_RESPONSE_PER_CONTRAST = 0.5


def detect_spots(
    image: np.ndarray,
    options: BlobOptions = BlobOptions(),
    *,
    background: np.ndarray | None = None,
    roi: np.ndarray | None = None,
) -> dict[str, np.ndarray]:
    """Find small round spots in one frame and measure them.

    Parameters
    ----------
    image : ndarray of uint8, shape (H, W) or (H, W, 3) BGR
        The frame.
    options : BlobOptions
        Polarity, background, threshold (otsu or a contrast in grey levels; "adaptive" is
        taken as otsu) and area limits, which set the range of spot sizes; ``split`` is not
        used (scale space separates touching spots).
    background : ndarray of uint8, shape (H, W), optional
        The background image when ``options.background`` is "temporal".
    roi : ndarray of uint8, shape (H, W), optional
        Spots are looked for only where it is nonzero.

    Returns
    -------
    dict of str to ndarray
        The columns of :func:`seedtrack.detection.blobs.detect_blobs`: ``x``, ``y`` (contrast-weighted
        centre within the spot's radius, pixels), ``area`` (pixels above the threshold within
        that radius), ``mean_intensity``, ``eccentricity``; sorted by y, then x.
    """
    gray = to_gray(image)
    signal = contrast(gray, options, background, roi)
    if isinstance(options.threshold, str):
        histogram = contrast_histogram(signal, roi)
        level = otsu_above(histogram, noise_floor(histogram))
    else:
        level = float(options.threshold)
    smallest = np.sqrt(max(options.min_area_px or 1.0, 1.0) / np.pi)
    largest = np.sqrt(options.max_area_px / np.pi) if options.max_area_px else max(_DEFAULT_LARGEST_RADIUS, 2 * smallest)
    # A disc of radius r matches the Laplacian of Gaussian of sigma r / sqrt(2).
    peaks = blob_log(
        signal.astype(np.float32) / 255,
        min_sigma=max(smallest / np.sqrt(2), 0.5),
        max_sigma=max(largest / np.sqrt(2), 0.5),
        num_sigma=_SCALES,
        threshold=_RESPONSE_PER_CONTRAST * level / 255,
        exclude_border=False,
    )
    if len(peaks) == 0:
        return _empty()
    table = _measure_spots(peaks, signal, gray, level)
    low = options.min_area_px or 0.0
    high = min(options.max_area_px or np.inf, options.max_area_fraction * gray.size)
    keep = (table["area"] >= low) & (table["area"] <= high)
    order = np.lexsort((table["x"][keep], table["y"][keep]))
    return {name: values[keep][order] for name, values in table.items()}


def _measure_spots(peaks: np.ndarray, signal: np.ndarray, gray: np.ndarray, level: float) -> dict[str, np.ndarray]:
    """Measure each (row, column, sigma) peak on the contrast within its radius."""
    height, width = signal.shape
    radius = np.sqrt(2) * peaks[:, 2] + 0.5
    reach = int(np.ceil(radius.max()))
    dy, dx = np.mgrid[-reach : reach + 1, -reach : reach + 1]
    dy, dx = dy.ravel()[None, :], dx.ravel()[None, :]
    rows = peaks[:, 0].astype(int)[:, None] + dy
    columns = peaks[:, 1].astype(int)[:, None] + dx
    within = (dx * dx + dy * dy <= radius[:, None] ** 2) & (rows >= 0) & (rows < height) & (columns >= 0) & (columns < width)
    rows, columns = np.clip(rows, 0, height - 1), np.clip(columns, 0, width - 1)
    contrast = signal[rows, columns].astype(float)
    above = within & (contrast > level)
    weight = np.where(above, contrast - level, 0.0)
    # A peak found below the bar (blob_log's bar is on the response) still gets a centre.
    weight = np.where(weight.sum(axis=1, keepdims=True) > 0, weight, np.where(within, contrast + 1e-9, 0.0))
    mass = weight.sum(axis=1)
    x = (weight * columns).sum(axis=1) / mass
    y = (weight * rows).sum(axis=1) / mass
    ex, ey = columns - x[:, None], rows - y[:, None]
    sxx, syy, sxy = (weight * ex * ex).sum(axis=1) / mass, (weight * ey * ey).sum(axis=1) / mass, (weight * ex * ey).sum(axis=1) / mass
    counted = np.where(above.any(axis=1, keepdims=True), above, within)
    area = counted.sum(axis=1).astype(float)
    intensity = np.where(counted, gray[rows, columns], 0).sum(axis=1) / area
    return {"x": x, "y": y, "area": area, "mean_intensity": intensity, "eccentricity": eccentricity(sxx, syy, sxy)}
