"""The IPAN tracker of Chetverikov and Verestoy (the paper's CV), self-initialising.

Each frame k is processed with its neighbours k-1 and k+1. For every point P of frame k the
triplets (a, P, b) that move at most v_max per frame and deviate less than delta_max (the
Sethi-Jain smooth-motion cost) are hypotheses, tried cheapest first. A hypothesis is rejected
when a competing triplet is cheaper: another point of frame k that could take b, or (when a
still starts a trajectory) another point that could follow a. With verification depth N_ver the
competing triplet must itself survive the same test one level shallower, so a hypothesis
overruled by a competitor that is itself overruled is restored. An accepted triplet fixes its
links for good. A point whose hypotheses all fail stays unlinked and may start a trajectory
from the next frame; a point with a backward link but no forward one ends its trajectory.

Post-processing closes gaps of up to ``max_gap`` frames between a trajectory's end and a later
start: the missing points are searched on a grid of directions and speeds within the limits
that delta_max puts on the direction and speed terms, and the pair whose bridged trajectory is
smoothest is joined first.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from scipy.spatial import cKDTree

from .motion import smooth_motion_cost
from .tracks import Tracks, check_limit, point_frames, tracks_from_links

FREE = -1
# Speeds of the gap search's grid at most: 1 px/frame steps up to a v_max of 16 px/frame, as in
# the authors' scenes; coarser beyond, so that the work stays bounded.
_MAX_SPEEDS = 16


@dataclass(frozen=True)
class IPANConfig:
    """Parameters of the IPAN tracker.

    Attributes
    ----------
    v_max : float
        Search radius: largest speed, pixels/frame.
    delta_max : float
        Largest smooth-motion cost of a triplet (0.6 in the authors' experiments).
    n_ver : int
        Verification depth (2 in the authors' experiments).
    max_gap : int
        Longest run of missing frames that post-processing bridges (2; 0 turns it off).
    angle_step : float
        Direction resolution of the gap search, degrees (10).
    speed_step : float
        Speed resolution of the gap search, pixels/frame (1).
    w1, w2 : float
        Weights of the direction and speed terms of the cost.
    max_candidates : int
        Each point considers at most this many of the nearest points within v_max in each
        neighbouring frame. Hypotheses and competitors grow with the square of the candidates
        and verification nests them, so on dense input with a loose v_max (no limit given, or
        one estimated high) the work is bounded by this rather than by the whole frame; with
        fewer candidates than this, as in the paper's scenes, it changes nothing.
    max_gap_candidates : int
        Post-processing tries each trajectory end with at most this many of the nearest starts
        in each later frame within reach, for the same reason (each try searches a grid).
    """

    v_max: float
    delta_max: float = 0.6
    n_ver: int = 2
    max_gap: int = 2
    angle_step: float = 10.0
    speed_step: float = 1.0
    w1: float = 0.1
    w2: float = 0.9
    max_candidates: int = 8
    max_gap_candidates: int = 3

    def __post_init__(self) -> None:
        check_limit("v_max", self.v_max, optional=False)
        if not 0 < self.delta_max < 1:
            raise ValueError(f"delta_max must lie in (0, 1), got {self.delta_max}")
        if self.n_ver < 1:
            raise ValueError(f"n_ver must be at least 1, got {self.n_ver}")
        if not 0 <= self.max_gap <= 2:
            raise ValueError(f"max_gap must be 0, 1 or 2, got {self.max_gap}")
        if self.angle_step <= 0 or self.speed_step <= 0:
            raise ValueError("the gap search steps must be positive")
        if min(self.max_candidates, self.max_gap_candidates) < 1:
            raise ValueError("max_candidates and max_gap_candidates must be at least 1")

    def cost(self, a: np.ndarray, p: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Smooth-motion cost of triplets a -> p -> b, positions of shape (..., 2)."""
        shape = np.broadcast_shapes(a.shape, p.shape, b.shape)[:-1]
        before = np.broadcast_to(p - a, shape + (2,)).reshape(-1, 2)
        after = np.broadcast_to(b - p, shape + (2,)).reshape(-1, 2)
        return smooth_motion_cost(before, after, self.w1, self.w2).reshape(shape)


class _Linker:
    """Hypothesis testing for the middle frame of three; links are stored per frame."""

    def __init__(self, frames: list[np.ndarray], config: IPANConfig):
        self.frames, self.config = frames, config
        self.forward = [np.full(f.shape[0], FREE, dtype=np.int64) for f in frames]
        self.backward = [np.full(f.shape[0], FREE, dtype=np.int64) for f in frames]
        trees = [cKDTree(f) if f.shape[0] else None for f in frames]
        # near[k][p]: points of frame k + 1 within v_max of point p of frame k, and back.
        self.ahead = [self._near(trees[k + 1], frames[k]) for k in range(len(frames) - 1)]
        self.behind = [None] + [self._near(trees[k - 1], frames[k]) for k in range(1, len(frames))]

    def _near(self, tree: cKDTree | None, points: np.ndarray) -> list[np.ndarray]:
        if tree is None or points.shape[0] == 0:
            return [np.empty(0, np.int64) for _ in range(points.shape[0])]
        # A point moving at exactly v_max must be found despite rounding.
        radius = self.config.v_max * (1.0 + 1e-9)
        k = min(self.config.max_candidates, tree.n)
        distance, index = tree.query(points, k=k, distance_upper_bound=radius)
        index = np.asarray(index).reshape(points.shape[0], k)
        found = np.isfinite(np.asarray(distance).reshape(points.shape[0], k))
        return [np.sort(row[keep]).astype(np.int64) for row, keep in zip(index, found)]

    def starts(self, k: int, p: int) -> np.ndarray:
        """Points of frame k - 1 that point p of frame k may follow: its fixed predecessor, or
        the untouched points (no link yet) within v_max, which would start a trajectory."""
        fixed = self.backward[k][p]
        if fixed != FREE:
            return np.array([fixed])
        near = self.behind[k][p]
        return near[(self.forward[k - 1][near] == FREE) & (self.backward[k - 1][near] == FREE)]

    def ends(self, k: int, p: int) -> np.ndarray:
        """Points of frame k + 1 within v_max of point p of frame k that no point claims yet."""
        near = self.ahead[k][p]
        return near[self.backward[k + 1][near] == FREE]

    def hypotheses(self, k: int, p: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """All (a, b) for point p of frame k with cost below delta_max, cheapest first."""
        a, b = self.starts(k, p), self.ends(k, p)
        if a.size == 0 or b.size == 0:
            return np.empty(0, np.int64), np.empty(0, np.int64), np.empty(0)
        a, b = np.repeat(a, b.size), np.tile(b, a.size)
        f0, f1, f2 = self.frames[k - 1], self.frames[k], self.frames[k + 1]
        cost = self.config.cost(f0[a], f1[p][None], f2[b])
        keep = cost < self.config.delta_max
        order = np.argsort(cost[keep], kind="stable")
        return a[keep][order], b[keep][order], cost[keep][order]

    def competitors(self, k: int, a: int, p: int, b: int, cost: float) -> list[tuple[int, int, int, float]]:
        """Triplets cheaper than (a, p, b) that would take its b, or its a while a is free."""
        f0, f1, f2 = self.frames[k - 1], self.frames[k], self.frames[k + 1]
        # Every competing triplet of a kind is costed in one call: the calls, not the
        # arithmetic, are what dense input multiplies.
        takers = [q for q in self.behind[k + 1][b] if q != p and self.forward[k][q] == FREE]
        r, q = self._pairs(takers, [self.starts(k, q) for q in takers])
        c = self.config.cost(f0[r], f1[q], f2[b][None]) if r.size else np.empty(0)
        cheaper = c < cost
        found = [(int(x), int(y), b, float(z)) for x, y, z in zip(r[cheaper], q[cheaper], c[cheaper])]
        if self.backward[k][p] == FREE:
            followers = [q for q in self.ahead[k - 1][a] if q != p and self.forward[k][q] == FREE and self.backward[k][q] == FREE]
            s, q = self._pairs(followers, [self.ends(k, q) for q in followers])
            c = self.config.cost(f0[a][None], f1[q], f2[s]) if s.size else np.empty(0)
            cheaper = c < cost
            found.extend((a, int(y), int(x), float(z)) for x, y, z in zip(s[cheaper], q[cheaper], c[cheaper]))
        return found

    @staticmethod
    def _pairs(points: list[int], partners: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        """Each point's partners, flattened in order, beside the point they belong to."""
        if not points:
            return np.empty(0, np.int64), np.empty(0, np.int64)
        return np.concatenate(partners).astype(np.int64), np.repeat(np.asarray(points, np.int64), [len(x) for x in partners])

    def accepted(self, k: int, a: int, p: int, b: int, cost: float, depth: int) -> bool:
        """True when no cheaper competitor survives verification one level shallower."""
        for competitor in self.competitors(k, a, p, b, cost):
            if depth <= 1 or self.accepted(k, *competitor, depth - 1):
                return False
        return True

    def process(self, k: int) -> None:
        """Link the points of frame k backwards and forwards where a hypothesis holds."""
        for p in range(self.frames[k].shape[0]):
            for a, b, cost in zip(*self.hypotheses(k, p)):
                if self.accepted(k, int(a), p, int(b), float(cost), self.config.n_ver):
                    self.backward[k][p], self.forward[k - 1][a] = a, p
                    self.forward[k][p], self.backward[k + 1][b] = b, p
                    break

    def links(self) -> list[tuple[int, int, int, int]]:
        return [(k, p, k + 1, int(q)) for k, f in enumerate(self.forward[:-1]) for p, q in enumerate(f) if q != FREE]


def _speed_bounds(speed: np.ndarray, delta_max: float, v_max: float) -> tuple[np.ndarray, np.ndarray]:
    """Speeds whose unweighted Sethi-Jain speed term against ``speed`` stays within delta_max."""
    root = math.sqrt(delta_max * (2.0 - delta_max))
    scale = speed / (1.0 - delta_max) ** 2
    return scale * (1.0 - root) ** 2, np.minimum(scale * (1.0 + root) ** 2, v_max)


def _continuations(origin: np.ndarray, velocity: np.ndarray, config: IPANConfig) -> np.ndarray:
    """Grid of next positions from ``origin`` (N, 2) moving on from ``velocity`` (N, 2).

    Directions within arccos(1 - delta_max) of the velocity's, in steps of ``angle_step``;
    speeds from the lowest that the delta_max limits allow up to the highest (capped at
    v_max) in steps of ``speed_step`` (wider when that would give more than ``_MAX_SPEEDS``
    speeds), the highest included. Returns shape (N, G, 2), NaN-padded.
    """
    half = math.degrees(math.acos(1.0 - config.delta_max))
    turns = np.radians(np.arange(-math.floor(half / config.angle_step), math.floor(half / config.angle_step) + 1)
                       * config.angle_step)
    speed = np.hypot(*velocity.T)
    heading = np.arctan2(velocity[:, 1], velocity[:, 0])
    # From the slowest allowed speed up to the fastest, both included, so that points near
    # standstill or near v_max have candidates too. A loose v_max would make the grid, and the
    # pairs of it bridging two missing frames, grow without bound: past _MAX_SPEEDS speeds the
    # step widens instead.
    low, high = _speed_bounds(speed, config.delta_max, config.v_max)
    step = np.maximum(config.speed_step, (high - low) / _MAX_SPEEDS)
    count = np.maximum(np.floor((high - low) / step) + 1, 0).astype(np.int64)
    last = low + step * (count - 1)
    with_high = (count > 0) & (high - last > 1e-9)
    size = int((count + with_high).max(initial=0))
    if size == 0:
        return np.empty((origin.shape[0], 0, 2))
    column = np.arange(size)
    speeds = np.where(column < count[:, None], low[:, None] + step[:, None] * column, np.nan)
    rows = np.flatnonzero(with_high)
    speeds[rows, count[rows]] = high[rows]
    angle = heading[:, None, None] + turns[None, :, None]
    step = np.stack((np.cos(angle) * speeds[:, None, :], np.sin(angle) * speeds[:, None, :]), axis=-1)
    return (origin[:, None, None, :] + step).reshape(origin.shape[0], -1, 2)


def bridge_cost(before: np.ndarray, end: np.ndarray, start: np.ndarray, after: np.ndarray, gap: int,
                config: IPANConfig) -> float:
    """Smallest mean triplet cost of a trajectory bridged over ``gap`` missing frames.

    Parameters
    ----------
    before, end : ndarray, shape (2,)
        The last two points of the ended trajectory, pixels.
    start, after : ndarray, shape (2,)
        The first two points of the later trajectory, pixels.
    gap : int
        Missing frames between ``end`` and ``start`` (1 or 2).
    config : IPANConfig

    Returns
    -------
    float
        The mean cost over the bridged trajectory's triplets, ``inf`` when no grid point keeps
        every triplet below delta_max and reaches ``start`` within v_max.
    """
    # Each triplet's test prunes the grid before the next is built: the same minimum as testing
    # every path of the grid, at a fraction of the work when two frames are missing.
    missing = _continuations(end[None], (end - before)[None], config)[0]  # (G, 2)
    first = config.cost(before[None], end[None], missing)
    keep = ~np.isnan(missing[:, 0]) & (first < config.delta_max)
    missing, costs = missing[keep], [first[keep]]
    last, previous = missing, np.broadcast_to(end, missing.shape)
    if gap == 2:
        second = _continuations(missing, missing - end[None], config)  # (G, H, 2)
        cost = config.cost(end[None, None], missing[:, None], second)
        keep = ~np.isnan(second[..., 0]) & (cost < config.delta_max)
        rows, columns = np.nonzero(keep)
        costs = [costs[0][rows], cost[rows, columns]]
        last, previous = second[rows, columns], missing[rows]
    reach = np.hypot(*(start[None] - last).T) <= config.v_max
    costs = [c[reach] for c in costs]
    last, previous = last[reach], previous[reach]
    costs += [config.cost(previous, last, start[None]), config.cost(last, start[None], after[None])]
    valid = (costs[-2] < config.delta_max) & (costs[-1] < config.delta_max)
    return float((sum(costs) / len(costs))[valid].min()) if valid.any() else math.inf


def close_gaps(frames: list[np.ndarray], links: list[tuple[int, int, int, int]], config: IPANConfig
               ) -> list[tuple[int, int, int, int]]:
    """Links that join trajectory ends to later starts across up to ``max_gap`` missing frames.

    Only an end with an incoming link and a start with an outgoing link have the velocities the
    search needs. Each end is tried with the ``max_gap_candidates`` nearest starts of each later
    frame within reach. Candidate joins are taken smoothest first, each end and start at most once.
    """
    successor = {(k, p): (j, q) for k, p, j, q in links}
    predecessor = {(j, q): (k, p) for k, p, j, q in links}
    ends = [key for key in predecessor if key not in successor]
    starts_in: dict[int, list[tuple[int, int]]] = {}
    for key in sorted(key for key in successor if key not in predecessor):
        starts_in.setdefault(key[0], []).append(key)
    candidates = []
    for end in ends:
        e = frames[end[0]][end[1]]
        for gap in range(1, config.max_gap + 1):
            starts = starts_in.get(end[0] + gap + 1, [])
            if not starts:
                continue
            distance = np.hypot(*(np.array([frames[k][q] for k, q in starts]) - e).T)
            near = np.argsort(distance, kind="stable")[: config.max_gap_candidates]
            for start in (starts[i] for i in near if distance[i] <= (gap + 1) * config.v_max):
                b, a = predecessor[end], successor[start]
                s = frames[start[0]][start[1]]
                cost = bridge_cost(frames[b[0]][b[1]], e, s, frames[a[0]][a[1]], gap, config)
                if math.isfinite(cost):
                    candidates.append((cost, end, start))
    joined, used = [], set()
    for cost, end, start in sorted(candidates):
        if end not in used and start not in used:
            used.update((end, start))
            joined.append(end + start)
    return joined


def ipan(frames: Sequence[np.ndarray], config: IPANConfig, first_frame: int = 0) -> Tracks:
    """Track with the self-initialising IPAN tracker and its gap-closing post-processing.

    Parameters
    ----------
    frames : sequence of ndarray, each (M_k, 2)
        Measurement positions per frame (x, y), pixels.
    config : IPANConfig
    first_frame : int
        0-based frame index of ``frames[0]``.

    Returns
    -------
    Tracks
        One track per linked chain; bridged gaps are filled on straight lines; unlinked points
        are one-point tracks.
    """
    frames = point_frames(frames)
    linker = _Linker(frames, config)
    for k in range(1, len(frames) - 1):
        linker.process(k)
    links = linker.links()
    if config.max_gap:
        links += close_gaps(frames, links, config)
    return tracks_from_links(frames, np.array(links, dtype=np.int64).reshape(-1, 4), first_frame)


__all__ = ["IPANConfig", "ipan", "bridge_cost", "close_gaps"]
