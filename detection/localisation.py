"""How far off each detection's centre may lie: its localisation error from what was measured.

Both detectors place a centre as a weighted centroid of the light over the object's pixels, so
the error of that centre follows, to first order, from the noise on those pixels: a centroid
x = sum(w_i p_i x_i) / sum(w_i p_i) moves by sum(w_i (x_i - x) n_i) / sum(w_i p_i) when noise
n_i is added to the light p_i (error propagation, as for the Gaussian mask estimator of
Thompson, Larson and Webb, Biophys. J. 82, 2775, 2002; trackpy's ``ep`` is the same idea for a
flat disc, after Savin and Doyle, Biophys. J. 88, 623, 2005). Its variance is then
sum((w_i (x_i - x))^2 v_i) / sum(w_i p_i)^2 with v_i the pixel's noise variance: the
background's measured noise, plus, for light spots in photon counts, the spot's own shot noise.
The result is one number per detection, pixels per axis (the root mean square of the x and y
standard deviations), the ``ep`` column of ``detections.csv``.
"""

from __future__ import annotations

import functools

import cv2
import numpy as np

__all__ = ["centroid_error", "windowed_centroid_error"]

# A spot that fills its window moves its fixed point far more than the noise's push (1 - f'
# near 0): taken as at most this many times, as the detector caps how wide it reads a spot.
_LEAST_FOLLOW = 0.05
# Rows per matrix product, few enough that the linear algebra library keeps it on one thread.
_PRODUCT_ROWS = 128


def centroid_error(sums: dict[str, np.ndarray], noise: float) -> np.ndarray:
    """Localisation error of contrast-weighted centroids over whole pixels (the blob detector).

    Parameters
    ----------
    sums : dict of str to ndarray
        Per object: ``mass`` (sum of the weights), ``area`` (pixels), ``x``, ``y`` (the
        weighted centroid, pixels), ``cx``, ``cy`` (the unweighted centre of its pixels) and
        ``sxx``, ``syy`` (the unweighted variances of its pixels' columns and rows, pixels^2).
    noise : float
        Standard deviation of each pixel's weight, from the frame's noise (data units).

    Returns
    -------
    ndarray of float
        Pixels per axis.

    Example
    -------
    A 3 x 3 square of weight 10, noise 2: the columns' squared offsets sum to 6, so
    2 sqrt(6) / 90 = 0.054 px.

    >>> one = np.ones(1)
    >>> s = dict(mass=90 * one, area=9 * one, x=one, y=one, cx=one, cy=one, sxx=2 / 3 * one, syy=2 / 3 * one)
    >>> round(float(centroid_error(s, 2.0)[0]), 4)
    0.0544
    """
    # sum((x_i - x)^2) over the pixels is the area times their variance about their own centre
    # plus the squared distance of that centre from the weighted one.
    spread = sums["area"] * (sums["sxx"] + sums["syy"] + (sums["cx"] - sums["x"]) ** 2 + (sums["cy"] - sums["y"]) ** 2) / 2
    return noise * np.sqrt(spread) / np.maximum(sums["mass"], 1e-30)


def windowed_centroid_error(
    light: np.ndarray, above: np.ndarray, dx: np.ndarray, dy: np.ndarray, ox: np.ndarray, oy: np.ndarray, window: np.ndarray, smoothing: float, noise: float, gain: float
) -> np.ndarray:
    """Localisation error of Gaussian-windowed centroids iterated to their fixed point (the
    spot detector), on light smoothed by a Gaussian before it is weighed.

    Parameters
    ----------
    light : ndarray, shape (N, K)
        Each spot's light over the K pixels of its disc (the band-passed frame, zero where
        clipped: noise there moves nothing).
    above : ndarray, shape (N, K)
        The raw frame over the same pixels less the background, data units: the spot's own
        light, whose shot noise adds to the background's.
    dx, dy : ndarray of int, shape (K,)
        The disc's pixel offsets from its centre.
    ox, oy : ndarray, shape (N,)
        The centroid, offset from the disc's centre, pixels.
    window : ndarray, shape (N,)
        Standard deviation of each spot's Gaussian window, pixels.
    smoothing : float
        Standard deviation of the Gaussian the frame was smoothed by first, pixels: the noise on
        the light is that of the raw pixels, smoothed.
    noise : float
        Standard deviation of a raw pixel's noise on the background, data units.
    gain : float
        Data units per photon: a pixel ``above`` the background by p adds ``gain * p`` to its
        variance (0: the background's noise alone).

    Returns
    -------
    ndarray of float, shape (N,)
        Pixels per axis.

    Example
    -------
    >>> dy, dx = np.mgrid[-4:5, -4:5].reshape(2, -1)
    >>> spot = 100 * np.exp(-(dx**2 + dy**2) / 4.5)[None, :]
    >>> a, b = (windowed_centroid_error(spot, spot, dx, dy, np.zeros(1), np.zeros(1), np.full(1, 3.0), 1.0, n, 0.0)[0] for n in (1.0, 2.0))
    >>> round(float(b / a), 3)
    2.0
    """
    light = np.asarray(light, float)
    if light.shape[0] == 0:
        return np.empty(0)
    ex = dx[None, :] - ox[:, None]
    ey = dy[None, :] - oy[:, None]
    w = np.exp(-(ex * ex + ey * ey) / (2 * window[:, None] ** 2)) * (light > 0)
    weighed = w * light
    total = np.maximum(weighed.sum(axis=1), 1e-30)
    # The window follows the centre: a fixed point x = f(x) moves by the noise's push over
    # 1 - f'(x), and f'(x) is the windowed light's variance along that axis over the window's.
    follow_x = 1 - (weighed * ex * ex).sum(axis=1) / (total * window**2)
    follow_y = 1 - (weighed * ey * ey).sum(axis=1) / (total * window**2)
    # The light at a pixel is the smoothed raw pixels about it, so each raw pixel's noise reaches
    # the centroid through the coefficients about it, smoothed the same way: the background's
    # through the smoothing's autocorrelation between the disc's pixels, the shot noise (on the
    # disc only) through the smoothing from them to each.
    reach, across = _smoothing_matrices(tuple(dx.tolist()), tuple(dy.tolist()), float(smoothing))
    shot = gain * np.maximum(above, 0)
    result = np.zeros(light.shape[0])
    for coefficient, follow in ((w * ex, follow_x), (w * ey, follow_y)):
        spread = _product(coefficient, reach)
        pushed = noise * noise * np.einsum("ij,ij->i", _product(coefficient, across), coefficient) + np.einsum("ij,ij->i", spread * spread, shot)
        result += pushed / (total * np.maximum(follow, _LEAST_FOLLOW)) ** 2
    return np.sqrt(result / 2)


def _product(rows: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    """``rows @ matrix``, a few rows at a time: one product of a frame's spots is spread by the
    linear algebra library over every core, at several times the processor time (1,200 spots:
    5 to 20 ms of CPU on a loaded machine against 1.4 ms on one thread)."""
    return np.concatenate([rows[start : start + _PRODUCT_ROWS] @ matrix for start in range(0, rows.shape[0], _PRODUCT_ROWS)])


@functools.lru_cache(maxsize=None)
def _smoothing_matrices(dx: tuple[int, ...], dy: tuple[int, ...], smoothing: float) -> tuple[np.ndarray, np.ndarray]:
    """For a disc of pixel offsets ``dx``, ``dy`` and a Gaussian of ``smoothing`` px: the
    smoothing's weight from each disc pixel to each (K, K), and its autocorrelation over the
    whole plane between them (K, K)."""
    kernel = cv2.getGaussianKernel(2 * int(np.ceil(4 * smoothing)) + 1, smoothing).ravel() if smoothing > 0 else np.ones(1)
    half = kernel.size // 2
    itself = np.correlate(kernel, kernel, mode="full")
    x, y = np.array(dx), np.array(dy)
    apart_x, apart_y = x[:, None] - x[None, :], y[:, None] - y[None, :]

    def at(values: np.ndarray, middle: int, offset: np.ndarray) -> np.ndarray:
        index = offset + middle
        inside = (index >= 0) & (index < values.size)
        return np.where(inside, values[np.clip(index, 0, values.size - 1)], 0.0)

    reach = at(kernel, half, apart_x) * at(kernel, half, apart_y)
    across = at(itself, kernel.size - 1, apart_x) * at(itself, kernel.size - 1, apart_y)
    return reach, across
