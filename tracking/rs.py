"""Rangarajan and Shah's greedy tracker (IM3 + CM2), the paper's RS, and RS' with a speed limit.

A fixed set of track heads (the points of the first frame, linked to the second by optimal
nearest neighbour) is extended frame by frame. Within a frame pair the pairs are scored by
proximal uniformity (IM3) and taken one at a time, greedily: among the pairs that are their
head's cheapest, the one whose alternatives (the head's other measurements) and competitors
(the measurement's other heads) are most expensive relative to its own cost. A head left
without a measurement is continued on a straight line (extrapolation), which is how RS bridges
occlusion; extra measurements are ignored.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from .motion import Candidates, proximal_uniformity_cost
from .nn import link_nearest
from .tracks import NO_MEASUREMENT, Tracks, check_limit, order_independent, point_frames


def greedy_conditioned_assignment(cost: np.ndarray) -> np.ndarray:
    """Rangarajan and Shah's greedy choice of pairs from a head x measurement cost matrix.

    Repeatedly takes, among the pairs that are the cheapest of their row, the one that
    maximises mean alternative cost + mean competitor cost - own cost, over the heads and
    measurements still free, until no allowed pair is left. A pair with no alternative (or no
    competitor) is unambiguous, so its missing mean counts as the largest cost of the frame.

    Parameters
    ----------
    cost : ndarray of float, shape (m, M)
        Individual costs; ``inf`` marks a forbidden pair.

    Returns
    -------
    ndarray of int, shape (m,)
        Measurement index per head, or -1.
    """
    m, n = cost.shape
    result = np.full(m, NO_MEASUREMENT, dtype=np.int64)
    allowed = np.isfinite(cost)
    if not allowed.any():
        return result
    ceiling = float(cost[allowed].max())
    value = np.where(allowed, cost, 0.0)
    while allowed.any():
        row_count = allowed.sum(axis=1, keepdims=True)
        column_count = allowed.sum(axis=0, keepdims=True)
        row_total = np.where(allowed, value, 0.0).sum(axis=1, keepdims=True)
        column_total = np.where(allowed, value, 0.0).sum(axis=0, keepdims=True)
        alternatives = np.divide(row_total - value, row_count - 1, out=np.full((m, n), ceiling), where=row_count > 1)
        competitors = np.divide(
            column_total - value, column_count - 1, out=np.full((m, n), ceiling), where=column_count > 1
        )
        masked = np.where(allowed, value, np.inf)
        cheapest = allowed & (masked <= masked.min(axis=1, keepdims=True))
        score = np.where(cheapest, alternatives + competitors - value, -np.inf)
        head, measurement = np.unravel_index(int(np.argmax(score)), score.shape)
        result[head] = measurement
        allowed[head, :] = False
        allowed[:, measurement] = False
    return result


@order_independent
def rangarajan_shah(
    frames: Sequence[np.ndarray],
    d_max: float | None = None,
    initial: np.ndarray | None = None,
    first_frame: int = 0,
) -> Tracks:
    """Track with Rangarajan and Shah's greedy proximal-uniformity algorithm.

    Parameters
    ----------
    frames : sequence of ndarray, each (M_k, 2)
        Measurement positions per frame (x, y), pixels.
    d_max : float or None
        Largest speed, pixels/frame (the paper's RS'); None is the original RS, which allows
        any pair.
    initial : ndarray of int, shape (m, 2), optional
        Given correspondences of frames 0 and 1 (-1 for none); by default one head per point
        of frame 0, linked to frame 1 by optimal nearest neighbour within ``d_max``.
    first_frame : int
        0-based frame index of ``frames[0]``.

    Returns
    -------
    Tracks
        One track per head. Frames where a head found no measurement hold its extrapolated
        position, marked as interpolated.
    """
    frames = point_frames(frames)
    d_max = check_limit("d_max", d_max)
    n_frames = len(frames)
    if initial is None:
        heads = np.arange(frames[0].shape[0]) if frames else np.empty(0, np.int64)
        initial = np.column_stack((heads, np.full(heads.size, NO_MEASUREMENT)))
        if n_frames > 1:
            rows, columns = link_nearest(frames[0], frames[1], d_max)
            initial[rows, 1] = columns
    initial = np.asarray(initial, dtype=np.int64)
    m = initial.shape[0]
    measurement = np.full((m, n_frames), NO_MEASUREMENT, dtype=np.int64)
    xy = np.full((m, n_frames, 2), np.nan)
    if n_frames == 0 or m == 0:
        return Tracks.from_dense(xy=xy, measurement=measurement, first_frame=first_frame)
    columns = min(initial.shape[1], n_frames)
    measurement[:, :columns] = initial[:, :columns]
    for k in range(columns):
        held = measurement[:, k] != NO_MEASUREMENT
        xy[held, k] = frames[k][measurement[held, k]]
    # A head missing in frame 1 stays where it was: with no velocity, that is its extrapolation.
    if columns > 1:
        xy[:, 1] = np.where(np.isnan(xy[:, 1]), xy[:, 0], xy[:, 1])
    velocity = xy[:, 1] - xy[:, 0] if columns > 1 else np.full((m, 2), np.nan)

    for k in range(columns, n_frames):
        position, points = xy[:, k - 1], frames[k]
        choice = np.full(m, NO_MEASUREMENT, dtype=np.int64)
        alive = ~np.isnan(position[:, 0])
        if points.shape[0] and alive.any():
            choice[alive] = greedy_conditioned_assignment(
                _pair_costs(position[alive], velocity[alive], points, d_max)
            )
        held = choice != NO_MEASUREMENT
        measurement[:, k] = choice
        xy[held, k] = points[choice[held]]
        xy[~held, k] = position[~held] + np.nan_to_num(velocity[~held])
        velocity = np.where(held[:, None], xy[:, k] - position, velocity)
    return Tracks.from_dense(xy=xy, measurement=measurement, first_frame=first_frame)


def _pair_costs(position: np.ndarray, velocity: np.ndarray, points: np.ndarray, d_max: float | None) -> np.ndarray:
    """IM3 cost of every head-measurement pair, normalised over the allowed pairs; inf beyond d_max."""
    m, n = position.shape[0], points.shape[0]
    head = np.repeat(np.arange(m), n)
    target = np.tile(np.arange(n), m)
    displacement = points[target] - position[head]
    allowed = np.ones(head.size, bool) if d_max is None else np.hypot(*displacement.T) <= d_max
    candidates = Candidates(
        head=head[allowed],
        measurement=target[allowed],
        displacement=displacement[allowed],
        gap=np.ones(int(allowed.sum()), dtype=np.int64),
        previous_velocity=velocity[head[allowed]],
    )
    cost = np.full(m * n, np.inf)
    cost[allowed] = proximal_uniformity_cost(candidates)
    return cost.reshape(m, n)


__all__ = ["rangarajan_shah", "greedy_conditioned_assignment"]
