"""The greedy optimal assignment (GOA) tracker and its self-initialising up-down driver.

Veenman, Reinders and Backer (2001): at each frame step, the track heads are assigned to the
next frame's measurements by one optimal assignment that minimises the combined motion model,
given the track states so far (greedy in time, optimal per frame). Heads that find no
acceptable measurement take a *slave* (a missed point whose position is later interpolated);
measurements that fit no head go to *false tracks*.

GOA-updown needs no given correspondences: it initialises the first links, runs GOA forwards
(up), then runs it again backwards in time (down) starting from the up pass's last links, so
that the early frames are re-decided with the velocities learned later.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Callable, Sequence

import numpy as np
from scipy.spatial import cKDTree

from .assignment import UNASSIGNED, solve_dense, solve_split
from .initialisation import first_links
from .motion import Candidates, CombinedModel, IndividualModel
from .tracks import Tracks, check_limit, link_speed_limit, point_frames, tracks_from_assignment

Progress = Callable[[int], None]


@dataclass(frozen=True)
class GOAConfig:
    """Parameters of GOA and GOA-updown.

    Attributes
    ----------
    individual : IndividualModel
        Individual motion model (default IM2 with w1 0.1, w2 0.9).
    combined : CombinedModel
        Combined motion model (default CM1 with z = 1).
    phi_max : float
        Largest individual cost a link may have; also the weight of a slave and of a false
        track (the paper's phi_max; 0.1 in its rotating-dish run).
    d_max : float or None
        Largest speed, pixels/frame (gap-normalised for heads that hold slaves). None means
        no limit: heads with a velocity are then gated by phi_max alone, and heads without one
        consider their ``neighbours`` nearest measurements.
    d_min : float
        Smallest speed, pixels/frame.
    corner : {"phi", "zero"}
        Weight of the false-track/slave block of the augmented matrix. Each link also puts one false
        track on one slave, so against leaving its head on a slave and its measurement on a false
        track it changes the total by weight + corner - 2 u, u being the slave and false-track
        weight (phi_max; phi_max**z under CM1). "zero", the reference code's, makes a link worth
        taking whenever its weight is below 2 u: every gated link is, and two links of weight u each
        tie with one perfect link (both lower the total by 2 u). "phi" (default, corner u) makes it
        worth taking only below u: one perfect link beats two of weight u (which change nothing), so
        the assignment prefers fewer, better links. A fast dish whose seeds are missed now and then
        is where this matters (rim speed 42 px/frame, 5% of the seeds hidden in each frame: 198 of
        240 seeds tracked right against 129 with "zero"; 30 px/frame, 10% hidden: 189 against 98);
        on PSMG and random walkers the two agree or "phi" is slightly better.
    initialisation : {"lookahead", "im1"}
        How GOA-updown picks the first links. "im1" is the paper's: optimal nearest-neighbour
        assignment of frames 0 and 1. "lookahead" (default) scores each frame 0-1 link by the
        smoothest path it starts over ``lookahead`` frames, mixed with 0.3 of its
        nearest-neighbour cost (see ``tracking.initialisation``), so that on a turning dish the
        shifted nearest-neighbour pairing is not chosen.
    lookahead : int
        Frames spanned by the paths that score the first links (3 = one triplet).
    neighbours : int
        Candidates per head without a velocity when d_max is None. 24, because a fast dish is
        crowded at the speed scale: at rim speed 42 px/frame with seeds 19 px apart (200 seeds)
        the true partner is often not among the 8 nearest: 8 tracked 73% of the seeds right, 12
        and 24 all of them; of 250 seeds 8, 12 and 24 tracked 46%, 57% and 100% (3 clips each,
        tests/benchmarks/bench_hidden.py); 10,000 PSMG points take 45% longer than with 8.
    restart_lost : bool
        Let GOA-updown's down pass start tracks from the last frame's measurements that no head
        of the up pass holds, reusing heads the up pass lost (default). The paper's down pass
        starts only from the up pass's last links, so a head that lost its point (e.g. after a
        wrong first link) stays lost and that point's track is missing.
    solver : {"split", "dense"}
        Solve each frame per connected component of the gated graph (fast), or the whole
        augmented matrix at once (the paper's form; for checking).
    """

    individual: IndividualModel = field(default_factory=IndividualModel)
    combined: CombinedModel = field(default_factory=CombinedModel)
    phi_max: float = 0.1
    d_max: float | None = None
    d_min: float = 0.0
    corner: str = "phi"
    initialisation: str = "lookahead"
    lookahead: int = 5
    neighbours: int = 24
    restart_lost: bool = True
    solver: str = "split"

    def __post_init__(self) -> None:
        check_limit("phi_max", self.phi_max, optional=False)
        check_limit("d_max", self.d_max)
        if self.d_min < 0 or (self.d_max is not None and self.d_min >= self.d_max):
            raise ValueError(f"d_min must be non-negative and below d_max, got {self.d_min}")
        if self.corner not in ("zero", "phi"):
            raise ValueError(f"corner must be 'zero' or 'phi', got {self.corner!r}")
        if self.initialisation not in ("lookahead", "im1"):
            raise ValueError(f"initialisation must be 'lookahead' or 'im1', got {self.initialisation!r}")
        if self.lookahead < 3:
            raise ValueError(f"lookahead must span at least 3 frames, got {self.lookahead}")
        if self.neighbours < 1:
            raise ValueError(f"neighbours must be at least 1, got {self.neighbours}")
        if self.solver not in ("split", "dense"):
            raise ValueError(f"solver must be 'split' or 'dense', got {self.solver!r}")

    @property
    def unmatched_weight(self) -> float:
        return self.combined.unmatched_weight(self.phi_max)

    @property
    def corner_weight(self) -> float:
        return 0.0 if self.corner == "zero" else self.unmatched_weight


@dataclass
class _HeadState:
    """What GOA knows of each head: its newest true measurement and its velocity."""

    last_xy: np.ndarray  # (m, 2), NaN for a head that never held a measurement
    last_step: np.ndarray  # (m,) pass step of that measurement
    velocity: np.ndarray  # (m, 2), NaN where fewer than two true measurements

    @classmethod
    def from_history(cls, frames: Sequence[np.ndarray], assignment: np.ndarray, steps: int) -> "_HeadState":
        m = assignment.shape[0]
        state = cls(np.full((m, 2), np.nan), np.full(m, -1, dtype=np.int64), np.full((m, 2), np.nan))
        for step in range(steps):
            state.advance(step, assignment[:, step], frames[step])
        return state

    def advance(self, step: int, measurement: np.ndarray, points: np.ndarray) -> None:
        held = measurement != UNASSIGNED
        new_xy = points[measurement[held]]
        had = held & (self.last_step >= 0)
        gap = step - self.last_step[had]
        self.velocity[had] = (points[measurement[had]] - self.last_xy[had]) / gap[:, None]
        self.last_xy[held] = new_xy
        self.last_step[held] = step


def _candidates(state: _HeadState, step: int, points: np.ndarray, config: GOAConfig) -> Candidates:
    """Gated (head, measurement) pairs for the frame at ``step``, found with a KD-tree."""
    alive = np.flatnonzero(state.last_step >= 0)
    has_history = ~np.isnan(state.velocity[:, 0])
    speed = np.hypot(*np.nan_to_num(state.velocity).T)
    limit = config.individual.gate_radius(speed, has_history, config.phi_max)
    if config.d_max is not None:
        limit = np.minimum(limit, config.d_max)
    gap = step - state.last_step
    heads: list[np.ndarray] = []
    measurements: list[np.ndarray] = []
    if points.shape[0] and alive.size:
        tree = cKDTree(points)
        bounded = alive[np.isfinite(limit[alive])]
        if bounded.size:
            found = tree.query_ball_point(state.last_xy[bounded], limit[bounded] * gap[bounded])
            counts = np.fromiter((len(f) for f in found), dtype=np.int64, count=bounded.size)
            heads.append(np.repeat(bounded, counts))
            measurements.append(np.fromiter((j for f in found for j in f), dtype=np.int64, count=counts.sum()))
        unbounded = alive[~np.isfinite(limit[alive])]
        if unbounded.size:
            heads_u, measurements_u = _unbounded_pairs(tree, state.last_xy[unbounded], points.shape[0], config)
            heads.append(unbounded[heads_u])
            measurements.append(measurements_u)
    head = np.concatenate(heads) if heads else np.empty(0, np.int64)
    measurement = np.concatenate(measurements) if measurements else np.empty(0, np.int64)
    return Candidates(
        head=head,
        measurement=measurement,
        displacement=points[measurement] - state.last_xy[head] if head.size else np.empty((0, 2)),
        gap=gap[head],
        previous_velocity=state.velocity[head],
    )


def _unbounded_pairs(tree: cKDTree, centres: np.ndarray, n_points: int, config: GOAConfig) -> tuple[np.ndarray, np.ndarray]:
    """Pairs for heads that no speed limit bounds: every measurement for order-2 models
    (which score any distance), the ``neighbours`` nearest for heads scored by distance."""
    k = min(config.neighbours, n_points)
    _, index = tree.query(centres, k=k)
    index = np.asarray(index).reshape(len(centres), k)
    return np.repeat(np.arange(len(centres)), k), index.ravel()


def _scale(candidates: Candidates, config: GOAConfig) -> float:
    """Speed that costs phi_max under the IM1 fallback: d_max, or the farthest candidate."""
    if config.d_max is not None:
        return config.d_max
    speeds = np.hypot(*candidates.velocity.T)
    return float(speeds.max()) if speeds.size and speeds.max() > 0 else 1.0


def assign_step(state: _HeadState, step: int, points: np.ndarray, config: GOAConfig) -> np.ndarray:
    """One step of the paper's Algorithm 1: cost, prune, reweight, assign.

    Returns
    -------
    ndarray of int, shape (m,)
        Measurement index per head in the frame at ``step``, or -1 for a slave.
    """
    candidates = _candidates(state, step, points, config)
    speed = np.hypot(*candidates.velocity.T)
    valid = speed >= config.d_min
    if config.d_max is not None:
        valid &= speed <= config.d_max
    candidates = candidates.subset(valid)
    cost = config.individual.cost(candidates, config.phi_max, _scale(candidates, config))
    keep = cost <= config.phi_max
    candidates, cost = candidates.subset(keep), cost[keep]
    weight = config.combined.weights(cost, candidates.head, candidates.measurement)
    solve = solve_split if config.solver == "split" else solve_dense
    return solve(
        state.last_xy.shape[0],
        points.shape[0],
        candidates.head,
        candidates.measurement,
        weight,
        config.unmatched_weight,
        config.corner_weight,
    )


def goa_pass(
    frames: Sequence[np.ndarray],
    initial: np.ndarray,
    config: GOAConfig = GOAConfig(),
    progress: Progress | None = None,
) -> np.ndarray:
    """Run GOA over the frames in the order given, from known links in the first two frames.

    Parameters
    ----------
    frames : sequence of ndarray, each (M_k, 2)
        Measurement positions per frame, pixels, in processing order.
    initial : ndarray of int, shape (m, 2)
        Each head's measurement index in ``frames[0]`` and ``frames[1]`` (-1 for none).
    config : GOAConfig
    progress : callable, optional
        Called with 1 after each frame step.

    Returns
    -------
    ndarray of int, shape (m, len(frames))
        Measurement index per head and frame, -1 for a slave.
    """
    m = initial.shape[0]
    assignment = np.full((m, len(frames)), UNASSIGNED, dtype=np.int64)
    assignment[:, : initial.shape[1]] = initial
    state = _HeadState.from_history(frames, assignment, initial.shape[1])
    for step in range(initial.shape[1], len(frames)):
        assignment[:, step] = assign_step(state, step, frames[step], config)
        state.advance(step, assignment[:, step], frames[step])
        if progress is not None:
            progress(1)
    return assignment


def initial_links(frames: Sequence[np.ndarray], config: GOAConfig) -> np.ndarray:
    """First links of a self-initialising pass: one head per measurement of ``frames[0]``.

    Returns
    -------
    ndarray of int, shape (M_0, 2)
        Each head's measurement in frames 0 and 1 (-1 where it gets a slave).
    """
    first = np.arange(frames[0].shape[0])
    lookahead = 2 if config.initialisation == "im1" else config.lookahead
    head, measurement, cost = first_links(
        frames, config.individual, config.phi_max, config.d_max, config.d_min, config.neighbours, lookahead
    )
    keep = cost <= config.phi_max
    weight = config.combined.weights(cost[keep], head[keep], measurement[keep])
    solve = solve_split if config.solver == "split" else solve_dense
    second = solve(
        first.size, frames[1].shape[0], head[keep], measurement[keep], weight, config.unmatched_weight, config.corner_weight
    )
    return np.column_stack((first, second))


def _down_start(frames: Sequence[np.ndarray], up: np.ndarray, config: GOAConfig) -> np.ndarray:
    """The down pass's first links (in reversed frame order): the up pass's last links and, with
    ``restart_lost``, fresh links for every measurement of the last frame that no head holds,
    on heads the up pass lost (no measurement in either of the last two frames), then on new
    heads. Without d_max the fresh links are limited to the speeds the up pass saw: IM2 is
    scale free, and among a few free points a fast chain of unrelated points can look smooth."""
    backwards = frames[::-1]
    start = up[:, ::-1][:, :2]
    free = np.setdiff1d(np.arange(backwards[0].shape[0]), start[:, 0])
    if not (config.restart_lost and free.size):
        return start
    limit = link_speed_limit(tracks_from_assignment(list(frames), up)) if config.d_max is None else None
    # A limit at or below the smallest speed (d_min) leaves no speed to link at.
    if limit is not None and limit > config.d_min:
        config = replace(config, d_max=limit)
    unused = np.setdiff1d(np.arange(backwards[1].shape[0]), start[:, 1])
    fresh = initial_links([backwards[0][free], backwards[1][unused], *backwards[2:]], config)
    second = np.full(free.size, UNASSIGNED, dtype=start.dtype)
    linked = fresh[:, 1] != UNASSIGNED
    second[linked] = unused[fresh[linked, 1]]
    lost = np.flatnonzero((start == UNASSIGNED).all(axis=1))[: free.size]
    extra = free.size - lost.size
    start = np.concatenate((start, np.full((extra, 2), UNASSIGNED, dtype=start.dtype)))
    rows = np.concatenate((lost, np.arange(start.shape[0] - extra, start.shape[0])))
    start[rows] = np.column_stack((free, second))
    return start


def goa(
    frames: Sequence[np.ndarray],
    initial: np.ndarray,
    config: GOAConfig = GOAConfig(),
    first_frame: int = 0,
    progress: Progress | None = None,
) -> Tracks:
    """GOA with given correspondences of the first two frames.

    Parameters
    ----------
    frames : sequence of ndarray, each (M_k, 2)
        Measurement positions per frame (x, y), pixels.
    initial : ndarray of int, shape (m, 2)
        Each track's measurement index in frames 0 and 1 (-1 for none).
    config : GOAConfig
    first_frame : int
        0-based frame index of ``frames[0]``.
    progress : callable, optional
        Called with 1 after each frame step.

    Returns
    -------
    Tracks
        One track per row of ``initial``; bound slaves interpolated.
    """
    frames = point_frames(frames)
    assignment = goa_pass(frames, np.asarray(initial, dtype=np.int64), config, progress)
    return tracks_from_assignment(frames, assignment, first_frame)


def goa_updown(
    frames: Sequence[np.ndarray],
    config: GOAConfig = GOAConfig(),
    first_frame: int = 0,
    progress: Progress | None = None,
) -> Tracks:
    """Self-initialising GOA: initial links, an up pass, then a down pass in reverse time.

    Parameters
    ----------
    frames : sequence of ndarray, each (M_k, 2)
        Measurement positions per frame (x, y), pixels.
    config : GOAConfig
    first_frame : int
        0-based frame index of ``frames[0]``.
    progress : callable, optional
        Called with 1 after each frame step of either pass (2 * (n_frames - 1) calls).

    Returns
    -------
    Tracks
        One track per measurement of the first frame (tracks the up pass lost may be replaced,
        and more added, by tracks that the down pass starts in the last frame; see
        ``GOAConfig.restart_lost``); bound slaves interpolated.
    """
    frames = point_frames(frames)
    if len(frames) < 2:
        assignment = np.arange(frames[0].shape[0])[:, None] if frames else np.empty((0, 0), np.int64)
        return tracks_from_assignment(frames, assignment, first_frame)
    up = goa_pass(frames, initial_links(frames, config), config, progress)
    if progress is not None:
        progress(1)
    backwards = frames[::-1]
    down = goa_pass(backwards, _down_start(frames, up, config), config, progress)
    if progress is not None:
        progress(1)
    return tracks_from_assignment(frames, down[:, ::-1], first_frame)


def pass_steps(n_frames: int) -> int:
    """Number of progress calls that :func:`goa_updown` makes for ``n_frames`` frames."""
    return 2 * max(n_frames - 1, 0) if n_frames >= 2 else 0


__all__ = ["GOAConfig", "goa", "goa_updown", "goa_pass", "assign_step", "initial_links", "pass_steps"]
