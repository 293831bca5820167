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
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import min_weight_full_bipartite_matching

UNASSIGNED = -1
# Pairs per sparse solve, in whole components. scipy's LAPJVsp clears arrays as long as its
# matrix for every row it augments, so one solve of all components grew with the square of the
# frame: 100,000 random walkers a frame spent 86 s of linking's 131 s there.
_BATCH_PAIRS = 2000


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
    # scipy.optimize loads all of its solvers (a seventh of run's imports):
    # paid here, by the dense solver, not by every tracker's import.
    from scipy.optimize import linear_sum_assignment

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
    """Solve the connected components of the pair graph apart; same optimum as dense.

    Components with a single head or a single measurement are decided without a solver: their
    cheapest pair is taken whenever it is cheaper than leaving both unmatched. The others go
    to sparse solves (:func:`solve_sparse`) of whole components, a few thousand pairs each, so
    that time grows with the number of pairs rather than with the square of the frame or of the
    largest component.

    Returns
    -------
    ndarray of int, shape (m,)
        For each head, the index of its measurement, or ``UNASSIGNED`` (-1) for a slave.
    """
    result = np.full(n_heads, UNASSIGNED, dtype=np.int64)
    if head.size == 0:
        return result
    pair_label, single_of = _components(n_heads, n_measurements, head, measurement)

    # Pairs grouped by component, cheapest first within each.
    order = np.lexsort((weight, pair_label))
    label = pair_label[order]
    boundaries = np.flatnonzero(label[1:] != label[:-1]) + 1
    starts = np.concatenate(([0], boundaries))

    # A component with one head (or one measurement) makes at most one match, its cheapest
    # pair: matching costs w (+ corner, the rest unmatched as they would be anyway), leaving it
    # costs 2 * unmatched; ties go to the match, as the solver's would.
    single = single_of[label[starts]]
    cheapest = order[starts[single]]
    take = weight[cheapest] + corner_weight <= 2 * unmatched_weight
    result[head[cheapest[take]]] = measurement[cheapest[take]]
    if single.all():
        return result

    # The other components in sparse solves of whole components, about _BATCH_PAIRS pairs each:
    # components do not interact, and each is solved as it would be alone.
    pairs = order[~single_of[label]]
    # The one shift of a solve of them all, so that every batch rounds its weights alike.
    shift = 1.0 - min(float(weight[pairs].min()), unmatched_weight, corner_weight)
    if pairs.size <= _BATCH_PAIRS:
        # One batch: its heads and measurements found by marking them, cheaper than sorting.
        _solve_batch(result, head, measurement, weight, pairs, unmatched_weight, corner_weight, shift, n_measurements)
        return result
    sizes = np.diff(np.append(starts, order.size))[~single]
    opens = np.concatenate(([0], np.cumsum(sizes)[:-1]))
    batch = np.flatnonzero(np.diff(opens // _BATCH_PAIRS, prepend=-1))
    bounds = np.append(opens[batch], pairs.size)
    for low, high in zip(bounds[:-1], bounds[1:]):
        _solve_batch(result, head, measurement, weight, pairs[low:high], unmatched_weight, corner_weight, shift)
    return result


def _solve_batch(
    result: np.ndarray,
    head: np.ndarray,
    measurement: np.ndarray,
    weight: np.ndarray,
    part: np.ndarray,
    unmatched_weight: float,
    corner_weight: float,
    shift: float,
    n_measurements: int | None = None,
) -> None:
    """One sparse solve of the whole components whose pairs are ``part``, into ``result``.

    With ``n_measurements`` the heads and measurements are found by marking them in arrays of
    the frame's size (a few operations on small frames); without, by sorting (a batch of a large
    frame)."""
    if n_measurements is None:
        heads, local_head = np.unique(head[part], return_inverse=True)
        measurements, local_measurement = np.unique(measurement[part], return_inverse=True)
    else:
        heads, local_head = _marked(head[part], result.size)
        measurements, local_measurement = _marked(measurement[part], n_measurements)
    joint = solve_sparse(heads.size, measurements.size, local_head, local_measurement, weight[part], unmatched_weight, corner_weight, shift)
    held = joint != UNASSIGNED
    result[heads[held]] = measurements[joint[held]]


def _marked(index: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray]:
    """``np.unique(index, return_inverse=True)`` for indices below ``size``."""
    mark = np.zeros(size, bool)
    mark[index] = True
    return np.flatnonzero(mark), (np.cumsum(mark) - 1)[index]


def _components(n_heads: int, n_measurements: int, head: np.ndarray, measurement: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The connected component of each pair (a label), and per label whether that component
    has a single head or a single measurement."""
    # Where no head has two pairs, each component is one measurement and the heads that share
    # it (and likewise the other way round): the graph need not be built, which on sparse
    # scenes was most of each frame's time.
    if np.bincount(head, minlength=n_heads).max() == 1:
        return measurement, np.ones(n_measurements, bool)
    if np.bincount(measurement, minlength=n_measurements).max() == 1:
        return head, np.ones(n_heads, bool)
    # Each node takes the least label of its neighbours, then its label's label, until no pair
    # joins two labels: about the log of the longest chain in rounds of a few array operations,
    # where building a sparse graph for scipy's connected_components took a fifth of tracking's
    # time (a 300-frame dish of 80 seeds).
    n_nodes = n_heads + n_measurements
    label = np.arange(n_nodes)
    ends = np.concatenate((head, n_heads + measurement))
    while True:
        least = np.minimum(label[head], label[n_heads + measurement])
        joined = label.copy()
        np.minimum.at(joined, ends, np.concatenate((least, least)))
        joined = joined[joined]
        if np.array_equal(joined, label):
            break
        label = joined
    head_count = np.bincount(label[:n_heads], minlength=n_nodes)
    measurement_count = np.bincount(label[n_heads:], minlength=n_nodes)
    return label[head], np.minimum(head_count, measurement_count) == 1


def solve_sparse(
    n_heads: int,
    n_measurements: int,
    head: np.ndarray,
    measurement: np.ndarray,
    weight: np.ndarray,
    unmatched_weight: float,
    corner_weight: float = 0.0,
    shift: float | None = None,
) -> np.ndarray:
    """The same optimum as :func:`solve_dense` from a sparse augmented matrix (LAPJVsp).

    Only the diagonals of the slave and false-track blocks are kept, and false-track/slave
    entries only where the transposed head-measurement pair is allowed: any set of matched
    pairs then still completes to a full assignment of the same cost (the matched heads'
    slaves go to the matched measurements' false tracks), so nothing optimal is lost.
    Each (head, measurement) pair is given at most once. ``shift`` is added to every weight
    (default: what makes the least 1; the solver needs non-zero weights).

    Returns
    -------
    ndarray of int, shape (m,)
        For each head, the index of its measurement, or ``UNASSIGNED`` (-1) for a slave.
    """
    heads, measurements = np.arange(n_heads), np.arange(n_measurements)
    rows = np.concatenate((head, heads, n_heads + measurements, n_heads + measurement))
    columns = np.concatenate((measurement, n_measurements + heads, measurements, n_measurements + head))
    values = np.concatenate(
        (weight, np.full(n_heads + n_measurements, unmatched_weight), np.full(head.size, corner_weight))
    )
    # Every full assignment has m + M entries, so a common shift keeps the optimum.
    values = values + (1.0 - values.min() if shift is None else shift)
    size = n_heads + n_measurements
    # Built in CSR's canonical order (no pair twice) with the solver's 32-bit indices, the matrix
    # scipy would make of (row, column) triplets, without the conversion's checks and copies.
    order = np.lexsort((columns, rows))
    start = np.concatenate(([0], np.cumsum(np.bincount(rows, minlength=size)))).astype(np.int32)
    matrix = csr_matrix((values[order], columns[order].astype(np.int32), start), shape=(size, size))
    _, column = min_weight_full_bipartite_matching(matrix)
    column = column[:n_heads]
    return np.where(column < n_measurements, column, UNASSIGNED).astype(np.int64)
