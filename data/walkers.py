"""Random walkers with ground truth: Brownian particles, optionally drifting, seen through a window.

The regime of particle tracking (beads, colloids, cells) that trackpy and laptrack are made for, to
test the tracker away from the smooth motion of the dish and of PSMG.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from seedtrack.tracking.tracks import Tracks


@dataclass(frozen=True)
class WalkerSpec:
    """What :func:`generate_walkers` draws.

    Attributes
    ----------
    walkers : int
        Number of particles, in the view and in a margin of ``margin`` pixels around it.
    frames : int
    size : float
        Side of the square view, pixels.
    sigma : float
        Standard deviation of each step along x and along y, pixels/frame.
    drift : tuple of float
        Mean step (x, y), pixels/frame.
    missed : float
        Probability that a particle in the view is not measured in a frame.
    margin : float
        Width of the band around the view where particles also start, so that some walk in and
        out, pixels.
    random_seed : int
    """

    walkers: int = 300
    frames: int = 30
    size: float = 512.0
    sigma: float = 1.5
    drift: tuple[float, float] = (0.0, 0.0)
    missed: float = 0.0
    margin: float = 20.0
    random_seed: int = 0


def generate_walkers(spec: WalkerSpec) -> tuple[list[np.ndarray], Tracks]:
    """Measured positions per frame and the truth.

    Returns
    -------
    frames : list of ndarray, each (M_k, 2)
        Positions (x, y), pixels, of the particles measured in frame k, in random order.
    truth : Tracks
        One track per particle that is ever in the view; ``measurement`` indexes ``frames`` and
        is -1 where the particle is in the view but missed, NaN positions where it is outside.
    """
    rng = np.random.default_rng(spec.random_seed)
    start = rng.uniform(-spec.margin, spec.size + spec.margin, (spec.walkers, 1, 2))
    steps = rng.normal(0.0, spec.sigma, (spec.walkers, spec.frames, 2)) + np.asarray(spec.drift, dtype=float)
    steps[:, 0] = 0.0
    xy = start + np.cumsum(steps, axis=1)
    inside = ((xy >= 0) & (xy < spec.size)).all(axis=2)
    seen = inside & (rng.random(inside.shape) >= spec.missed)
    measurement = np.full(inside.shape, -1, dtype=np.int64)
    frames = []
    for k in range(spec.frames):
        # Random order within a frame: the tracker must not lean on the order of the truth.
        who = rng.permutation(np.flatnonzero(seen[:, k]))
        measurement[who, k] = np.arange(who.size)
        frames.append(xy[who, k])
    xy = np.where(inside[..., None], xy, np.nan)
    ever = inside.any(axis=1)
    return frames, Tracks.from_dense(xy[ever], measurement[ever])
