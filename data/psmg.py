"""Point set motion generator (PSMG): random smooth trajectories with ground truth.

Chetverikov and Verestoy's generator, as Veenman et al. also used it: each point starts at a
uniform position with a uniform direction and a normally distributed speed; from frame to
frame its speed and direction take small Gaussian steps, and the speed is kept within
[0, max_speed]. Only trajectories that stay inside the square view for the whole sequence are
kept (data "without entry/exit"), so every trajectory spans every frame. With ``entry_exit``
the points are drawn in a larger square around the view instead, so that they cross its border:
each stay in the view of at least 3 frames is one true trajectory (as in Primet's tpsmg), shorter
stays are not measured. A point may be occluded (not measured) for up to ``max_occlusion``
frames in a row, never in the first or last three frames of its trajectory. Positions are
pixels, x right, y down; frames are 0-based. Measurements are shuffled within each frame so
that no tracker can use their order.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tracking.tracks import NO_MEASUREMENT, Tracks

# Candidate trajectories drawn per wanted one and per attempt; slow points in a big view
# almost always fit, fast ones in a small view need more.
_BATCH_FACTOR = 4
_MAX_ATTEMPTS = 200
# Shortest stay in the view that counts as a trajectory with entry/exit, frames.
_SHORTEST_STAY = 3
# Frames at each end of a trajectory without occlusion: every trajectory then begins and ends
# with three measured points, the least that a triplet-based tracker (IPAN) needs to start or
# end a trajectory. The sources do not say where their generator put occlusions.
_CLEAR_ENDS = 3


@dataclass(frozen=True)
class PSMGSpec:
    """What to generate.

    Attributes
    ----------
    trajectories : int
        Number of points (all spanning every frame); with ``entry_exit``, the number of points
        in the view on average (more are drawn around it, at the same density).
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
        Probability that an occlusion starts in a frame (never in the first three or the last
        three frames of a trajectory, never right after another occlusion).
    max_occlusion : int
        Longest occlusion, frames; each lasts a uniformly drawn 1..max_occlusion frames, cut
        short before the trajectory's last three frames.
    entry_exit : bool
        Points enter and leave the view (see above).
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
    max_occlusion: int = 1
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
        if self.max_occlusion < 1:
            raise ValueError(f"max_occlusion must be at least 1 frame, got {self.max_occlusion}")

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
        One track per trajectory with its position in every frame it spans (NaN outside);
        occluded frames are marked interpolated (no measurement).

    Raises
    ------
    ValueError
        If trajectories that stay in the view are too rare to draw (speed too high for the size).
    """
    rng = np.random.default_rng(spec.random_seed)
    paths = _stays_in_view(rng, spec) if spec.entry_exit else _paths_in_view(rng, spec)
    spans = ~np.isnan(paths[..., 0])
    hidden = _occlusions(rng, spec, spans)
    measurement = np.full(spans.shape, NO_MEASUREMENT, dtype=np.int64)
    frames = []
    for k in range(spec.frames):
        seen = np.flatnonzero(spans[:, k] & ~hidden[:, k])
        order = rng.permutation(seen.size)
        frames.append(paths[seen[order], k])
        measurement[seen[order], k] = np.arange(seen.size)
    return frames, Tracks(xy=paths, measurement=measurement)


def _paths_in_view(rng: np.random.Generator, spec: PSMGSpec) -> np.ndarray:
    """(trajectories, frames, 2) positions of trajectories that never leave the view."""
    kept: list[np.ndarray] = []
    wanted = spec.trajectories
    for _ in range(_MAX_ATTEMPTS):
        if wanted <= 0:
            break
        batch = _random_paths(rng, spec, _BATCH_FACTOR * wanted + 8)
        inside = ((batch >= 0) & (batch <= spec.size)).all(axis=(1, 2))
        kept.append(batch[inside][:wanted])
        wanted -= kept[-1].shape[0]
    if wanted > 0:
        raise ValueError(
            f"could not draw {spec.trajectories} trajectories that stay in a {spec.size:g} px view "
            f"at speed {spec.mean_speed:g} over {spec.frames} frames"
        )
    return np.concatenate(kept) if kept else np.empty((0, spec.frames, 2))


def _stays_in_view(rng: np.random.Generator, spec: PSMGSpec) -> np.ndarray:
    """(stays, frames, 2) positions of every stay of at least 3 frames in the view, NaN outside.

    Points start in a square that reaches ``mean_speed * (frames - 1)`` beyond the view on each
    side, as many as keep the view's density at ``trajectories / size**2``.
    """
    margin = spec.mean_speed * max(spec.frames - 1, 0)
    outer = spec.size + 2 * margin
    count = int(round(spec.trajectories * (outer / spec.size) ** 2))
    paths = _random_paths(rng, spec, count, low=-margin, high=spec.size + margin)
    inside = ((paths >= 0) & (paths <= spec.size)).all(axis=2)
    # Label each run of in-view frames: a new run starts where a point (re-)enters.
    enters = inside & ~np.concatenate((np.zeros((count, 1), bool), inside[:, :-1]), axis=1)
    run = np.cumsum(enters.ravel()).reshape(inside.shape) - 1
    length = np.bincount(run[inside], minlength=int(enters.sum()))
    keep = inside & (length[np.where(inside, run, 0)] >= _SHORTEST_STAY)
    kept_runs, row = np.unique(run[keep], return_inverse=True)
    stays = np.full((kept_runs.size, spec.frames, 2), np.nan)
    point, frame = np.nonzero(keep)
    stays[row, frame] = paths[point, frame]
    return stays


def _random_paths(
    rng: np.random.Generator, spec: PSMGSpec, count: int, low: float = 0.0, high: float | None = None
) -> np.ndarray:
    """(count, frames, 2) random smooth paths starting uniformly in [low, high]^2 (high: size)."""
    start = rng.uniform(low, spec.size if high is None else high, size=(count, 2))
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


def _occlusions(rng: np.random.Generator, spec: PSMGSpec, spans: np.ndarray) -> np.ndarray:
    """(trajectories, frames) bool: occlusions inside each trajectory's span, apart from each other.

    ``spans`` (trajectories, frames) marks the frames each trajectory is in the view; its runs
    are contiguous. An occlusion may start where the frame before is visible, and neither it nor
    any of its frames lies in the first or last three frames of the span.
    """
    starts = rng.random(spans.shape) < spec.occlusion
    length = rng.integers(1, spec.max_occlusion + 1, size=spans.shape) if spec.max_occlusion > 1 else np.ones(spans.shape, np.int64)
    frame = np.arange(spec.frames)
    span_first = np.where(spans, frame, spec.frames).min(axis=1)
    latest = np.where(spans, frame, -1).max(axis=1) - _CLEAR_ENDS  # last frame an occlusion may cover
    hidden = np.zeros(spans.shape, bool)
    last_hidden = np.full(spans.shape[0], -2)
    for k in range(1, spec.frames):
        begin = starts[:, k] & (k >= span_first + _CLEAR_ENDS) & (k <= latest) & (last_hidden < k - 1)
        last_hidden = np.where(begin, np.minimum(k + length[:, k] - 1, latest), last_hidden)
        hidden[:, k] = last_hidden >= k
    return hidden
