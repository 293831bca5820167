"""One frame's optimal assignment of track heads to measurements, with slaves and false tracks.

The paper squares the problem into an augmented (m + M) x (M + m) matrix: heads and false
tracks against measurements and slaves. Any head may take a slave and any measurement may go to
a false track at weight phi_max, so heads and measurements that share no gated pair never
influence each other. Solving each connected component of the gated graph on its own therefore
gives the same optimum as the whole matrix, in time that grows with the component sizes rather
than with the square of the frame.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

UNASSIGNED = -1


def augmented_matrix(
    n_heads: int,
    n_measurements: int,
    head: np.ndarray,
    measurement: np.ndarray,
    weight: np.ndarray,
    unmatched_weight: float,
    corner_weight: float,
) -> np.ndarray:
    """The paper's square matrix: heads then false tracks (rows), measurements then slaves.

    Parameters
    ----------
    n_heads, n_measurements : int
        m track heads and M measurements of the next frame.
    head, measurement, weight : ndarray, shape (P,)
        The allowed pairs and their combined-model weights; every other head-measurement
        entry is ``inf`` (pruned).
    unmatched_weight : float
        Weight of head-slave and false-track-measurement entries (phi_max under CM1).
    corner_weight : float
        Weight of false-track-slave entries (0 in the reference code).

    Returns
    -------
    ndarray of float, shape (m + M, M + m)
    """
    size = n_heads + n_measurements
    matrix = np.empty((size, size))
    matrix[:n_heads, :n_measurements] = np.inf
    matrix[head, measurement] = weight
    matrix[:n_heads, n_measurements:] = unmatched_weight
    matrix[n_heads:, :n_measurements] = unmatched_weight
    matrix[n_heads:, n_measurements:] = corner_weight
    return matrix


def solve_dense(
    n_heads: int,
    n_measurements: int,
    head: np.ndarray,
    measurement: np.ndarray,
    weight: np.ndarray,
    unmatched_weight: float,
    corner_weight: float = 0.0,
) -> np.ndarray:
    """Solve the whole augmented matrix at once (the paper's formulation).

    Returns
    -------
    ndarray of int, shape (m,)
        For each head, the index of its measurement, or ``UNASSIGNED`` (-1) for a slave.
    """
    matrix = augmented_matrix(n_heads, n_measurements, head, measurement, weight, unmatched_weight, corner_weight)
    rows, columns = linear_sum_assignment(matrix)
    result = np.full(n_heads, UNASSIGNED, dtype=np.int64)
    is_match = (rows < n_heads) & (columns < n_measurements)
    result[rows[is_match]] = columns[is_match]
    return result


def solve_split(
    n_heads: int,
    n_measurements: int,
    head: np.ndarray,
    measurement: np.ndarray,
    weight: np.ndarray,
    unmatched_weight: float,
    corner_weight: float = 0.0,
) -> np.ndarray:
    """Solve each connected component of the pair graph separately; same optimum as dense.

    Components made of one head and one measurement are decided without a solver: their pair
    is taken whenever it is cheaper than leaving both unmatched.

    Returns
    -------
    ndarray of int, shape (m,)
        For each head, the index of its measurement, or ``UNASSIGNED`` (-1) for a slave.
    """
    result = np.full(n_heads, UNASSIGNED, dtype=np.int64)
    if head.size == 0:
        return result
    graph = coo_matrix(
        (np.ones(head.size), (head, n_heads + measurement)), shape=(n_heads + n_measurements,) * 2
    )
    _, label = connected_components(graph, directed=False)
    pair_label = label[head]
    order = np.argsort(pair_label, kind="stable")
    boundaries = np.flatnonzero(np.diff(pair_label[order])) + 1
    starts = np.concatenate(([0], boundaries))
    ends = np.concatenate((boundaries, [order.size]))

    single = (ends - starts) == 1
    lone_pairs = order[starts[single]]
    # A lone pair against one slave and one false track: matching costs w (+ corner), leaving
    # both costs 2 * unmatched; ties go to the match, as the solver's would.
    take = weight[lone_pairs] + corner_weight <= 2 * unmatched_weight
    result[head[lone_pairs[take]]] = measurement[lone_pairs[take]]

    for start, end in zip(starts[~single], ends[~single]):
        pairs = order[start:end]
        heads, local_head = np.unique(head[pairs], return_inverse=True)
        measurements, local_measurement = np.unique(measurement[pairs], return_inverse=True)
        local = solve_dense(
            heads.size,
            measurements.size,
            local_head,
            local_measurement,
            weight[pairs],
            unmatched_weight,
            corner_weight,
        )
        matched = local != UNASSIGNED
        result[heads[matched]] = measurements[local[matched]]
    return result
