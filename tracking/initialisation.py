"""How a self-initialising pass picks its first links (frame 0 to frame 1).

The paper links frames 0 and 1 by optimal nearest-neighbour assignment (IM1). On a turning
dish with a generous d_max that prefers a shifted pairing at the rim, and the wrong tracks it
starts survive on slaves. Here each candidate first link is scored instead by the smoothest
path it can start over the next few frames: a dynamic programme over links, whose per-step
cost is the individual model (IM2) of each triplet. A wrong link can find a smooth-looking
continuation for one frame by chance, but hardly for several in a row.
"""

from __future__ import annotations

import collections
import contextlib
import threading
from typing import Iterator, Sequence

import numpy as np
from scipy.spatial import cKDTree

from .motion import Candidates, IndividualModel, NearestNeighbour, SmoothMotion, SpeedLimits, smooth_motion_cost

# Cost of a slave on a first-link path, as a share of phi_max.
_SLAVE_SHARE = 0.15
# Points nearest a path's predicted position that may continue it.
_CONTINUATIONS = 3
# Share of the first link's own IM1 cost (distance against the farthest candidate) in its score.
# It decides between paths that end alike (e.g. through slaves), so that the choice does not
# depend on measurement order, and it damps fast chains of unrelated points that IM2, being scale
# free, can find smooth. PSMG, 100 points, no d_max, track error at occlusion 0.1 / 0.2 (10
# seeds): share 0 -> 0.051 / 0.111, 0.2 -> 0.047 / 0.045, 0.5 -> 0.047 / 0.045; the dishes stay
# 80/80 up to 0.5 and fail at 1 (the paper's IM1 alone).
_NEAREST_SHARE = 0.3
_LINEAR_IM1 = NearestNeighbour()
# Up to this many (origin, point) distances pairs_within measures them all: below it the grid's
# bookkeeping costs more (100 x 100: 53 us against 85; 150 x 150: 214 against 97).
_ALL_DISTANCES_UP_TO = 16384
# A hair beyond each radius for the grid's cell range, so that rounding loses no pair that the
# exact test keeps.
_ROUNDING = 1e-9


class _SharedTrees(threading.local):
    """The KD-trees built within :func:`shared_trees` blocks of this thread, by content."""

    def __init__(self) -> None:
        self.depth = 0
        self.trees: collections.OrderedDict[tuple, cKDTree] = collections.OrderedDict()
        self.points = 0


_SHARED = _SharedTrees()
# Trees kept at once, and points in them: a pass looks at the frames about its step, so older ones
# are let go (a million points' trees are tens of megabytes).
_TREES_KEPT = 16
_POINTS_KEPT = 1_000_000


@contextlib.contextmanager
def shared_trees() -> Iterator[None]:
    """Within the block, :func:`tree_of` builds one KD-tree for the same points, asked again.

    A pass asks for a frame's tree at its step, when it confirms a head back from slaves by the
    next frames, and when it opens tracks among the frames' free points (the same points, in
    another array, from one step to the next until the pass reaches them): linking bulk water's
    detections built 11,102 trees, 2,849 with them shared. The trees are let go when the
    outermost block ends.

    Example
    -------
    >>> frame = np.arange(6.0).reshape(3, 2)
    >>> with shared_trees():
    ...     tree_of(frame) is tree_of(frame.copy())
    True
    """
    _SHARED.depth += 1
    try:
        yield
    finally:
        _SHARED.depth -= 1
        if not _SHARED.depth:
            _SHARED.trees.clear()
            _SHARED.points = 0


def tree_of(points: np.ndarray) -> cKDTree:
    """The KD-tree of ``points`` (M, 2), pixels: built once for the same points within
    :func:`shared_trees`, anew outside.

    Example
    -------
    >>> int(tree_of(np.array([[0.0, 0.0], [3.0, 4.0]])).query([3.0, 3.0])[1])
    1
    """
    if not _SHARED.depth:
        return cKDTree(points)
    key = (points.shape, hash(points.tobytes()))
    tree = _SHARED.trees.get(key)
    if tree is not None and np.array_equal(tree.data, points):
        _SHARED.trees.move_to_end(key)
        return tree
    tree = cKDTree(points)
    if key in _SHARED.trees:
        _SHARED.points -= _SHARED.trees.pop(key).n
    _SHARED.trees[key] = tree
    _SHARED.points += tree.n
    while len(_SHARED.trees) > _TREES_KEPT or (_SHARED.points > _POINTS_KEPT and len(_SHARED.trees) > 1):
        _SHARED.points -= _SHARED.trees.popitem(last=False)[1].n
    return tree


def pairs_within(origins: np.ndarray, radius: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """All (origin, point) index pairs with the point within the origin's radius (pixels),
    ordered by origin, then by point: the pairs of cKDTree.query_ball_point, found faster.

    A point is within when its squared distance is at most the squared radius, the test
    query_ball_point makes. Few origins and points are tested all against all; otherwise the
    points are binned on a grid of square cells (:func:`_grid_pairs`) and each origin is tested
    against the cells its radius reaches. Against a KD-tree query per origin (Python lists of
    its points) or trees of origins by radius class, this took a third to a half of the time
    from 400 to 100,000 points a frame.

    Example
    -------
    >>> pairs_within(np.array([[0.0, 0.0], [10.0, 0.0]]), np.array([1.0, 5.0]), np.array([[0.0, 1.0], [12.0, 0.0], [0.5, 0.0]]))
    (array([0, 0, 1]), array([0, 2, 1]))
    """
    empty = np.empty(0, np.int64)
    if origins.shape[0] == 0 or points.shape[0] == 0:
        return empty, empty
    radius = np.broadcast_to(np.asarray(radius, dtype=float), origins.shape[:1])
    if origins.shape[0] * points.shape[0] <= _ALL_DISTANCES_UP_TO:
        dx = points[:, 0] - origins[:, 0, None]
        dy = points[:, 1] - origins[:, 1, None]
        owner, target = np.nonzero(dx * dx + dy * dy <= (radius * radius)[:, None])
        return owner.astype(np.int64, copy=False), target.astype(np.int64, copy=False)
    owner, target = _grid_pairs(origins, radius, points)
    step = points[target] - origins[owner]
    kept = step[:, 0] * step[:, 0] + step[:, 1] * step[:, 1] <= radius[owner] * radius[owner]
    owner, target = owner[kept], target[kept]
    order = np.argsort(owner * points.shape[0] + target)
    return owner[order], target[order]


def _grid_pairs(origins: np.ndarray, radius: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Candidate (origin, point) pairs, a superset of those within the radius: every point in
    the grid cells that each origin's square of side twice its radius touches.

    The cells are as wide as the median radius, or wider where the points are sparser (about
    one point a cell at most), so an origin looks at a few rows of a few cells. Points are
    sorted by cell, row by row, so one origin's cells in one row hold a contiguous run of them,
    found in a table of where each cell's run starts. Infinite radii take every point.
    """
    n_points = points.shape[0]
    reach = np.abs(radius)
    owners, targets = [], []
    everywhere = np.flatnonzero(np.isinf(reach))
    if everywhere.size:
        owners.append(np.repeat(everywhere, n_points))
        targets.append(np.tile(np.arange(n_points), everywhere.size))
    searched = np.flatnonzero(np.isfinite(reach) & np.isfinite(origins[:, 0]) & np.isfinite(origins[:, 1]))
    if searched.size:
        # Columns are taken apart: reductions along axis 0 of an (M, 2) array cost ten times more.
        x, y = points[:, 0], points[:, 1]
        low_x, low_y = float(x.min()), float(y.min())
        span_x, span_y = float(x.max()) - low_x, float(y.max()) - low_y
        cell = max(float(np.median(reach[searched])), (span_x * span_y / n_points) ** 0.5, max(span_x, span_y) / n_points, _ROUNDING)
        scale = 1.0 / cell
        columns, rows = int(span_x * scale) + 1, int(span_y * scale) + 1
        key = np.floor((y - low_y) * scale).astype(np.int64) * columns + np.floor((x - low_x) * scale).astype(np.int64)
        order = np.argsort(key, kind="stable")
        start = np.zeros(columns * rows + 1, np.int64)
        np.cumsum(np.bincount(key, minlength=columns * rows), out=start[1:])
        x, y = origins[searched, 0] - low_x, origins[searched, 1] - low_y
        r = reach[searched] * (1 + _ROUNDING)
        left = np.clip(np.floor((x - r) * scale), 0, columns - 1).astype(np.int64)
        right = np.clip(np.floor((x + r) * scale), -1, columns - 1).astype(np.int64)
        top = np.clip(np.floor((y - r) * scale), 0, rows - 1).astype(np.int64)
        bottom = np.clip(np.floor((y + r) * scale), -1, rows - 1).astype(np.int64)
        runs = np.where(right >= left, np.maximum(bottom - top + 1, 0), 0)
        run_origin = np.repeat(np.arange(searched.size), runs)
        row_start = (top[run_origin] + np.arange(run_origin.size) - np.repeat(np.cumsum(runs) - runs, runs)) * columns
        low = start[row_start + left[run_origin]]
        count = start[row_start + right[run_origin] + 1] - low
        owners.append(searched[np.repeat(run_origin, count)])
        targets.append(order[np.repeat(low - (np.cumsum(count) - count), count) + np.arange(int(count.sum()))])
    if len(owners) == 1:
        return owners[0], targets[0]
    if not owners:
        return np.empty(0, np.int64), np.empty(0, np.int64)
    return np.concatenate(owners), np.concatenate(targets)


def first_links(
    frames: Sequence[np.ndarray],
    model: IndividualModel,
    phi_max: float,
    limits: SpeedLimits,
    neighbours: int,
    lookahead: int,
    slave_cost: float | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Candidate links from frame 0 to frame 1, each scored by its smoothest continuation.

    Parameters
    ----------
    frames : sequence of ndarray, each (M_k, 2)
        Measurement positions, pixels, in processing order; at least 2 frames.
    model : IndividualModel
        Scores each triplet by smooth motion: IM2 with its weights, any other model is replaced
        by IM2 with default weights.
    phi_max : float
        Largest cost of any triplet on a path.
    limits : SpeedLimits
        The speed gate of every link of a path, pixels/frame; with no d_max, the ``neighbours``
        nearest points of frame 1 are the candidates of each point of frame 0 and phi_max
        bounds the speeds after that.
    neighbours : int
        Candidates per frame-0 point when there is no d_max.
    lookahead : int
        Frames the path spans, the first link's two included (3 scores by one triplet).
    slave_cost : float, optional
        Cost of a path step that skips a missed point: the path may pass one frame at a time
        through the position its velocity predicts, as a slave does. Default 0.15 phi_max
        (the best of 0.03 to 0.25 on occluded PSMG scenes): without it a point missed early
        makes its true first link look rough (phi_max per missing step), and at high speed a
        chain of unrelated points that IM2, being scale free, finds smooth wins instead.

    Returns
    -------
    head, measurement, cost : ndarray, shape (P,)
        Frame-0 index, frame-1 index and the score of that link: the mean triplet cost of the
        best path that it starts, mixed with 0.3 of its IM1 cost. A path that cannot be
        continued within phi_max pays phi_max for each triplet it lacks, so the link stays
        possible but loses to smooth alternatives.
    """
    link_model = model
    if not isinstance(model, SmoothMotion):
        model = SmoothMotion()
    if slave_cost is None:
        slave_cost = _SLAVE_SHARE * phi_max
    horizon = min(lookahead, len(frames))
    head, measurement = _first_candidates(frames[0], frames[1], limits.d_max, neighbours)
    velocity = np.take(frames[1], measurement, axis=0) - np.take(frames[0], head, axis=0)
    valid = limits.admits(velocity)
    head, measurement = head[valid], measurement[valid]
    if not head.size:
        # Nothing to score: most windows in which tracks may open hold no link.
        return head, measurement, np.empty(0)
    # A model measured on the data brings its own speed scale, so that a speed limit only
    # removes candidates and does not reweigh the rest (seedtrack.tracking.adaptive).
    scale = getattr(link_model, "speed_scale", None) or limits.scale(velocity[valid])
    # Without a lookahead an IM1 link model scores by its own cost (its power, 1 or 2); otherwise
    # the paper's linear IM1, the cost _NEAREST_SHARE was measured with.
    nearest_model = link_model if horizon < 3 and link_model.order == 1 else _LINEAR_IM1
    pairs = Candidates(head, measurement, velocity[valid], np.ones(head.size, np.int64), np.full((head.size, 2), np.nan))
    nearest = nearest_model.cost(pairs, phi_max, scale)
    if horizon < 3:
        return head, measurement, nearest

    # Links of each step, as (from, to) index pairs; triplets chain link a of step k to
    # link b of step k + 1 with a.to == b.from.
    links = [(head, measurement)]
    triplets: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
    # Each frame's points followed by the slaves (predicted positions) that paths put there.
    points = [np.asarray(f, dtype=float) for f in frames[:horizon]]
    for step in range(1, horizon - 1):
        origin, target = links[-1]
        # Rows taken by index (fancy indexing of (n, 2) arrays costs several times more).
        start, middle = points[step - 1].take(origin, axis=0), points[step].take(target, axis=0)
        move = middle - start
        # A smooth continuation lies near the straight-line prediction, so each link looks at
        # the points nearest to it (exact gating by IM2 alone would reach far for fast links).
        k = min(_CONTINUATIONS, frames[step + 1].shape[0])
        point_out = _nearest(frames[step + 1], middle + move, k) if k and origin.size else np.empty(0, np.int64)
        link_in = np.repeat(np.arange(origin.size), k)
        middle_index = target[link_in]
        next_velocity = np.take(frames[step + 1], point_out, axis=0) - middle.take(link_in, axis=0)
        triplet_cost = smooth_motion_cost(move.take(link_in, axis=0), next_velocity, model.w1, model.w2)
        ok = (triplet_cost <= phi_max) & limits.admits(next_velocity)
        link_in, point_out, middle_index, triplet_cost = link_in[ok], point_out[ok], middle_index[ok], triplet_cost[ok]
        # A link into a measured point may go on through a slave (one in a row at most), unless a
        # measured continuation already costs less than the slave would.
        smooth = np.zeros(origin.size, bool)
        smooth[link_in[triplet_cost < slave_cost]] = True
        into_measured = np.flatnonzero((target < frames[step].shape[0]) & ~smooth)
        slaves = frames[step + 1].shape[0] + np.arange(into_measured.size)
        points[step + 1] = np.concatenate((points[step + 1], middle.take(into_measured, axis=0) + move.take(into_measured, axis=0)))
        link_in = np.concatenate((link_in, into_measured))
        point_out = np.concatenate((point_out, slaves))
        middle_index = np.concatenate((middle_index, target[into_measured]))
        triplet_cost = np.concatenate((triplet_cost, np.full(into_measured.size, slave_cost)))
        width = points[step + 1].shape[0]
        out_links, link_out = np.unique(middle_index * width + point_out, return_inverse=True)
        links.append((out_links // width, out_links % width))
        triplets.append((link_in, link_out.ravel(), triplet_cost))

    # Backward dynamic programme: cheapest remaining path cost from each link.
    to_go = np.zeros(links[-1][0].size)
    for step in range(len(triplets) - 1, -1, -1):
        link_in, link_out, triplet_cost = triplets[step]
        missing = phi_max * (len(triplets) - step)
        best = np.full(links[step][0].size, missing)
        np.minimum.at(best, link_in, triplet_cost + to_go[link_out])
        to_go = best
    # The mix of two costs within phi_max is within phi_max; clipping keeps rounding from
    # pruning a link at the limit.
    cost = (1 - _NEAREST_SHARE) * to_go / len(triplets) + _NEAREST_SHARE * nearest
    return head, measurement, np.minimum(cost, phi_max)


def _nearest(points: np.ndarray, centres: np.ndarray, k: int) -> np.ndarray:
    """The ``k`` nearest of ``points`` to each centre, pixels, as ``k`` indices a centre (row
    after row; in no set order within a row): the set a KD-tree query gives, which is all that
    the paths use. A frame of ``k`` points (windows of free points often are) needs no tree."""
    if k == points.shape[0]:
        return np.tile(np.arange(k), centres.shape[0])
    _, index = tree_of(points).query(centres, k=k)
    return np.asarray(index).reshape(-1, k).ravel()


def _first_candidates(
    first: np.ndarray, second: np.ndarray, d_max: float | None, neighbours: int
) -> tuple[np.ndarray, np.ndarray]:
    if d_max is not None:
        return pairs_within(first, np.full(first.shape[0], d_max), second)
    k = min(neighbours, second.shape[0])
    if k == 0 or first.shape[0] == 0:
        return np.empty(0, np.int64), np.empty(0, np.int64)
    _, index = tree_of(second).query(first, k=k)
    index = np.asarray(index).reshape(first.shape[0], k)
    return np.repeat(np.arange(first.shape[0]), k), index.ravel()
