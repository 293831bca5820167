"""Threshold blob detector: dark (or light) blobs become point measurements.

A frame goes in, a table of measurements comes out. Each pixel's *contrast* against a
background estimate (local median, a given image, or the frame's median) is thresholded,
connected pixels form blobs, touching blobs are split, area limits drop dust and clutter, and
each blob is measured: contrast-weighted centroid, area, mean grey level, eccentricity.
Nothing here knows about tracking or files.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from seedtrack.data.depth import to_uint8, value_range

from .background import NOISE_FLOOR_SIGMAS, contrast_histogram, flat_background, local_background, noise_floor, otsu_above
from .localisation import centroid_error
from .split import split_touching

MEASUREMENT_COLUMNS = ("x", "y", "area", "mean_intensity", "eccentricity", "ep")
POLARITIES = ("dark", "light", "auto")
BACKGROUNDS = ("local", "none", "temporal")
THRESHOLD_METHODS = ("otsu", "adaptive")
# Niblack's adaptive threshold: local mean plus this many local standard deviations.
_ADAPTIVE_SIGMAS = 3.0


@dataclass(frozen=True)
class BlobOptions:
    """Options of :func:`detect_blobs`.

    Attributes
    ----------
    polarity : {"auto", "dark", "light"}
        Whether objects are darker or lighter than the background; "auto" picks the side with
        more contrast standing out of the noise.
    background : {"local", "none", "temporal"}
        "local": a median over windows of ``background_size`` pixels; "none": the frame's
        median grey level everywhere; "temporal": an image the caller passes (the median over
        time of a static scene, see :func:`seedtrack.detection.background.temporal_median`).
    background_size : float
        Window of the local background, pixels; must be well above an object's size.
    threshold : "otsu", "adaptive" or float
        "otsu": Otsu's level among the pixels whose contrast stands out of the noise;
        "adaptive": per pixel, the local mean plus 3 local standard deviations of the contrast
        (Niblack), never below the noise floor; a number: the smallest contrast of an object
        pixel, grey levels (0-255).
    min_area_px, max_area_px : float or None
        Blobs with fewer or more pixels are dropped; None leaves that side open, except that
        blobs covering more than ``max_area_fraction`` of the frame are always background.
    max_area_fraction : float
        Largest blob, as a fraction of the frame's pixels, that can be an object.
    split : bool
        Split blobs of touching objects (see :func:`seedtrack.detection.split.split_touching`).
    """

    polarity: str = "auto"
    background: str = "local"
    background_size: float = 40.0
    threshold: str | float = "otsu"
    min_area_px: float | None = 4.0
    max_area_px: float | None = None
    max_area_fraction: float = 0.01
    split: bool = True

    def __post_init__(self) -> None:
        if self.polarity not in POLARITIES:
            raise ValueError(f"polarity must be one of {', '.join(POLARITIES)}, got {self.polarity!r}")
        if self.background not in BACKGROUNDS:
            raise ValueError(f"background must be one of {', '.join(BACKGROUNDS)}, got {self.background!r}")
        if not 3 <= self.background_size <= 2000:
            raise ValueError(f"background_size must lie in 3..2000 px, got {self.background_size:g}")
        if isinstance(self.threshold, str):
            if self.threshold not in THRESHOLD_METHODS:
                raise ValueError(f"threshold must be otsu, adaptive or a number, got {self.threshold!r}")
        elif not 0 <= self.threshold <= 255:
            raise ValueError(f"threshold must lie in 0..255, got {self.threshold:g}")
        for name in ("min_area_px", "max_area_px"):
            value = getattr(self, name)
            if value is not None and value < 0:
                raise ValueError(f"{name} must not be negative, got {value:g}")
        if self.min_area_px is not None and self.max_area_px is not None and self.min_area_px > self.max_area_px:
            raise ValueError(f"min_area_px {self.min_area_px:g} exceeds max_area_px {self.max_area_px:g}")


def to_gray(image: np.ndarray) -> np.ndarray:
    """A uint8 grey-level view of an (H, W) or (H, W, 3) BGR frame of any depth (deeper data
    mapped from its range, see :func:`seedtrack.data.depth.value_range`).

    Example
    -------
    >>> int(to_gray(np.full((2, 2), 4095, np.uint16)).max())
    255
    """
    if image.dtype != np.uint8:
        image = to_uint8(image, value_range(image))
    if image.ndim == 3:
        return cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    return image


def background_of(gray: np.ndarray, options: BlobOptions, background: np.ndarray | None = None) -> np.ndarray:
    """The background estimate ``options`` ask for (``background`` for "temporal")."""
    if options.background == "temporal":
        if background is None:
            raise ValueError("a temporal background needs the background image")
        if background.shape != gray.shape:
            raise ValueError(f"background is {background.shape[1]}x{background.shape[0]}, the frame {gray.shape[1]}x{gray.shape[0]}")
        return background
    if options.background == "none":
        return flat_background(gray)
    return local_background(gray, options.background_size)


def choose_polarity(gray: np.ndarray, background: np.ndarray, roi: np.ndarray | None = None) -> str:
    """The polarity, "dark" or "light", whose contrast beyond the noise floor weighs more.

    Parameters
    ----------
    gray, background : ndarray of uint8, shape (H, W)
    roi : ndarray of uint8, shape (H, W), optional
        Nonzero where to look.
    """
    mass = {}
    for side, signal in (("dark", cv2.subtract(background, gray)), ("light", cv2.subtract(gray, background))):
        histogram = contrast_histogram(signal, roi)
        floor = noise_floor(histogram)
        levels = np.arange(256)
        mass[side] = float(np.sum(histogram * np.clip(levels - floor, 0, None)))
    return "dark" if mass["dark"] >= mass["light"] else "light"


def contrast(
    gray: np.ndarray, options: BlobOptions, background: np.ndarray | None = None, roi: np.ndarray | None = None, part: tuple[slice, slice] = np.s_[:, :]
) -> np.ndarray:
    """How far each pixel lies on the objects' side of the background, grey levels.

    Parameters
    ----------
    gray : ndarray of uint8, shape (H, W)
    options : BlobOptions
        Polarity and background.
    background : ndarray of uint8, shape (H, W), optional
        The background image when ``options.background`` is "temporal".
    roi : ndarray of uint8, shape (H, W), optional
        Contrast is zero where it is zero.
    part : tuple of slice, optional
        Rows and columns of the frame whose contrast is wanted (the background is still
        estimated on the whole frame, and the polarity, if "auto", decided there).

    Returns
    -------
    ndarray of uint8, shape (H, W), or that of ``part``

    Example
    -------
    >>> frame = np.full((40, 40), 200, np.uint8)
    >>> frame[10, 30] = 50
    >>> int(contrast(frame, BlobOptions(polarity="dark"), part=np.s_[5:15, 25:35])[5, 5])
    150
    """
    _check_roi(roi, gray)
    base = background_of(gray, options, background)
    polarity = options.polarity if options.polarity != "auto" else choose_polarity(gray, base, roi)
    gray, base = gray[part], base[part]
    # uint8 (saturating) so that whole-frame passes stay cheap.
    signal = cv2.subtract(base, gray) if polarity == "dark" else cv2.subtract(gray, base)
    if roi is not None:
        signal = cv2.bitwise_and(signal, signal, mask=roi[part])
    return signal


def eccentricity(sxx: np.ndarray, syy: np.ndarray, sxy: np.ndarray) -> np.ndarray:
    """Eccentricity of the ellipses with second central moments sxx, syy, sxy (0 for a circle)."""
    half_gap = np.sqrt(((sxx - syy) / 2) ** 2 + sxy**2)
    major, minor = (sxx + syy) / 2 + half_gap, np.maximum((sxx + syy) / 2 - half_gap, 0)
    return np.sqrt(1 - np.divide(minor, major, out=np.ones_like(major), where=major > 0))


def detect_blobs(
    image: np.ndarray,
    options: BlobOptions = BlobOptions(),
    *,
    background: np.ndarray | None = None,
    roi: np.ndarray | None = None,
    roi_box: tuple[int, int, int, int] | None = None,
) -> dict[str, np.ndarray]:
    """Find blobs in one frame and measure them.

    Parameters
    ----------
    image : ndarray of uint8, shape (H, W) or (H, W, 3) BGR
        The frame.
    options : BlobOptions
        Polarity, background, threshold, area limits, splitting.
    background : ndarray of uint8, shape (H, W), optional
        The background image when ``options.background`` is "temporal".
    roi : ndarray of uint8, shape (H, W), optional
        Region of interest: blobs are looked for only where it is nonzero.
    roi_box : tuple of int, optional
        ``cv2.boundingRect(roi)``, (x, y, width, height) in pixels, when known: found otherwise.

    Returns
    -------
    dict of str to ndarray
        ``x``, ``y``: contrast-weighted centroid, pixels (x to the right, y down, pixel
        centres at integer coordinates); ``area``: pixels in the blob; ``mean_intensity``:
        mean grey level (0-255) of the blob; ``eccentricity``: of the ellipse with the blob's
        second moments (0 round, towards 1 elongated); ``ep``: the centroid's localisation
        error from the contrast's noise, pixels per axis
        (:func:`seedtrack.detection.localisation.centroid_error`). Sorted by y, then x. Empty
        arrays when the frame holds no blob.
    """
    gray = to_gray(image)
    _check_roi(roi, gray)
    # Past the region's bounding box the contrast is zero and no pixel an object's: thresholding
    # and labelling are done within the box (a dish's is three fifths of its frame). Not with
    # the adaptive threshold, whose box filter would see the box's edges.
    top, left, bottom, right = _inner_box(roi, roi_box) if roi is not None and options.threshold != "adaptive" else (0, 0, *gray.shape)
    if bottom <= top or right <= left:
        return _empty()
    part = np.s_[top:bottom, left:right]
    signal = contrast(gray, options, background, roi, part)
    histogram = contrast_histogram(signal, roi[part] if roi is not None else None)
    level = _level(signal, options.threshold, options.background_size, histogram)
    mask = np.greater(signal, level) if np.ndim(level) else cv2.threshold(signal, level, 1, cv2.THRESH_BINARY)[1].view(bool)
    within = np.flatnonzero(mask)
    if within.size == 0:
        return _empty()
    count, labels = cv2.connectedComponents(mask.view(np.uint8), connectivity=8, ltype=cv2.CV_32S)
    label = labels.ravel()[within]
    weight = signal.ravel()[within] - (level if not np.ndim(level) else level.ravel()[within])
    rows, columns = np.divmod(within, right - left)
    inside = (rows + top) * gray.shape[1] + columns + left
    if options.split:
        label, count = split_touching(label, count, inside, gray.shape, weight, _area_limits(options, gray.size))
    noise = noise_floor(histogram) / NOISE_FLOOR_SIGMAS
    return _measure(label, count, inside, weight, gray, _area_limits(options, gray.size), noise)


def _check_roi(roi: np.ndarray | None, gray: np.ndarray) -> None:
    if roi is not None and roi.shape != gray.shape:
        raise ValueError(f"region of interest is {roi.shape[1]}x{roi.shape[0]}, the frame {gray.shape[1]}x{gray.shape[0]}")


def _inner_box(roi: np.ndarray, roi_box: tuple[int, int, int, int] | None) -> tuple[int, int, int, int]:
    """Top, left, bottom, right (exclusive) of the region's nonzero pixels, pixels; top and left
    rounded down to even, so that the contrast histogram's every other row and column are the
    frame's."""
    x, y, width, height = roi_box if roi_box is not None else cv2.boundingRect(roi)
    return y - y % 2, x - x % 2, y + height, x + width


def _level(signal: np.ndarray, threshold: str | float, window: float, histogram: np.ndarray) -> float | np.ndarray:
    """Contrast above which a pixel is an object pixel: a number, or a per-pixel map
    (``histogram``: :func:`~seedtrack.detection.background.contrast_histogram` of ``signal``)."""
    if not isinstance(threshold, str):
        return float(threshold)
    floor = noise_floor(histogram)
    if threshold == "otsu":
        return otsu_above(histogram, floor)
    contrast = signal.astype(np.float32)
    size = (int(window), int(window))
    mean = cv2.boxFilter(contrast, -1, size)
    spread = np.sqrt(np.maximum(cv2.boxFilter(contrast * contrast, -1, size) - mean * mean, 0))
    return np.maximum(mean + np.float32(_ADAPTIVE_SIGMAS) * spread, np.float32(floor))


def _area_limits(options: BlobOptions, frame_pixels: int) -> tuple[float, float]:
    low = options.min_area_px if options.min_area_px is not None else 0.0
    high = options.max_area_fraction * frame_pixels
    if options.max_area_px is not None:
        high = min(high, options.max_area_px)
    return low, high


def _measure(
    label: np.ndarray, count: int, inside: np.ndarray, weight: np.ndarray, gray: np.ndarray, limits: tuple[float, float], noise: float
) -> dict[str, np.ndarray]:
    """Per-blob measurements from the object pixels' labels (label 0 is never used); ``noise``
    is the contrast's noise standard deviation, grey levels."""
    area = np.bincount(label, minlength=count)[1:].astype(float)
    keep = (area >= limits[0]) & (area <= limits[1])
    if not keep.any():
        return _empty()
    rows, columns = np.divmod(inside, gray.shape[1])

    def total(values: np.ndarray | None) -> np.ndarray:
        return np.bincount(label, weights=values, minlength=count)[1:][keep]

    area = area[keep]
    mass = total(weight)
    x = total(weight * columns) / mass
    y = total(weight * rows) / mass
    intensity = total(gray.ravel()[inside].astype(float)) / area
    # Shape from the unweighted second moments about each blob's own centre of pixels.
    cx, cy = total(columns.astype(float)) / area, total(rows.astype(float)) / area
    sxx = total(columns * columns.astype(float)) / area - cx * cx
    syy = total(rows * rows.astype(float)) / area - cy * cy
    sxy = total(columns * rows.astype(float)) / area - cx * cy
    error = centroid_error({"mass": mass, "area": area, "x": x, "y": y, "cx": cx, "cy": cy, "sxx": sxx, "syy": syy}, noise)
    table = {"x": x, "y": y, "area": area, "mean_intensity": intensity, "eccentricity": eccentricity(sxx, syy, sxy), "ep": error}
    order = np.lexsort((table["x"], table["y"]))
    return {name: values[order] for name, values in table.items()}


def _empty() -> dict[str, np.ndarray]:
    return {name: np.empty(0) for name in MEASUREMENT_COLUMNS}
