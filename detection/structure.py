"""The background's own maxima, told apart from the objects by their masses.

A threshold calibrated on white noise sees white noise. Real footage has structured background as
well: out-of-focus blur, compression blocks, uneven light. Its local maxima are many and their
masses (a spot's integrated brightness over the band-passed frame) form a mode of their own, far
heavier than white noise of the measured level would make; the objects form a second mode above
it. On the bulk-water beads the background's mode lies at a mass of about 23, ten times white
noise's, and the beads' at about 200. The least mass of such a clip lies in the valley between the two
modes of the density of log mass, where a candidate becomes more likely an object than background
(a mixture of two normal components fitted to the log masses), and the knob a user turns is the signal-to-background ratio:
the least mass over the background's typical maximum.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

# The density of log10 mass is a histogram of bins this wide, decades, smoothed by a Gaussian of
# this standard deviation (the mass of one object varies by about a tenth of a decade between
# frames, so finer structure is sampling noise).
_BIN_DECADES = 0.02
_SMOOTH_DECADES = 0.08
# A mode is a local maximum of the density at least this share of the highest.
_MODE_SHARE = 0.25
# The background is structured when its mode lies this many times above the median mass of white
# noise's maxima at the measured level (0.8 to 1.05 on the frames of bench_detect_spots.py, about 8 on
# bulk water).
_STRUCTURED = 3.0
# There is a valley between two modes when the density somewhere between them falls to this share
# of the lower of the two (bulk water: 0.6 to 0.75, frame by frame).
_DIP = 0.85
# Least candidates to read a density from.
_FEWEST = 50
# The two-component fit starts at the two modes with this spread, decades, and takes this many
# steps (it settles within about 50 on the bulk-water frames).
_START_SPREAD = 0.15
_EM_STEPS = 200


@dataclass(frozen=True)
class Background:
    """The background's maxima as the candidates' masses show them.

    Attributes
    ----------
    mass : float
        Typical mass of the background's maxima (the lower mode of the candidates' log mass, or
        white noise's median where there is no such mode), data units times pixels.
    structured : bool
        The background's maxima are at least 3 times heavier than white noise's.
    valley : float
        Where the density between the background's mode and the objects' dips: the mass above
        which a candidate more likely belongs to the objects than to the background (two normal
        components fitted to the log masses); 0 when the density does not dip.
    """

    mass: float
    structured: bool
    valley: float


def background_of(masses: np.ndarray, white_median: float) -> Background:
    """Where the background's maxima lie among the candidates' masses, and the valley above them.

    Parameters
    ----------
    masses : ndarray
        Masses of every local maximum of one frame (data units times pixels).
    white_median : float
        Median mass of white noise's maxima at the frame's measured noise level.

    Returns
    -------
    Background

    Example
    -------
    >>> rng = np.random.default_rng(0)
    >>> masses = np.concatenate([rng.lognormal(np.log(20), 0.4, 600), rng.lognormal(np.log(200), 0.25, 400)])
    >>> found = background_of(masses, 3.0)
    >>> found.structured, 40 < found.valley < 100
    (True, True)
    """
    values = np.log10(masses[masses > 0])
    if values.size < _FEWEST:
        return Background(white_median, False, 0.0)
    low, high = float(values.min()), float(values.max())
    bins = max(3, int(np.ceil((high - low) / _BIN_DECADES)) + 1)
    counts = np.histogram(values, bins=bins, range=(low, low + bins * _BIN_DECADES))[0].astype(np.float32)
    # Zero-padded wide enough that no mode is made at the ends by the smoothing's border.
    pad = int(4 * _SMOOTH_DECADES / _BIN_DECADES)
    density = cv2.GaussianBlur(np.pad(counts, pad)[None, :], (0, 0), _SMOOTH_DECADES / _BIN_DECADES, borderType=cv2.BORDER_CONSTANT)[0]
    centres = low + (np.arange(density.size) - pad + 0.5) * _BIN_DECADES
    inner = density[1:-1]
    modes = np.flatnonzero((inner > density[:-2]) & (inner >= density[2:]) & (inner >= _MODE_SHARE * density.max())) + 1
    background_mode = modes[0]
    mass = float(10 ** centres[background_mode])
    structured = mass >= _STRUCTURED * white_median
    if modes.size < 2:
        return Background(mass, structured, 0.0)
    objects_mode = modes[1 + int(np.argmax(density[modes[1:]]))]
    if density[background_mode : objects_mode + 1].min() > _DIP * min(density[background_mode], density[objects_mode]):
        return Background(mass, structured, 0.0)
    return Background(mass, structured, float(10 ** _equal_odds(values, centres[background_mode], centres[objects_mode])))


def _equal_odds(values: np.ndarray, low: float, high: float) -> float:
    """The log mass between ``low`` and ``high`` above which a candidate more likely belongs to the
    upper of two normal components fitted to ``values`` (expectation-maximisation from the two
    modes), so that the background's broad tail of out-of-focus blur and blocks, which fills the
    valley, is weighed against the objects' narrower mode."""
    means = np.array([low, high])
    spreads = np.full(2, _START_SPREAD)
    weights = np.full(2, 0.5)
    column = values[:, None]
    for _ in range(_EM_STEPS):
        likely = weights / spreads * np.exp(-0.5 * ((column - means) / spreads) ** 2)
        share = likely / np.maximum(likely.sum(axis=1, keepdims=True), np.finfo(float).tiny)
        weights = share.mean(axis=0)
        means = (share * column).sum(axis=0) / share.sum(axis=0)
        spreads = np.maximum(np.sqrt((share * (column - means) ** 2).sum(axis=0) / share.sum(axis=0)), _BIN_DECADES)
    grid = np.linspace(min(means), max(means), 1001)[:, None]
    odds = weights / spreads * np.exp(-0.5 * ((grid - means) / spreads) ** 2)
    upper = int(np.argmax(means))
    return float(grid[int(np.argmax(odds[:, upper] > odds[:, 1 - upper])), 0])
