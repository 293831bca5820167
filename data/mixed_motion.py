"""Scenes that mix kinds of motion (issue 29): in one view, some objects move smoothly, some walk
at random and some swing back and forth about fixed sites, so that no one persistence fits
them all.

Returns what :func:`seedtrack.data.unseen.generate_unseen` returns: measured positions per frame
in random order and the truth as :class:`~seedtrack.tracking.tracks.Tracks` (pixels, x right,
y down, 0-based frames; NaN where an object is out of view).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from seedtrack.tracking.tracks import Tracks

from .unseen import UnseenSpec, _oscillate, _reflected, _walk, observed


@dataclass(frozen=True)
class MixedSpec:
    """One scene of mixed motion.

    Attributes
    ----------
    points : int
        Objects in the scene.
    shares : tuple of float
        Shares of smooth movers (heading wandering 5 degrees a frame, walls reflect), random
        walkers (Gaussian steps, walls reflect) and oscillators (swinging along a line through a
        fixed site, periods of 4 to 10 frames, as :mod:`seedtrack.data.unseen`'s "oscillate"),
        in that order; the last kind takes what rounding leaves.
    speed : float
        Speed of the smooth movers and root-mean-square step of the walkers, pixels/frame; the
        oscillators' fastest speed is half of it to all of it.
    frames : int
    size : float
        Side of the square view, pixels.
    noise : float
        Standard deviation of the position error per axis, pixels.
    random_seed : int
    """

    points: int = 120
    shares: tuple[float, float, float] = (0.4, 0.4, 0.2)
    speed: float = 4.0
    frames: int = 30
    size: float = 200.0
    noise: float = 0.2
    random_seed: int = 0

    def __post_init__(self) -> None:
        if self.points < 1 or self.frames < 3 or not self.size > 0 or not self.speed > 0 or self.noise < 0:
            raise ValueError("need points >= 1, frames >= 3, size > 0, speed > 0 and noise >= 0")
        if len(self.shares) != 3 or min(self.shares) < 0 or not math.isclose(sum(self.shares), 1.0):
            raise ValueError(f"shares must be three non-negative numbers summing to 1, got {self.shares}")


def generate_mixed(spec: MixedSpec) -> tuple[list[np.ndarray], Tracks]:
    """Draw one scene of mixed motion.

    Returns
    -------
    frames : list of ndarray, each (M_k, 2)
        Measured positions per frame, pixels, in random order.
    truth : Tracks
        One track per object with its position in every frame it is in view; smooth movers
        first, then walkers, then oscillators.

    Example
    -------
    >>> frames, truth = generate_mixed(MixedSpec(points=10, random_seed=1))
    >>> len(frames), truth.n_tracks
    (30, 10)
    """
    rng = np.random.default_rng(spec.random_seed)
    smooth = int(round(spec.shares[0] * spec.points))
    walkers = min(int(round(spec.shares[1] * spec.points)), spec.points - smooth)
    swinging = spec.points - smooth - walkers
    like = UnseenSpec(points=max(swinging, 1), speed=spec.speed, frames=spec.frames, size=spec.size)
    paths = [
        _walk(rng, like, smooth, spec.frames, np.full(smooth, spec.speed), math.radians(5.0), 0.0),
        _random_walk(rng, walkers, spec),
        _oscillate(rng, like)[:swinging],
    ]
    paths = np.concatenate(paths)
    return observed(rng, paths + rng.normal(0.0, spec.noise, paths.shape), spec.size)


def _random_walk(rng: np.random.Generator, n: int, spec: MixedSpec) -> np.ndarray:
    xy = np.empty((n, spec.frames, 2))
    xy[:, 0] = rng.uniform(0, spec.size, (n, 2))
    for k in range(spec.frames - 1):
        xy[:, k + 1], _ = _reflected(xy[:, k] + rng.normal(0.0, spec.speed / math.sqrt(2.0), (n, 2)), np.zeros(n), spec.size)
    return xy


__all__ = ["MixedSpec", "generate_mixed"]
