"""Generated clips of a few bright spots on a dark background, like TrackMate's FakeTracks sample.

TrackMate's tutorial clip is 50 frames of 128 x 128 with at most four bright round spots that
wander, meet and part, on a dark noisy background. These clips have that layout and differ from
:mod:`seedtrack.data.spotfield` in what matters to a detector: few spots in a small frame (so the
false spots of the noise count for much), spots of several sizes and brightnesses, a background
that slopes across the frame, and the noise of a camera on a dark scene: a few photons a pixel
(Poisson, so skewed towards bright), amplified, plus read noise, rounded and clipped to 8 bits.
Positions are in pixels, x to the right and y down, pixel centres at integer coordinates; frames
are 0-based.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class SparseSpotSpec:
    """What to generate.

    Attributes
    ----------
    width, height : int
        Frame size, pixels.
    frames : int
    spots : int
        Spots wandering through the clip (each in every frame).
    sigma_range : tuple of float
        Each spot's Gaussian standard deviation is drawn from this range, pixels.
    peak_range : tuple of float
        Each spot's peak, photons above the background, drawn from this range.
    step_px : float
        Standard deviation of a spot's step per axis, pixels per frame.
    background : tuple of float
        Background photons per pixel at the left and at the right edge.
    gain : float
        Grey levels per photon.
    read_noise : float
        Standard deviation of the read noise, grey levels.
    offset : float
        Grey level of no light.
    random_seed : int
    """

    width: int = 128
    height: int = 128
    frames: int = 50
    spots: int = 4
    sigma_range: tuple[float, float] = (1.0, 1.6)
    peak_range: tuple[float, float] = (8.0, 30.0)
    step_px: float = 1.5
    background: tuple[float, float] = (1.0, 3.0)
    gain: float = 7.0
    read_noise: float = 3.0
    offset: float = 4.0
    random_seed: int = 0

    def __post_init__(self) -> None:
        if self.spots < 1 or self.frames < 1 or min(self.width, self.height) < 32:
            raise ValueError("spots and frames must be >= 1 and the frame at least 32 x 32")
        if not (0 < self.sigma_range[0] <= self.sigma_range[1] and 0 < self.peak_range[0] <= self.peak_range[1]):
            raise ValueError("sigma_range and peak_range must be positive and ordered")
        if min(self.background) < 0 or self.gain <= 0 or self.read_noise < 0:
            raise ValueError("background and read_noise must be >= 0 and gain > 0")


@dataclass(frozen=True, eq=False)
class SparseSpotClip:
    """A generated clip and its truth.

    Attributes
    ----------
    frames : ndarray of uint8, shape (frames, height, width)
    xy : ndarray of float, shape (frames, spots, 2)
        True centre of each spot in each frame, pixels.
    sigma : ndarray of float, shape (spots,)
        Each spot's standard deviation, pixels.
    """

    frames: np.ndarray
    xy: np.ndarray
    sigma: np.ndarray


def make_sparse_spots(spec: SparseSpotSpec) -> SparseSpotClip:
    """Generate a clip (same spec, same clip).

    Example
    -------
    >>> clip = make_sparse_spots(SparseSpotSpec(frames=3, spots=2))
    >>> clip.frames.shape, clip.frames.dtype, clip.xy.shape
    ((3, 128, 128), dtype('uint8'), (3, 2, 2))
    """
    rng = np.random.default_rng(spec.random_seed)
    sigma = rng.uniform(*spec.sigma_range, spec.spots)
    peak = rng.uniform(*spec.peak_range, spec.spots)
    margin = 4 * spec.sigma_range[1]
    low = np.array([margin, margin])
    high = np.array([spec.width - 1 - margin, spec.height - 1 - margin])
    xy = np.empty((spec.frames, spec.spots, 2))
    xy[0] = rng.uniform(low, high, (spec.spots, 2))
    for k in range(1, spec.frames):
        moved = xy[k - 1] + rng.normal(0, spec.step_px, (spec.spots, 2))
        # Reflected at the margins, so that every spot stays whole in every frame.
        moved = np.where(moved < low, 2 * low - moved, moved)
        xy[k] = np.where(moved > high, 2 * high - moved, moved)
    rows, columns = np.mgrid[0 : spec.height, 0 : spec.width].astype(np.float32)
    light = np.broadcast_to(np.linspace(*spec.background, spec.width, dtype=np.float32), (spec.height, spec.width))
    frames = np.empty((spec.frames, spec.height, spec.width), np.uint8)
    for k in range(spec.frames):
        photons = light.copy()
        for (x, y), s, a in zip(xy[k], sigma, peak):
            photons += a * np.exp(-((columns - x) ** 2 + (rows - y) ** 2) / (2 * s * s))
        grey = spec.offset + spec.gain * rng.poisson(photons) + rng.normal(0, spec.read_noise, photons.shape)
        frames[k] = np.clip(np.rint(grey), 0, 255).astype(np.uint8)
    return SparseSpotClip(frames=frames, xy=xy, sigma=sigma)
