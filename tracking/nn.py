"""Frame-to-frame optimal nearest-neighbour linking (the simplest baseline; IM1 + CM1).

Each pair of consecutive frames is linked by one optimal assignment that minimises the summed
distance, with pairs farther apart than d_max forbidden. A point that finds no partner ends its
track, and an unclaimed point starts one: there is no memory of motion and no gap closing.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from .assignment import UNASSIGNED, solve_split
from .initialisation import pairs_within
from .tracks import Tracks, check_limit, order_independent, point_frames, tracks_from_links


def link_nearest(before: np.ndarray, after: np.ndarray, d_max: float | None) -> tuple[np.ndarray, np.ndarray]:
    """Optimal one-to-one links between two point sets, each no longer than ``d_max``.

    Parameters
    ----------
    before, after : ndarray of float, shape (M, 2) and (N, 2)
        Positions, pixels.
    d_max : float or None
        Longest link, pixels; None allows any length.

    Returns
    -------
    ndarray of int, ndarray of int
        Indices into ``before`` and ``after`` of the links, in order of ``before``.
    """
    if before.shape[0] == 0 or after.shape[0] == 0:
        return np.empty(0, np.int64), np.empty(0, np.int64)
    distance = np.hypot(before[:, None, 0] - after[None, :, 0], before[:, None, 1] - after[None, :, 1])
    if d_max is None:
        # Imported when used: scipy.optimize is a seventh of run's imports, and run needs none of it.
        from scipy.optimize import linear_sum_assignment

        rows, columns = linear_sum_assignment(distance)
        return rows.astype(np.int64), columns.astype(np.int64)
    # Within d_max, leaving both ends of a link unmatched (d_max each) always costs more than
    # the link, so the optimum links as many points as it can, then the shortest total.
    head, target = pairs_within(before, np.full(before.shape[0], float(d_max)), after)
    weight = np.hypot(*(after[target] - before[head]).T)
    chosen = solve_split(before.shape[0], after.shape[0], head, target, weight, float(d_max))
    rows = np.flatnonzero(chosen != UNASSIGNED)
    return rows, chosen[rows]


@order_independent
def nearest_neighbour(
    frames: Sequence[np.ndarray],
    d_max: float | None = None,
    first_frame: int = 0,
) -> Tracks:
    """Track by optimal nearest-neighbour assignment between consecutive frames.

    Parameters
    ----------
    frames : sequence of ndarray, each (M_k, 2)
        Measurement positions per frame (x, y), pixels.
    d_max : float or None
        Largest speed, pixels/frame; None links every point it can.
    first_frame : int
        0-based frame index of ``frames[0]``.

    Returns
    -------
    Tracks
        One track per chain of links; unlinked points are one-point tracks.
    """
    frames = point_frames(frames)
    d_max = check_limit("d_max", d_max)
    links = []
    for k in range(len(frames) - 1):
        rows, columns = link_nearest(frames[k], frames[k + 1], d_max)
        links.append(np.column_stack((np.full(rows.size, k), rows, np.full(rows.size, k + 1), columns)))
    return tracks_from_links(frames, np.concatenate(links) if links else np.empty((0, 4), np.int64), first_frame)


__all__ = ["nearest_neighbour", "link_nearest"]
