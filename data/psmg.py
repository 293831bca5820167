"""Point set motion generator (PSMG): random smooth trajectories with ground truth.

Chetverikov and Verestoy's generator, as Veenman et al. also used it: each point starts at a
uniform position with a uniform direction and a normally distributed speed; from frame to
frame its speed and direction take small Gaussian steps, and the speed is kept within
[0, max_speed]. Only trajectories that stay inside the square view for the whole sequence are
kept (data "without entry/exit"), so every trajectory spans every frame. A point may be
occluded (not measured) for single frames, away from the sequence's ends. Positions are pixels, x right, y down; frames are
0-based. Measurements are shuffled within each frame so that no tracker can use their order.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from seedtrack.tracking.tracks import NO_MEASUREMENT, Tracks

# Candidate trajectories drawn per wanted one and per attempt; slow points in a big view
# almost always fit, fast ones in a small view need more.
_BATCH_FACTOR = 4
_MAX_ATTEMPTS = 200
# Frames at each end of the sequence without occlusion: every trajectory then begins and ends
# with three measured points, the least that a triplet-based tracker (IPAN) needs to start or
# end a trajectory. The sources do not say where their generator put occlusions.
_CLEAR_ENDS = 3
# With entry and exit, a trajectory is kept if it is in view in this many frames at least.
_MIN_IN_VIEW = 3


@dataclass(frozen=True)
class PSMGSpec:
    """What to generate.

    Attributes
    ----------
    trajectories : int
        Number of points (all spanning every frame).
    frames : int
        Number of frames.
    size : float
        Side of the square view, pixels.
    mean_speed : float
        Mean initial speed, pixels/frame.
    speed_sigma : float
        Standard deviation of the initial speed, pixels/frame.
    speed_step_sigma : float
        Standard deviation of the speed change per frame, pixels/frame.
    angle_step_sigma : float
        Standard deviation of the direction change per frame, degrees.
    max_speed : float or None
        Largest speed, pixels/frame; None for twice the mean speed.
    occlusion : float
        Probability that a point's occlusion starts in a frame (never in the first three or the
        last three frames; after an occlusion the point is seen at least once before the next).
    max_gap : int
        Longest occlusion, frames; each lasts 1 to ``max_gap`` frames (uniform), cut short three
        frames before the end.
    entry_exit : bool
        Draw trajectories in a larger square around the view (by the distance a point can travel
        in the sequence on each side), so that points enter and leave; a trajectory is kept if
        it is in view in at least three frames, and has no position outside the view.
    random_seed : int
        Seed of every random choice: same spec, same data.
    """

    trajectories: int = 20
    frames: int = 20
    size: float = 200.0
    mean_speed: float = 3.0
    speed_sigma: float = 0.0
    speed_step_sigma: float = 0.0
    angle_step_sigma: float = 0.0
    max_speed: float | None = None
    occlusion: float = 0.0
    max_gap: int = 1
    entry_exit: bool = False
    random_seed: int = 0

    def __post_init__(self) -> None:
        if self.trajectories < 0 or self.frames < 1:
            raise ValueError("need a non-negative number of trajectories and at least one frame")
        if not self.size > 0 or self.mean_speed < 0:
            raise ValueError("size must be positive and mean_speed non-negative")
        if min(self.speed_sigma, self.speed_step_sigma, self.angle_step_sigma) < 0:
            raise ValueError("standard deviations must be non-negative")
        if not 0 <= self.occlusion < 1:
            raise ValueError(f"occlusion must lie in [0, 1), got {self.occlusion}")
        if self.max_gap < 1:
            raise ValueError(f"max_gap must be at least 1 frame, got {self.max_gap}")

    @property
    def speed_limit(self) -> float:
        """Largest speed a point can reach, pixels/frame."""
        return 2.0 * self.mean_speed if self.max_speed is None else self.max_speed


def generate_psmg(spec: PSMGSpec) -> tuple[list[np.ndarray], Tracks]:
    """Draw one PSMG data set.

    Returns
    -------
    frames : list of ndarray, each (M_k, 2)
        Measured positions per frame, pixels, in random order.
    truth : Tracks
        One track per trajectory with its position in every frame it is in view (NaN outside);
        occluded frames are marked interpolated (no measurement).

    Raises
    ------
    ValueError
        If trajectories that stay in the view are too rare to draw (speed too high for the size).
    """
    rng = np.random.default_rng(spec.random_seed)
    paths = _paths_in_view(rng, spec)
    hidden = _occlusions(rng, spec)
    if spec.entry_exit:
        outside = ((paths < 0) | (paths > spec.size)).any(axis=2)
        paths[outside] = np.nan
        hidden |= outside
    frames, measurement = [], np.full((spec.trajectories, spec.frames), NO_MEASUREMENT, dtype=np.int64)
    for k in range(spec.frames):
        seen = np.flatnonzero(~hidden[:, k])
        order = rng.permutation(seen.size)
        frames.append(paths[seen[order], k])
        measurement[seen[order], k] = np.arange(seen.size)
    return frames, Tracks.from_dense(xy=paths, measurement=measurement)


def _paths_in_view(rng: np.random.Generator, spec: PSMGSpec) -> np.ndarray:
    """(trajectories, frames, 2) positions of trajectories that never leave the view, or with
    entry/exit, that are in view in at least three frames."""
    kept: list[np.ndarray] = []
    wanted = spec.trajectories
    margin = spec.speed_limit * (spec.frames - 1) if spec.entry_exit else 0.0
    for _ in range(_MAX_ATTEMPTS):
        if wanted <= 0:
            break
        batch = _random_paths(rng, spec, _BATCH_FACTOR * wanted + 8, margin)
        in_view = ((batch >= 0) & (batch <= spec.size)).all(axis=2)
        inside = in_view.sum(axis=1) >= _MIN_IN_VIEW if spec.entry_exit else in_view.all(axis=1)
        kept.append(batch[inside][:wanted])
        wanted -= kept[-1].shape[0]
    if wanted > 0:
        raise ValueError(
            f"could not draw {spec.trajectories} trajectories that stay in a {spec.size:g} px view "
            f"at speed {spec.mean_speed:g} over {spec.frames} frames"
        )
    return np.concatenate(kept) if kept else np.empty((0, spec.frames, 2))


def _random_paths(rng: np.random.Generator, spec: PSMGSpec, count: int, margin: float = 0.0) -> np.ndarray:
    start = rng.uniform(-margin, spec.size + margin, size=(count, 2))
    heading = rng.uniform(0.0, 2.0 * math.pi, size=count)
    speed = rng.normal(spec.mean_speed, spec.speed_sigma, size=count)
    heading_steps = rng.normal(0.0, math.radians(spec.angle_step_sigma), size=(count, max(spec.frames - 2, 0)))
    speed_steps = rng.normal(0.0, spec.speed_step_sigma, size=(count, max(spec.frames - 2, 0)))
    limit = spec.speed_limit
    speeds = [np.clip(speed, 0.0, limit)]
    for step in speed_steps.T:  # the clip is applied at every step, so it cannot be a cumsum
        speeds.append(np.clip(speeds[-1] + step, 0.0, limit))
    speeds = np.stack(speeds[: max(spec.frames - 1, 0)], axis=1)
    headings = heading[:, None] + np.concatenate((np.zeros((count, 1)), np.cumsum(heading_steps, axis=1)), axis=1)
    headings = headings[:, : max(spec.frames - 1, 0)]
    steps = np.stack((speeds * np.cos(headings), speeds * np.sin(headings)), axis=-1)
    return start[:, None, :] + np.concatenate((np.zeros((count, 1, 2)), np.cumsum(steps, axis=1)), axis=1)


def _occlusions(rng: np.random.Generator, spec: PSMGSpec) -> np.ndarray:
    """(trajectories, frames) bool: occlusions of 1 to max_gap frames, away from the first and
    last three frames, each followed by at least one frame in which the point is seen."""
    starts = rng.random((spec.trajectories, spec.frames)) < spec.occlusion
    length = rng.integers(1, spec.max_gap + 1, size=starts.shape) if spec.max_gap > 1 else np.ones(starts.shape, int)
    hidden = np.zeros(starts.shape, bool)
    remaining = np.zeros(spec.trajectories, int)
    for k in range(_CLEAR_ENDS, spec.frames - _CLEAR_ENDS):
        begin = starts[:, k] & (remaining == 0) & ~hidden[:, k - 1]
        remaining = np.where(begin, length[:, k], remaining)
        hidden[:, k] = remaining > 0
        remaining = np.maximum(remaining - 1, 0)
    return hidden
