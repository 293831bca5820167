"""Spot detector for small faint round spots (beads, particles, fluorescent dots).

The method of Crocker and Grier (J. Colloid Interface Sci. 179, 298, 1996), written here: the
frame is band-passed (a Gaussian of 1 px takes off pixel noise, a running mean over the spot's
diameter takes off the background), every local maximum of the band-passed frame is a candidate,
its centre is refined to sub-pixel by the brightness centroid over a disc of the spot's radius,
the disc following the centroid pixel by pixel until it sits within 0.6 px of it (the light
weighted by a Gaussian window of the spot's size, so that a touching neighbour does not pull the
centre over), and a spot is kept when its integrated brightness (*mass*, the band-passed frame
summed over the disc) stands well out of the noise, which is measured on the frame, not assumed;
when it stands above the wider background too; and when it is not the halo of a heavier spot.

Everything is computed in float32 on the data's own values, so 8-bit, 16-bit and float frames of
the same content give the same spots. The settings that describe the clip (the spot's diameter,
its polarity, the least mass) are fixed once per clip by :func:`fit_spot_settings` and passed in,
so :func:`detect_spots` is a function of one frame and those settings alone.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, replace

import cv2
import numpy as np
from scipy.spatial import cKDTree

from .blobs import MEASUREMENT_COLUMNS, eccentricity
from .localisation import windowed_centroid_error
from .structure import background_of

# Standard deviation of the Gaussian that takes off pixel noise, pixels (Crocker and Grier's
# lambda_n = 1).
_NOISE_SIGMA_PX = 1.0
# The disc is moved a pixel when the centroid lies further than this from its centre, pixels.
_SHIFT_PX = 0.6
# A spot's centre stands this many floors (band-passed noise deviations) above the wide
# background.
_STANDING_FLOORS = 2.0
# A spot within this many diameters of one this many times heavier is its halo, not a spot (the
# running mean over a diameter about a strong spot is pulled up, about a dark ring down; the
# wide-background test catches the halo further out), unless it stands out of the wide
# background as far as the noise's own maxima do only once per 10^5 pixels (a bead beside a
# brighter one).
_HALO_REACH = 1.0
_HALO_RATIO = 3.0
# Most moves of the disc per spot, and steps of the Gaussian-windowed centroid.
_MAX_ITERATIONS = 10
_WINDOW_ITERATIONS = 4
# The Gaussian window is this many of the spot's own measured sigmas wide (at least the clip's
# window); a windowed variance of more than this share of the window's is read as this share.
_WINDOW_PER_SIGMA = 2.0
_WIDEST_SEEN = 0.95
# The least mass is set so that white noise of the measured level gives this many false spots
# per pixel, measured on a generated frame of noise of this side with this seed; fewer where the
# frame holds so few spots that this many false ones would be more than this share of them.
_FALSE_SPOTS_PER_PIXEL = 1e-5
_FALSE_SHARE = 0.01
_CALIBRATION_SIZE = 1024
_CALIBRATION_SEED = 16
# Zero is the dark level of data whose background stands more than this many noise deviations
# above it (a Poisson background of at least one photon a pixel).
_DARK_LEVEL_SIGMAS = 1.0
# Immerkaer's noise filter: the difference of two discrete Laplacians.
_IMMERKAER = np.array([[1, -2, 1], [-2, 4, -2], [1, -2, 1]], np.float32)
# A pixel less the mean of its 8 neighbours: takes off smooth light like Immerkaer's filter but
# keeps 0.83 of the noise's skewness (the Laplacians' difference keeps a sixth).
_CENTRE_LESS_RING = np.full((3, 3), -1 / 8, np.float32)
_CENTRE_LESS_RING[1, 1] = 1
# The skewness is measured on residuals within this many of their standard deviations of their
# median (so that spots, whose residuals lie far out, hardly count); the skewnesses of the table
# that turns that into the noise's skewness.
_SKEW_WINDOW = 3.0
# False spots come from where the noise is strongest (Poisson noise grows with the light): the
# least mass is set for the noise of the noisiest tenth of squares of this side, pixels.
_NOISE_TILE = 32
_NOISIEST_PERCENT = 90
_SKEW_GRID = np.round(np.arange(0, 2.05, 0.1), 1)
# Candidates whose mass at the first disc is below this fraction of the least mass are dropped
# before refinement (speed only: a disc moved onto its spot gains far less than this).
_PREFILTER = 0.5
# Scales (Gaussian sigma, pixels) among which the spot size is looked for; at most this many of
# the strongest maxima vote.
_SIZE_SIGMAS = np.array([0.8, 1.0, 1.25, 1.6, 2.0, 2.5, 3.2, 4.0, 5.0])
# The 5-point Laplacian is the Laplacian plus a twelfth of each fourth derivative, which at a
# Gaussian's centre is the Laplacian of that Gaussian widened by 1/8 px^2 of variance: the
# responses are normalised by the scale it works at, else small spots read wide (1.0 as 1.09).
_STENCIL_VARIANCE = 1 / 8
_SIZE_VOTERS = 200
# Median absolute deviation of a normal distribution, in standard deviations.
_MAD_TO_SIGMA = 1.4826
# Spots stand apart from the noise's maxima when the sorted masses of the candidates jump by
# this factor (the heaviest noise maxima of a frame lie about 1.1 apart, spots of one kind 1.2).
_VALLEY_RATIO = 3.0
# The heaviest noise maxima of a frame lie at most this many times further above their median
# than white noise's once-per-10^5-pixels maxima lie above theirs (a small frame's heaviest are
# rarer, compression's a little heavier: 1.0 to 1.1 times on the frames it was set on).
_VALLEY_REACH = 2.0
# Spots whose discs would cover more than this share of the region are more than a spot detector
# expects: background taken for spots, or objects too crowded to tell apart.
_CROWDED_SHARE = 0.3
# Where the background is structured and its maxima show no valley below the objects', a least
# mass under this many times their typical mass is said to be unsafe (bulk water: precision 0.80
# against the beads marked by looking at 2 times, 0.89 at 3); above it (compressed generated
# spots, whose gap in the sorted masses set it at 8 to 10 times) it is not.
_SAFE_SNR = 2.0


@dataclass(frozen=True)
class SpotSettings:
    """What :func:`detect_spots` looks for, fixed once per clip.

    Attributes
    ----------
    diameter : int
        Spot diameter, pixels, odd: the refinement disc has radius ``diameter // 2`` and the
        background is a running mean over ``diameter`` pixels.
    min_mass : float
        Least integrated brightness of a spot: the band-passed frame summed over its disc, in
        the data's units times pixels.
    polarity : {"dark", "light"}
        Spots darker or lighter than the background.
    floor : float
        Band-passed level below which a pixel is background and weighs nothing, in the data's
        units (Crocker and Grier's clipping level; one noise standard deviation by default).
    standing : float
        How far above the wide background (the frame smoothed by 1 px, in the data's units) a
        spot within a diameter of one three times heavier must stand to count as a spot and
        not as that one's halo; infinite: never.
    background_mass : float
        Typical mass of the background's own maxima (see
        :func:`seedtrack.detection.structure.background_of`), 0 when not measured: the
        signal-to-background ratio is ``min_mass / background_mass``.
    unusual : str
        Why the first frame's count or background is unusual for the spot detector, in words;
        "" when it is not.
    noise : float
        Standard deviation of a raw pixel's noise, data units, for each spot's localisation
        error (``ep``); 0: measured on each frame.
    gain : float
        Data units per photon of the spots' own light (:func:`shot_gain`), whose shot noise
        adds to the localisation error; 0: none counted.
    """

    diameter: int
    min_mass: float
    polarity: str = "light"
    floor: float = 0.0
    standing: float = np.inf
    background_mass: float = 0.0
    unusual: str = ""
    noise: float = 0.0
    gain: float = 0.0

    def __post_init__(self) -> None:
        if int(self.diameter) != self.diameter or self.diameter < 3 or self.diameter % 2 == 0:
            raise ValueError(f"diameter must be an odd whole number >= 3 px, got {self.diameter:g}")
        if not np.isfinite(self.min_mass) or self.min_mass < 0:
            raise ValueError(f"min_mass must be finite and >= 0, got {self.min_mass:g}")
        if not np.isfinite(self.floor) or self.floor < 0:
            raise ValueError(f"floor must be finite and >= 0, got {self.floor:g}")
        if not (np.isfinite(self.noise) and self.noise >= 0 and np.isfinite(self.gain) and self.gain >= 0):
            raise ValueError(f"noise and gain must be finite and >= 0, got {self.noise:g}, {self.gain:g}")
        if np.isnan(self.standing) or self.standing < 0:
            raise ValueError(f"standing must be >= 0, got {self.standing:g}")
        if self.polarity not in ("dark", "light"):
            raise ValueError(f"polarity must be dark or light, got {self.polarity!r}")


def as_float_gray(image: np.ndarray) -> np.ndarray:
    """An (H, W) float32 grey frame, in the data's own units, from a grey or BGR frame of any depth.

    Example
    -------
    >>> as_float_gray(np.full((2, 3, 3), 1000, np.uint16)).dtype
    dtype('float32')
    """
    if image.ndim == 3:
        if image.shape[2] == 1:
            image = image[..., 0]
        else:
            depth = image if image.dtype in (np.uint8, np.uint16, np.float32) else image.astype(np.float32)
            image = cv2.cvtColor(depth[..., :3], cv2.COLOR_BGR2GRAY)
    return np.asarray(image, dtype=np.float32)


def band_pass(gray: np.ndarray, diameter: int, polarity: str = "light") -> np.ndarray:
    """The frame with pixel noise and background taken off, spots positive, the rest kept signed.

    Parameters
    ----------
    gray : ndarray, shape (H, W)
        Grey frame, any depth.
    diameter : int
        Spot diameter, pixels: the background is the running mean over this square.
    polarity : {"dark", "light"}
        Dark spots are turned positive.

    Returns
    -------
    ndarray of float32, shape (H, W)
        Gaussian(1 px) of the frame less its running mean, in the data's units; positive on spots.

    Example
    -------
    >>> frame = np.zeros((21, 21), np.float32); frame[10, 10] = 100
    >>> bool(band_pass(frame, 7)[10, 10] > 0)
    True
    """
    return _band_and_smooth(gray, diameter, polarity)[0]


def _band_and_smooth(gray: np.ndarray, diameter: int, polarity: str) -> tuple[np.ndarray, np.ndarray]:
    """:func:`band_pass` and the frame smoothed by the noise Gaussian, both spots positive."""
    signal = np.asarray(gray, np.float32)
    if polarity == "dark":
        signal = np.negative(signal)
    smooth = cv2.GaussianBlur(signal, (0, 0), _NOISE_SIGMA_PX, borderType=cv2.BORDER_REFLECT)
    background = cv2.boxFilter(signal, -1, (diameter, diameter), borderType=cv2.BORDER_REFLECT)
    return cv2.subtract(smooth, background, dst=background), smooth


def _wide_background(smooth: np.ndarray, diameter: int, rows: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """The background over about 4 diameters at the given pixels: a 5 x 5 median of a copy
    shrunk that much (a median, so that spots and dark rings barely move it), read off with
    bilinear interpolation."""
    height, width = smooth.shape
    shrink = max(1, min(int(round(4 * diameter / 5)), height // 5, width // 5))
    small = cv2.medianBlur(cv2.resize(smooth, (max(1, width // shrink), max(1, height // shrink)), interpolation=cv2.INTER_AREA), 5)
    # Pixel centres of the shrunk copy sit at (i + 0.5) * scale - 0.5 in the frame.
    u = np.clip((columns + 0.5) * small.shape[1] / width - 0.5, 0, small.shape[1] - 1)
    v = np.clip((rows + 0.5) * small.shape[0] / height - 0.5, 0, small.shape[0] - 1)
    u0, v0 = np.minimum(u.astype(int), small.shape[1] - 2).clip(0), np.minimum(v.astype(int), small.shape[0] - 2).clip(0)
    fu, fv = u - u0, v - v0
    u1, v1 = np.minimum(u0 + 1, small.shape[1] - 1), np.minimum(v0 + 1, small.shape[0] - 1)
    top = small[v0, u0] * (1 - fu) + small[v0, u1] * fu
    bottom = small[v1, u0] * (1 - fu) + small[v1, u1] * fu
    return top * (1 - fv) + bottom * fv


@functools.lru_cache(maxsize=None)
def _disc(radius: int) -> tuple[np.ndarray, np.ndarray]:
    """Row and column offsets of the pixels within ``radius`` of a centre."""
    dy, dx = np.mgrid[-radius : radius + 1, -radius : radius + 1]
    inside = dx * dx + dy * dy <= radius * radius
    return dy[inside], dx[inside]


def pixel_noise(gray: np.ndarray, roi: np.ndarray | None = None) -> float:
    """Standard deviation of the pixel noise of a frame, in the data's units.

    Immerkaer's estimator (Computer Vision and Image Understanding 64, 300, 1996): the frame
    filtered by the difference of two discrete Laplacians, which takes off anything smooth
    (light, background, most of each spot) and keeps pixel noise, whose mean absolute value is
    sqrt(2/pi) times 6 sigma. Integer data are never taken for less noisy than their own
    rounding: one step of their values (1 for 8- or 16-bit data, 257 for 8-bit data stored in
    16 bits) over sqrt(12).

    Parameters
    ----------
    gray : ndarray, shape (H, W)
        Grey frame, any depth.
    roi : ndarray of uint8, shape (H, W), optional
        Nonzero where to measure.

    Returns
    -------
    float

    Example
    -------
    >>> rng = np.random.default_rng(0)
    >>> round(pixel_noise(rng.normal(100, 4, (200, 200))), 1)
    4.0
    """
    values = np.asarray(gray)
    residual = cv2.filter2D(values.astype(np.float32), -1, _IMMERKAER)[1:-1, 1:-1]
    if roi is not None:
        residual = residual[roi[1:-1, 1:-1] > 0]
    sigma = float(np.sqrt(np.pi / 2) * np.mean(np.abs(residual)) / 6) if residual.size else 0.0
    if values.dtype.kind in "iu":
        sample = np.unique(values[::7, ::7])
        step = float(np.min(np.diff(sample))) if sample.size > 1 else 1.0
        sigma = max(sigma, step / np.sqrt(12))
    return sigma


def band_noise(gray: np.ndarray, diameter: int, polarity: str = "light", roi: np.ndarray | None = None) -> float:
    """The band-passed frame's noise (:func:`band_pass`), data units: the spread of its values
    about their median (the median absolute deviation, in standard deviations, so that spots,
    a small share of the pixels, hardly count).

    This is the noise at the scale a spot's centroid sees it. Compression takes off the fine,
    pixel-to-pixel noise that :func:`pixel_noise` reads, and keeps the coarser noise that moves
    centroids: through JPEG at quality 75, spots whose centres were off by 0.17 px were given
    0.03 px from the pixel noise.

    Example
    -------
    >>> rng = np.random.default_rng(0)
    >>> round(band_noise(rng.normal(100, 4, (200, 200)), 9) / band_noise(rng.normal(100, 1, (200, 200)), 9), 1)
    4.0
    """
    values = band_pass(gray, diameter, polarity)
    if roi is not None:
        values = values[roi > 0]
    if values.size == 0:
        return 0.0
    return float(_MAD_TO_SIGMA * np.median(np.abs(values - np.median(values))))


def shot_gain(gray: np.ndarray, noise: float, polarity: str, roi: np.ndarray | None = None) -> float:
    """Data units per photon, at most: the background's noise variance over its level, as if
    all of it were the shot noise of light counted from zero (a camera's offset or read noise
    make the true gain smaller). 0 for dark spots (less light, less shot noise than around
    them) and where zero is not the dark level (the background within one noise deviation of
    it: a background taken off, signed data).

    Example
    -------
    >>> rng = np.random.default_rng(0)
    >>> frame = rng.poisson(40.0, (200, 200)).astype(np.float32) * 2.5   # 2.5 units a photon
    >>> round(shot_gain(frame, pixel_noise(frame), "light"), 1)
    2.5
    """
    if polarity != "light":
        return 0.0
    values = np.asarray(gray)[::4, ::4] if roi is None else np.asarray(gray)[::4, ::4][roi[::4, ::4] > 0]
    level = float(np.median(values)) if values.size else 0.0
    return noise * noise / level if level > _DARK_LEVEL_SIGMAS * noise else 0.0


def _noisiest_level(gray: np.ndarray, roi: np.ndarray | None) -> float:
    """Immerkaer's noise level over squares of :data:`_NOISE_TILE` pixels, the 90th percentile."""
    residual = np.abs(cv2.filter2D(np.asarray(gray, np.float32), -1, _IMMERKAER)) * np.float32(np.sqrt(np.pi / 2) / 6)
    centres = slice(_NOISE_TILE // 2, None, _NOISE_TILE)
    local = cv2.blur(residual, (_NOISE_TILE, _NOISE_TILE), borderType=cv2.BORDER_REFLECT)[centres, centres]
    if roi is not None:
        local = local[roi[centres, centres] > 0]
    return float(np.percentile(local, _NOISIEST_PERCENT)) if local.size else 0.0


def noise_skewness(gray: np.ndarray, roi: np.ndarray | None = None) -> float:
    """Skewness of the pixel noise of a frame, towards the light (0 for Gaussian noise).

    A camera on a dark scene counts a few photons a pixel: its noise is skewed towards bright
    (Poisson noise of mean m has skewness 1 / sqrt(m)), and its bright excursions make false
    spots far more often than Gaussian noise of the same standard deviation. The skewness is
    read off the residuals of each pixel less the mean of its neighbours, those within 3 of
    their standard deviations of their median only (a spot's residuals lie further out), by
    matching that trimmed skewness to the one gamma-distributed noise gives (a table made once
    on generated noise). Rounded to 0.1, between 0 (never taken for lighter-tailed than
    Gaussian) and 2 (exponential noise).

    Parameters
    ----------
    gray : ndarray, shape (H, W)
        Grey frame, any depth, spots positive.
    roi : ndarray of uint8, shape (H, W), optional
        Nonzero where to measure.

    Returns
    -------
    float

    Example
    -------
    >>> rng = np.random.default_rng(0)
    >>> noise_skewness(rng.normal(100, 5, (256, 256))), noise_skewness(rng.poisson(2.0, (256, 256)) * 7.0)
    (0.0, 0.8)
    """
    statistic = _trimmed_skewness(np.asarray(gray, np.float32), roi)
    table = _trimmed_skewness_table()
    return round(float(np.interp(statistic, table, _SKEW_GRID)), 1)


def _trimmed_skewness(gray: np.ndarray, roi: np.ndarray | None) -> float:
    residual = cv2.filter2D(gray, -1, _CENTRE_LESS_RING)[1:-1, 1:-1]
    if roi is not None:
        residual = residual[roi[1:-1, 1:-1] > 0]
    residual = residual.ravel()
    if residual.size < 16:
        return 0.0
    centre = float(_median(residual))
    spread = _MAD_TO_SIGMA * float(_median(np.abs(residual - centre)))
    kept = residual[np.abs(residual - centre) < _SKEW_WINDOW * spread]
    deviation = float(np.std(kept)) if kept.size >= 16 else 0.0
    if deviation == 0:
        # No noise to speak of (a drawn frame): nothing to skew the least mass.
        return 0.0
    return float(np.mean(((kept - kept.mean()) / deviation) ** 3))


@functools.lru_cache(maxsize=None)
def _trimmed_skewness_table() -> np.ndarray:
    """The trimmed skewness of gamma noise of each skewness of the grid (fixed seed)."""
    return np.maximum.accumulate([_trimmed_skewness(_unit_noise((256, 256), skewness), None) for skewness in _SKEW_GRID])


def _unit_noise(shape: tuple[int, int], skewness: float) -> np.ndarray:
    """White noise of zero mean, unit standard deviation and this skewness: Gaussian at 0, else
    gamma-distributed (shape 4 / skewness^2), as photon counts are."""
    rng = np.random.default_rng(_CALIBRATION_SEED)
    if skewness <= 0:
        return rng.standard_normal(shape).astype(np.float32)
    k = 4 / skewness**2
    return ((rng.standard_gamma(k, shape) - k) / np.sqrt(k)).astype(np.float32)


@functools.lru_cache(maxsize=None)
def _unit_noise_levels(diameter: int, skewness: float = 0.0) -> tuple[float, float, float, float, float]:
    """(floor, least mass, tail, median mass, standing) for white noise of unit standard
    deviation and this skewness at this diameter.

    The floor is the band-passed noise's standard deviation; the least mass is the mass that
    the noise's own local maxima exceed once per 10^5 pixels, found on a frame of generated
    noise (fixed seed, so always the same); the tail is how much more mass they exceed ten
    times more rarely (measured between once per 10^4 and once per 10^5 pixels); the median
    mass is their median; the standing is how far above the wide background they stand once per
    10^5 pixels.
    """
    noise = _unit_noise((_CALIBRATION_SIZE, _CALIBRATION_SIZE), skewness)
    band, smooth = _band_and_smooth(noise, diameter, "light")
    floor = float(np.std(band[diameter:-diameter, diameter:-diameter]))
    found = detect_spots(noise, SpotSettings(diameter, 0.0, "light", floor), localise=False)
    masses = np.sort(found["mass"])[::-1]
    least = float(masses[int(_FALSE_SPOTS_PER_PIXEL * noise.size)])
    rows, columns = np.round(found["y"]).astype(int), np.round(found["x"]).astype(int)
    standing = np.sort(smooth[rows, columns] - _wide_background(smooth, diameter, rows, columns))[::-1]
    return (
        floor,
        least,
        least - float(masses[int(10 * _FALSE_SPOTS_PER_PIXEL * noise.size)]),
        float(np.median(masses)),
        float(standing[int(_FALSE_SPOTS_PER_PIXEL * noise.size)]),
    )


def _valley(masses: np.ndarray, reach: float) -> float:
    """The least mass in the valley between the noise's maxima and the spots, 0 when there is none.

    Above the median candidate (the noise's maxima are most of the candidates) the sorted masses
    are looked through for the first gap of :data:`_VALLEY_RATIO` times: the spots form a mode of
    their own above it when the mass below it (the heaviest of the noise) lies no more than
    ``reach`` times the median above the median, as white noise's heaviest do. The valley's
    middle on a log scale is as far from either side as can be.
    """
    if masses.size < 2:
        return 0.0
    masses = np.sort(masses)
    median = float(np.median(masses))
    upper = masses[masses >= median]
    ratio = upper[1:] / np.maximum(upper[:-1], np.finfo(np.float64).tiny)
    gaps = np.flatnonzero(ratio >= _VALLEY_RATIO)
    if gaps.size == 0 or upper[gaps[0]] > reach * median:
        return 0.0
    return float(np.sqrt(upper[gaps[0]] * upper[gaps[0] + 1]))


@dataclass(frozen=True)
class SpotShape:
    """Size and shape of the strongest spots of a frame (see :func:`spot_shape`).

    Attributes
    ----------
    sigma : float
        Their Gaussian standard deviation, pixels (the median over them).
    elongation : float
        Median ratio of their curvatures across and along (1 round, 2 for a spot twice as long
        as wide, measured at the spot's own scale).
    diameter : int
        2 round(3 sigma) + 1, at least 3: the disc then holds 99% of a Gaussian spot's light.
    """

    sigma: float
    elongation: float
    diameter: int


def spot_shape(gray: np.ndarray, polarity: str = "light", roi: np.ndarray | None = None) -> SpotShape:
    """Size and shape of the strongest spots, from the scale space of the frame.

    The scale-normalised Laplacian of Gaussian of a Gaussian spot of sigma s peaks at scale s
    (read between the scales of a grid by a parabola over log-scale); at each of the strongest
    maxima over position and scale, the Hessian's two eigenvalues give the spot's elongation.
    The strongest are those that stand furthest out of the noise at their scale (the response
    over its spread over the frame at that scale, measured): pixel noise makes the largest
    normalised responses at the smallest scales, so that faint spots' own responses would be
    outvoted by the noise's.

    Parameters
    ----------
    gray : ndarray, shape (H, W)
        A grey frame, any depth.
    polarity : {"dark", "light"}
    roi : ndarray of uint8, shape (H, W), optional
        Nonzero where to look.

    Returns
    -------
    SpotShape

    Example
    -------
    >>> rows, columns = np.mgrid[0:64, 0:64]
    >>> spot = 50 * np.exp(-((columns - 31.0) ** 2 + (rows - 30.0) ** 2) / (2 * 2.0**2))
    >>> spot_shape(spot.astype(np.float32)).diameter
    13
    """
    signal = np.asarray(gray, np.float32) if polarity == "light" else -np.asarray(gray, np.float32)
    smoothed = [cv2.GaussianBlur(signal, (0, 0), float(sigma), borderType=cv2.BORDER_REFLECT) for sigma in _SIZE_SIGMAS]
    # Written in place, scale by scale: at 1280x960 each float64 copy of the stack is 88 MB, and
    # making and filling those copies took a third of the first frame's decisions.
    stack = np.empty((len(_SIZE_SIGMAS), *signal.shape))
    for sigma, image, response in zip(_SIZE_SIGMAS, smoothed, stack):
        np.multiply(-(sigma**2 + _STENCIL_VARIANCE), cv2.Laplacian(image, cv2.CV_32F, ksize=1), out=response)
    spread = _response_spread(stack, roi)
    best = stack[0] / spread[0]
    for response, scale in zip(stack[1:], spread[1:]):
        np.maximum(best, response / scale, out=best)
    if roi is not None:
        best = np.where(roi > 0, best, 0)
    peaks = (best == cv2.dilate(best, np.ones((5, 5), np.uint8))) & (best > 0)
    rows, columns = np.nonzero(peaks)
    if rows.size == 0:
        return SpotShape(float(_SIZE_SIGMAS[0]), 1.0, 3)
    response = best[rows, columns]
    order = np.argsort(response)[::-1]
    # The objects vote, not the noise: maxima at least half as strong as the strongest, each by
    # its strength, so that a small static mark beside one bright spot does not outvote it.
    bar = 0.5 * float(response[order[0]])
    strongest = order[: min(_SIZE_VOTERS, int(np.sum(response >= bar)))]
    rows, columns = rows[strongest], columns[strongest]
    level = np.argmax(stack[:, rows, columns], axis=0)
    ratios = np.empty(rows.size)
    for k in np.unique(level):
        here = level == k
        image = smoothed[k]
        hxx = cv2.Sobel(image, cv2.CV_32F, 2, 0, ksize=3)[rows[here], columns[here]]
        hyy = cv2.Sobel(image, cv2.CV_32F, 0, 2, ksize=3)[rows[here], columns[here]]
        hxy = cv2.Sobel(image, cv2.CV_32F, 1, 1, ksize=3)[rows[here], columns[here]]
        half_gap = np.sqrt(((hxx - hyy) / 2) ** 2 + hxy**2)
        # A bright spot curves down both ways: across is the stronger curvature.
        across, along = -((hxx + hyy) / 2 - half_gap), -((hxx + hyy) / 2 + half_gap)
        ratios[here] = np.where(along > 0, across / np.maximum(along, 1e-12), np.inf)
    sigma = float(np.median(_peak_scale(stack[:, rows, columns], level)))
    return SpotShape(sigma, _weighted_median(ratios, response[strongest]), max(3, 2 * int(np.floor(3 * sigma + 0.5)) + 1))


def _peak_scale(responses: np.ndarray, level: np.ndarray) -> np.ndarray:
    """Each column's scale of greatest response, between the grid's scales: the vertex of the
    parabola through the responses at the best scale and its two neighbours, over log-scale (a
    Gaussian spot's normalised response is symmetric in log-scale about its sigma). At the
    grid's ends, the end's scale."""
    u = np.log(_SIZE_SIGMAS)
    sigma = _SIZE_SIGMAS[level].astype(float)
    inner = (level > 0) & (level < len(u) - 1)
    k = level[inner]
    columns = np.nonzero(inner)[0]
    x0, x1, x2 = u[k - 1], u[k], u[k + 1]
    y0, y1, y2 = (responses[k + d, columns].astype(float) for d in (-1, 0, 1))
    # The parabola's coefficients of u^2 and u, both times (x0 - x1)(x0 - x2)(x1 - x2) < 0, so
    # that it opens downwards where ``bend`` > 0.
    bend = x2 * (y1 - y0) + x1 * (y0 - y2) + x0 * (y2 - y1)
    slope = x2**2 * (y0 - y1) + x1**2 * (y2 - y0) + x0**2 * (y1 - y2)
    vertex = np.where(bend > 0, -slope / (2 * np.where(bend > 0, bend, 1.0)), x1)
    sigma[inner] = np.exp(np.clip(vertex, x0, x2))
    return sigma


def _response_spread(stack: np.ndarray, roi: np.ndarray | None) -> np.ndarray:
    """Each scale's spread of responses over the frame (median absolute deviation as a standard
    deviation, on every other pixel each way): the noise's, as spots cover little of a frame.
    All ones where a scale shows none (a frame without noise), so that its responses are taken
    as they are."""
    sample = stack[:, ::2, ::2]
    values = sample[:, roi[::2, ::2] > 0] if roi is not None else sample.reshape(len(stack), -1)
    if values.shape[1] == 0:
        return np.ones(len(stack), np.float32)
    centre = _median(values)
    spread = _MAD_TO_SIGMA * _median(np.abs(values - centre[:, None]))
    return spread.astype(np.float32) if np.all(spread > 0) else np.ones(len(stack), np.float32)


def _median(values: np.ndarray) -> np.ndarray:
    """``np.median(values, axis=-1)`` of a float array, the same numbers: a third to a sixth of
    its time on a frame's values, for which it partitions at three places (the two middle ones
    and the last, to find NaN) where one and a maximum do.

    Example
    -------
    >>> _median(np.array([[3.0, 1.0, 2.0, 8.0], [1.0, np.nan, 0.0, 2.0]])).tolist()
    [2.5, nan]
    """
    half = values.shape[-1] // 2
    part = np.partition(values, half, axis=-1)
    middle = part[..., half] if values.shape[-1] % 2 else (part[..., :half].max(axis=-1) + part[..., half]) / 2
    return np.where(np.isnan(values).any(axis=-1), np.nan, middle)


def _weighted_median(values: np.ndarray, weights: np.ndarray) -> float:
    """The value below which half the weight lies (the lower of two when it falls between)."""
    order = np.argsort(values, kind="stable")
    cumulative = np.cumsum(weights[order])
    return float(values[order][np.searchsorted(cumulative, 0.5 * cumulative[-1])])


def fit_spot_settings(
    gray: np.ndarray, polarity: str, *, diameter: int | None = None, roi: np.ndarray | None = None, snr: float | None = None
) -> SpotSettings:
    """The clip's spot settings from one frame.

    The diameter is estimated (:func:`spot_shape`) unless given. The noise's level and skewness
    are measured (:func:`pixel_noise`, :func:`noise_skewness`); for the spots' localisation
    error, the noise is also read at the spots' scale (:func:`band_noise`, as the white noise
    that band-passes to it), which compression keeps, and the larger taken. The floor is the band-passed
    level of white noise of that level; the least mass is the mass at which white noise of that
    skewness, at the level of the noisiest tenth of the frame (squares of 32 px), makes one false
    spot per 10^5 pixels (about 3 in a 640 x 512 frame), or one per hundred of the spots this
    frame holds when that is rarer (a few spots in a small frame, as in TrackMate's FakeTracks:
    the noise's mass tail is continued at the slope it has between once per 10^4 and once per
    10^5 pixels, which errs high for tails as light as or lighter than exponential). Where the
    masses of the frame's candidates show the spots as a mode of their own above the noise's
    maxima (a jump of 3 times in the sorted masses, just above a noise-like tail), the least mass
    is no lower than the middle of that valley: compression takes off the fine noise the level is
    read from, and its blocks make maxima far heavier than that level's noise would. A spot
    beside one three times heavier is taken for a bead, not its halo, when it stands above the
    wide background as far as the noise's maxima (of that skewness, at that level) do once per
    10^5 pixels.

    Real footage has structured background (out-of-focus blur, compression blocks, uneven
    light), whose maxima white noise does not describe. Where the candidates' masses show the
    background's maxima as a mode at least 3 times heavier than white noise's median, and the
    objects as a second mode above a dip in the density of log mass, the least mass is no lower
    than where a candidate becomes more likely an object than background (two normal components
    fitted to the log masses; :func:`seedtrack.detection.structure.background_of`). ``snr`` (the signal-to-background
    ratio), when given, sets the least mass to ``snr`` times the background's typical maximum
    instead.

    Example
    -------
    >>> rng = np.random.default_rng(0)
    >>> fit_spot_settings(rng.normal(100, 5, (100, 100)), "light", diameter=7).diameter
    7
    """
    if diameter is None:
        diameter = spot_shape(gray, polarity, roi).diameter
    sigma = pixel_noise(gray, roi)
    strongest = max(sigma, _noisiest_level(gray, roi))
    signal = np.asarray(gray, np.float32) if polarity == "light" else -np.asarray(gray, np.float32)
    floor, mass, tail, median, standing = _unit_noise_levels(int(diameter), noise_skewness(signal, roi))
    noise = max(sigma, band_noise(gray, int(diameter), polarity, roi) / floor)
    settings = SpotSettings(
        diameter=int(diameter), min_mass=mass * strongest, polarity=polarity, floor=floor * sigma, standing=standing * strongest,
        noise=noise, gain=shot_gain(gray, sigma, polarity, roi),
    )
    pixels = int(np.count_nonzero(roi)) if roi is not None else np.asarray(gray).shape[0] * np.asarray(gray).shape[1]
    # Every candidate's mass: a spot's is decided by heavier ones only, so those above the least
    # mass are the spots the least mass finds.
    candidates = detect_spots(gray, replace(settings, min_mass=0.0), roi=roi, localise=False)["mass"]
    spots = int(np.count_nonzero(candidates > settings.min_mass))
    allowed = _FALSE_SHARE * spots / max(pixels, 1)
    if 0 < allowed < _FALSE_SPOTS_PER_PIXEL:
        settings = replace(settings, min_mass=float((mass + tail * np.log10(_FALSE_SPOTS_PER_PIXEL / allowed)) * strongest))
    # Compression takes off the fine noise the level is read from and leaves blocks and blotches
    # that make heavier maxima than that level's noise would: where the candidates' masses show
    # the spots apart from the noise, the least mass is never below the valley between them.
    settings = replace(settings, min_mass=max(settings.min_mass, _valley(candidates, _VALLEY_REACH * mass / median)))
    background = background_of(candidates, median * strongest)
    least = max(settings.min_mass, background.valley if background.structured else 0.0) if snr is None else snr * background.mass
    settings = replace(settings, min_mass=float(least), background_mass=background.mass)
    unusual = ""
    if background.structured and not background.valley and snr is None and least < _SAFE_SNR * background.mass:
        unusual = (
            f"the background's own maxima (typical mass {background.mass:.3g}, {background.mass / (median * strongest):.0f} times white"
            f" noise's) show no valley below heavier objects, and the least mass is snr {least / background.mass:.2g} of them:"
            " spots may be background; raise the signal-to-background ratio (--snr) if so"
        )
    covered = np.count_nonzero(candidates > settings.min_mass) * len(_disc(settings.diameter // 2)[0]) / max(pixels, 1)
    if covered > _CROWDED_SHARE and not unusual:
        unusual = f"spots would cover {covered:.0%} of the frame, more than spots do: background may be taken for spots; raise the signal-to-background ratio (--snr) if so"
    return replace(settings, unusual=unusual)


def detect_spots(
    image: np.ndarray, settings: SpotSettings, *, roi: np.ndarray | None = None, background: np.ndarray | None = None, localise: bool = True
) -> dict[str, np.ndarray]:
    """Find spots in one frame and measure them (Crocker and Grier).

    Parameters
    ----------
    image : ndarray, shape (H, W) or (H, W, 3) BGR
        The frame, of any depth (uint8, uint16, float).
    settings : SpotSettings
        Diameter, least mass and polarity of the clip (see :func:`fit_spot_settings`).
    roi : ndarray of uint8, shape (H, W), optional
        Spots are looked for only where it is nonzero.
    background : ndarray, shape (H, W), optional
        A static scene's background (the median over time) to take off first: what never
        moves is then no spot.
    localise : bool
        Measure each spot's localisation error (``ep``; NaN when not).

    Returns
    -------
    dict of str to ndarray
        ``x``, ``y``: brightness centroid over the spot's disc, pixels (x to the right, y down,
        pixel centres at integer coordinates); ``area``: pixels of the disc that are brighter
        than the background; ``mean_intensity``: mean grey level of those pixels, in the data's
        units; ``eccentricity``: of the brightness's second moments (0 round); ``mass``: the
        integrated brightness, data units times pixels; ``ep``: the centre's localisation error,
        pixels per axis (:func:`seedtrack.detection.localisation.windowed_centroid_error`, with
        ``settings.noise`` and ``settings.gain``). Sorted by y, then x.

    Example
    -------
    >>> rows, columns = np.mgrid[0:40, 0:40]
    >>> frame = (20 + 80 * np.exp(-((columns - 20.3) ** 2 + (rows - 15.6) ** 2) / 4.5)).astype(np.float32)
    >>> found = detect_spots(frame, SpotSettings(diameter=9, min_mass=50))
    >>> round(float(found["x"][0]), 1), round(float(found["y"][0]), 1)
    (20.3, 15.6)
    """
    gray = as_float_gray(image)
    if background is not None:
        gray = gray - as_float_gray(background)
    if roi is not None and roi.shape != gray.shape:
        raise ValueError(f"region of interest is {roi.shape[1]}x{roi.shape[0]}, the frame {gray.shape[1]}x{gray.shape[0]}")
    diameter = settings.diameter
    radius = diameter // 2
    band, smooth = _band_and_smooth(gray, diameter, settings.polarity)
    # Only light standing out of the noise counts for centroids and mass (Crocker and Grier
    # clip the band-passed frame at a low level). It is written inside a border of zeros
    # ``radius`` wide, so that a disc about any pixel of the frame can be read without clipping.
    height, width = gray.shape
    padded = np.empty((height + 2 * radius, width + 2 * radius), np.float32)
    padded[:radius], padded[-radius:], padded[:, :radius], padded[:, -radius:] = 0, 0, 0, 0
    positive = cv2.threshold(band, settings.floor, 0, cv2.THRESH_TOZERO, dst=padded[radius:-radius, radius:-radius])[1]
    if roi is not None:
        positive[roi == 0] = 0
    # A candidate is the brightest pixel of the square of side 1.6 radii about it (two fast
    # 1-D passes), so that touching spots, whose peaks lie about a diameter apart, both count;
    # the maxima of one spot that this leaves meet when refined and are merged.
    side = 2 * int(np.ceil(0.8 * radius)) + 1
    local_max = cv2.dilate(positive, np.ones((side, side), np.uint8))
    # numpy's nonzero is four times as fast as OpenCV's on a mask of booleans.
    peaks = np.logical_and(cv2.compare(positive, local_max, cv2.CMP_EQ), cv2.compare(positive, 0.0, cv2.CMP_GT))
    rows, columns = np.divmod(np.flatnonzero(peaks), width)
    if rows.size == 0:
        return _empty()
    dy, dx = _disc(radius)
    # diameter - 1 is 6 sigma of the spot: a window of 1.5 sigma, wide enough that a defocused
    # bead's centre does not hop between its lobes, narrow enough to keep a neighbour out.
    window = (diameter - 1) / 4
    rows, columns, mass, weights = _refine(padded, rows, columns, dy, dx, settings.min_mass, window)
    keep = mass > settings.min_mass
    rows, columns, mass, weights = rows[keep], columns[keep], mass[keep], weights[keep]
    # A spot is lighter than the wide background around it, not only than the running mean
    # over its diameter, which a dark ring pulls down into a light halo about it.
    wide = _wide_background(smooth, diameter, rows, columns)
    standing = smooth[rows, columns] - wide
    keep = standing > _STANDING_FLOORS * settings.floor
    rows, columns, mass, weights, wide = rows[keep], columns[keep], mass[keep], weights[keep], wide[keep]
    if rows.size == 0:
        return _empty()
    ox, oy, own = _centroid(weights, dx, dy, window)
    x, y = columns + ox, rows + oy
    x, y, order = _without_duplicates(x, y, mass, radius, standing[keep] > settings.standing)
    weights, rows, columns = weights[order], rows[order], columns[order]
    # The frame's values over each disc, the edge pixels repeated beyond the frame (the border
    # makes one flat look-up of what would be clipped row and column indices).
    edged = cv2.copyMakeBorder(gray, radius, radius, radius, radius, cv2.BORDER_REPLICATE)
    raw = edged.ravel()[(rows * edged.shape[1] + columns)[:, None] + (dy + radius) * edged.shape[1] + dx + radius]
    if localise:
        noise = settings.noise if settings.noise > 0 else pixel_noise(gray, roi)
        above = (raw if settings.polarity == "light" else -raw) - wide[order, None]
        error = windowed_centroid_error(weights, above, dx, dy, ox[order], oy[order], own[order], _NOISE_SIGMA_PX, noise, settings.gain)
    else:
        error = np.full(rows.size, np.nan)
    ex, ey = dx[None, :] - ox[order, None], dy[None, :] - oy[order, None]
    total = mass[order]
    sxx, syy, sxy = ((weights * e).sum(axis=1) / total for e in (ex * ex, ey * ey, ex * ey))
    lit = weights > 0
    area = lit.sum(axis=1).astype(float)
    intensity = np.where(lit, raw, 0).sum(axis=1) / np.maximum(area, 1)
    table = {
        "x": x,
        "y": y,
        "area": area,
        "mean_intensity": intensity.astype(float),
        "eccentricity": eccentricity(sxx, syy, sxy),
        "mass": total.astype(float),
        "ep": error,
    }
    order = np.lexsort((table["x"], table["y"]))
    return {name: values[order] for name, values in table.items()}


def _centroid(weights: np.ndarray, dx: np.ndarray, dy: np.ndarray, window: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Brightness centroid of each disc (offsets from its centre, pixels) and the window it
    ends with (standard deviation, pixels), each pixel's light
    weighted by a Gaussian window about the estimate, iterated from the disc's centre towards a
    fixed point.

    A flat disc weighs every pixel alike: the noise far from the centre moves the centroid as
    much as the light at it, and a touching neighbour's light pulls it over. The Gaussian
    window (the Gaussian mask estimator, Thompson, Larson and Webb 2002) weighs pixels as the
    spot's own light does, close to the best a centroid can do on a Gaussian spot. Its width
    follows each spot's own size, as Crocker and Grier measure it from the second moment: at
    the first step, under the clip's ``window``, the spot's light is measured along its
    narrowest axis (a touching neighbour widens the other one only) and the window's shrinking
    taken off (a Gaussian of variance v seen through a window of variance w^2 shows
    v w^2 / (v + w^2)); the window is then :data:`_WINDOW_PER_SIGMA` times that, never
    narrower than ``window``. A wide, out-of-focus bead is then centred on its whole light,
    not on the part of it nearest where the disc began.
    """
    radius = int(dx.max())
    span = np.arange(-radius, radius + 1, dtype=np.float32)
    # One product gives each disc's light and its two first moments, another (at the first
    # step) its three second ones: two products of three columns stay on one thread of the
    # linear algebra library, where one of six would be spread over all cores at twice the CPU.
    first = np.stack([np.ones_like(dx), dx, dy], axis=1).astype(np.float32)
    second = np.stack([dx * dx, dy * dy, dx * dy], axis=1).astype(np.float32)
    windowed = np.empty_like(weights)
    column, row = dx + radius, dy + radius
    # The window is separable: one exponential per row and column offset of each disc (the
    # same for all at the first step, centred on the disc).
    across = np.exp(np.float32(-1 / (2 * window**2)) * span**2)
    np.multiply(weights, across[column], out=windowed)
    np.multiply(windowed, across[row], out=windowed)
    total, sx, sy = (windowed @ first).T
    sxx, syy, sxy = (windowed @ second).T
    total = np.maximum(total, np.float32(1e-30))
    ox, oy = sx / total, sy / total
    vxx, vyy, vxy = sxx / total - ox * ox, syy / total - oy * oy, sxy / total - ox * oy
    narrowest = np.maximum((vxx + vyy) / 2 - np.sqrt(((vxx - vyy) / 2) ** 2 + vxy * vxy), 0)
    w2 = np.float32(window**2)
    # A spot that fills the window (variance near w^2) is far wider than the disc: capped there.
    variance = np.minimum(narrowest, np.float32(_WIDEST_SEEN * w2))
    sigma = np.sqrt(variance * w2 / (w2 - variance))
    own = np.maximum(np.float32(_WINDOW_PER_SIGMA) * sigma, np.float32(window))
    scale = (-1 / (2 * own * own))[:, None]
    for _ in range(_WINDOW_ITERATIONS - 1):
        across = np.exp(scale * (span[None, :] - ox[:, None]) ** 2)
        down = np.exp(scale * (span[None, :] - oy[:, None]) ** 2)
        np.multiply(weights, across[:, column], out=windowed)
        np.multiply(windowed, down[:, row], out=windowed)
        total, sx, sy = (windowed @ first).T
        total = np.maximum(total, np.float32(1e-30))
        ox, oy = sx / total, sy / total
    return ox.astype(float), oy.astype(float), own.astype(float)


def _refine(
    padded: np.ndarray, rows: np.ndarray, columns: np.ndarray, dy: np.ndarray, dx: np.ndarray, min_mass: float, window: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Move each disc pixel by pixel towards its brightness centroid (at most 10 moves).

    Returns the discs' final integer centres, their masses and their pixel weights (N, K).
    """
    height, width = padded.shape
    radius = int(dx.max())
    # The light of the square about a candidate bounds its disc's: a candidate whose square
    # holds less than the least mass is dropped by four look-ups in the integral image, before
    # any disc is gathered.
    summed = cv2.integral(padded, sdepth=cv2.CV_32F)
    side = 2 * radius + 1
    stride = summed.shape[1]
    corner = rows * stride + columns
    summed = summed.ravel()
    square = summed[corner + side * stride + side] - summed[corner + side] - summed[corner + side * stride] + summed[corner]
    hopeful = square > min_mass
    rows, columns = rows[hopeful], columns[hopeful]
    # Discs are gathered from the flat frame, one index per pixel: a quarter of the time of
    # indexing rows and columns.
    flat = padded.ravel()
    offsets = (dy + radius) * width + dx + radius
    weights = flat[(rows * width + columns)[:, None] + offsets]
    mass = weights.sum(axis=1)
    hopeful = mass > _PREFILTER * min_mass
    rows, columns, weights, mass = rows[hopeful], columns[hopeful], weights[hopeful], mass[hopeful]
    gauss = np.exp(-(dx * dx + dy * dy) / (2 * window**2)).astype(np.float32)
    # The first moments in float64 by one matrix product, at a sixth of the time of summing
    # pixel by pixel and with the same result: products of float32 light and whole offsets are
    # exact in float64, and so are their sums while a disc's lit pixels span less than about
    # 10^6 (the floor clips off fainter light), in whatever order they are added.
    arms = np.column_stack((dx, dy)).astype(np.float64)
    # The discs still moving, and their pixels.
    active, current = np.arange(rows.size), weights
    for _ in range(_MAX_ITERATIONS):
        w = current * gauss
        m = np.maximum(w.sum(axis=1), 1e-30)
        first = w.astype(np.float64) @ arms
        ox, oy = first[:, 0] / m, first[:, 1] / m
        step_x = (ox > _SHIFT_PX).astype(np.intp) - (ox < -_SHIFT_PX)
        step_y = (oy > _SHIFT_PX).astype(np.intp) - (oy < -_SHIFT_PX)
        moving = np.flatnonzero(step_x | step_y)
        if moving.size == 0:
            break
        active = active[moving]
        columns[active] = np.clip(columns[active] + step_x[moving], 0, width - 2 * radius - 1)
        rows[active] = np.clip(rows[active] + step_y[moving], 0, height - 2 * radius - 1)
        current = flat[(rows[active] * width + columns[active])[:, None] + offsets]
        weights[active] = current
        mass[active] = current.sum(axis=1)
    return rows, columns, mass, weights


def _without_duplicates(
    x: np.ndarray, y: np.ndarray, mass: np.ndarray, radius: int, standing_out: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Drop the lighter of two spots closer than a radius (two maxima of one flat spot whose
    discs walked onto it), and a spot within a diameter of one ``_HALO_RATIO`` times heavier
    (the light halo the running mean leaves around a strong spot, above all one ringed dark)
    unless it is ``standing_out`` of the wide background (a halo is light only against the
    running mean: the bead beside a brighter one also stands out of the wide background);
    returns the kept x, y and their indices into the input."""
    order = np.argsort(-mass, kind="stable")
    pairs = cKDTree(np.column_stack((x, y))).query_pairs(_HALO_REACH * (2 * radius + 1), output_type="ndarray")
    if len(pairs) == 0:
        return x, y, np.arange(x.size)
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    heavy = np.where(rank[pairs[:, 0]] < rank[pairs[:, 1]], pairs[:, 0], pairs[:, 1])
    light = pairs[:, 0] + pairs[:, 1] - heavy
    close = np.hypot(x[heavy] - x[light], y[heavy] - y[light]) <= max(radius, 1)
    halo = (mass[heavy] >= _HALO_RATIO * mass[light]) & ~standing_out[light]
    wanted = close | halo
    heavy, light = heavy[wanted], light[wanted]
    dropped = np.zeros(x.size, bool)
    # Heaviest first, so a spot dropped by a heavier one cannot drop a third.
    for k in np.argsort(rank[heavy], kind="stable"):
        if not dropped[heavy[k]]:
            dropped[light[k]] = True
    kept = np.flatnonzero(~dropped)
    return x[kept], y[kept], kept


def _empty() -> dict[str, np.ndarray]:
    return {name: np.empty(0) for name in (*MEASUREMENT_COLUMNS, "mass", "ep")}
