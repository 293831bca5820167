import numpy as np
import pytest

from seedtrack.tracking import assignment
from seedtrack.tracking.assignment import UNASSIGNED, solve_dense, solve_sparse, solve_split


def random_problem(rng, n_heads, n_measurements, density):
    mask = rng.random((n_heads, n_measurements)) < density
    head, measurement = np.nonzero(mask)
    weight = rng.random(head.size) * 0.1
    return head, measurement, weight


@pytest.mark.parametrize("seed", range(20))
@pytest.mark.parametrize("corner", [0.0, 0.1])
def test_split_agrees_with_dense(seed, corner):
    rng = np.random.default_rng(seed)
    n_heads, n_measurements = rng.integers(1, 40, size=2)
    head, measurement, weight = random_problem(rng, n_heads, n_measurements, density=0.08)
    dense = solve_dense(n_heads, n_measurements, head, measurement, weight, 0.1, corner)
    split = solve_split(n_heads, n_measurements, head, measurement, weight, 0.1, corner)
    np.testing.assert_array_equal(dense, split)


@pytest.mark.parametrize("seed", range(10))
@pytest.mark.parametrize("one_pair_per", ["head", "measurement"])
def test_split_agrees_with_dense_when_components_are_stars(seed, one_pair_per):
    # Each head (or measurement) in at most one pair: the components are found without a graph.
    rng = np.random.default_rng(seed)
    n_heads, n_measurements = rng.integers(1, 40, size=2)
    many, few = (n_heads, n_measurements) if one_pair_per == "head" else (n_measurements, n_heads)
    side = np.flatnonzero(rng.random(many) < 0.7)
    other = rng.integers(0, few, side.size)
    head, measurement = (side, other) if one_pair_per == "head" else (other, side)
    weight = rng.random(head.size) * 0.3  # some dearer than leaving both unmatched
    for corner in (0.0, 0.1):
        dense = solve_dense(n_heads, n_measurements, head, measurement, weight, 0.1, corner)
        split = solve_split(n_heads, n_measurements, head, measurement, weight, 0.1, corner)
        np.testing.assert_array_equal(dense, split)


def test_measurement_used_once_and_slaves_for_the_rest():
    # Two heads want the same measurement; the cheaper one wins, the other takes a slave.
    result = solve_split(2, 1, np.array([0, 1]), np.array([0, 0]), np.array([0.01, 0.05]), 0.1)
    np.testing.assert_array_equal(result, [0, UNASSIGNED])


def test_zero_corner_prefers_more_links_than_phi_corner():
    # Head 0 likes measurement 0 best; taking measurement 1 instead lets head 1 link too.
    head = np.array([0, 0, 1])
    measurement = np.array([0, 1, 0])
    weight = np.array([0.01, 0.09, 0.08])
    np.testing.assert_array_equal(solve_dense(2, 2, head, measurement, weight, 0.1, 0.0), [1, 0])
    np.testing.assert_array_equal(solve_dense(2, 2, head, measurement, weight, 0.1, 0.1), [0, UNASSIGNED])


def test_no_pairs_gives_all_slaves():
    empty = np.empty(0, np.int64)
    result = solve_split(3, 2, empty, empty, np.empty(0), 0.1)
    np.testing.assert_array_equal(result, [UNASSIGNED] * 3)


@pytest.mark.parametrize("seed", range(10))
@pytest.mark.parametrize("corner", [0.0, 0.1])
def test_sparse_agrees_with_dense_on_one_crowded_component(seed, corner):
    # Dense pair graphs and weights below zero (CM2 can give them): the reduced slave and
    # false-track blocks must still reach the full matrix's optimum.
    rng = np.random.default_rng(seed)
    n_heads, n_measurements = rng.integers(2, 30, size=2)
    head, measurement, weight = random_problem(rng, n_heads, n_measurements, density=0.6)
    weight = weight - 0.05
    dense = solve_dense(n_heads, n_measurements, head, measurement, weight, 0.1, corner)
    sparse = solve_sparse(n_heads, n_measurements, head, measurement, weight, 0.1, corner)
    np.testing.assert_array_equal(dense, sparse)


@pytest.mark.parametrize("corner", [0.0, 0.1])
def test_split_solves_many_components_in_batches_as_in_one_sparse_solve(corner, monkeypatch):
    # Thousands of crowded components, more pairs than one batch holds: the batches must give
    # exactly the one solve's assignment, ties included (weights on a coarse grid tie often).
    rng = np.random.default_rng(5)
    heads, measurements, weights = [], [], []
    n_heads = n_measurements = 0
    for _ in range(1500):
        h, m = rng.integers(2, 5, size=2)
        head, measurement, _ = random_problem(rng, h, m, density=0.7)
        heads.append(head + n_heads)
        measurements.append(measurement + n_measurements)
        weights.append(rng.integers(0, 8, head.size) * 0.0125)
        n_heads, n_measurements = n_heads + h, n_measurements + m
    head, measurement, weight = np.concatenate(heads), np.concatenate(measurements), np.concatenate(weights)
    assert head.size > 2 * assignment._BATCH_PAIRS
    split = solve_split(n_heads, n_measurements, head, measurement, weight, 0.1, corner)
    monkeypatch.setattr(assignment, "_BATCH_PAIRS", head.size)
    whole = solve_split(n_heads, n_measurements, head, measurement, weight, 0.1, corner)
    np.testing.assert_array_equal(split, whole)
