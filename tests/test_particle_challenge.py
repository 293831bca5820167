"""The ISBI 2012 challenge's alpha, beta, JSC, JSC_theta and RMSE on cases worked by hand."""

import math

import numpy as np
import pytest

from seedtrack.tracking.particle_challenge import challenge_scores
from seedtrack.tracking.tracks import Tracks


def _tracks(points):
    """Tracks from (track id, frame, x, y) tuples."""
    track, frame, x, y = (np.array(column) for column in zip(*points))
    return Tracks.from_rows(track, frame, x.astype(float), y.astype(float))


TRUTH = _tracks(
    [(0, f, f, 0) for f in range(4)]  # A: 4 points along y = 0
    + [(1, f, 20 + f, 0) for f in range(3)]  # B: 3 points
)


def test_worked_case_with_a_miss_a_far_point_and_a_spurious_track():
    result = _tracks(
        # P follows A: distances 3, 4, 6 (beyond the gate: costs 5, not a match), 0, then one
        # frame (4) where A has no point: costs 5.
        [(7, 0, 0, 3), (7, 1, 1, 4), (7, 2, 2, 6), (7, 3, 3, 0), (7, 4, 4, 0)]
        # Q follows B from frame 1: B's frame 0 costs 5, then distances 0 and 1.
        + [(8, 1, 21, 0), (8, 2, 22, 1)]
        # S is spurious: 2 points far from everything.
        + [(9, 0, 50, 50), (9, 1, 51, 50)]
    )
    scores = challenge_scores(result, TRUTH, gate=5.0)
    # d(X, Y) = (3 + 4 + 5 + 0 + 5) + (5 + 0 + 1) = 23; d(X, ∅) = 5 * 7 = 35; d(Ȳ, ∅) = 5 * 2.
    assert scores.alpha == pytest.approx(1 - 23 / 35)
    assert scores.beta == pytest.approx((35 - 23) / (35 + 10))
    # TP = 3 + 2; FN = 7 - 5; FP = 9 - 5.
    assert scores.jsc == pytest.approx(5 / 11)
    # Two pairs, no true track left to the dummy, one result track unpaired.
    assert scores.jsc_theta == pytest.approx(2 / 3)
    assert scores.paired_tracks == 2
    assert scores.rmse == pytest.approx(math.sqrt((9 + 16 + 0 + 0 + 1) / 5))


def test_a_track_costlier_than_the_dummy_is_left_unpaired():
    # Near A in frame 0 only (distance 1), then far, and 6 frames where A has none:
    # d = 1 + 3 * 5 + 6 * 5 = 46 > 4 * 5, so A goes to the dummy.
    result = _tracks([(0, 0, 0, 1)] + [(0, f, 100, 100) for f in range(1, 10)])
    truth = _tracks([(0, f, f, 0) for f in range(4)])
    scores = challenge_scores(result, truth, gate=5.0)
    assert (scores.alpha, scores.beta, scores.jsc, scores.jsc_theta, scores.paired_tracks) == (0.0, 0.0, 0.0, 0.0, 0)
    assert math.isnan(scores.rmse)


def test_the_truth_scores_perfectly_and_the_gate_is_strict():
    scores = challenge_scores(TRUTH, TRUTH)
    assert (scores.alpha, scores.beta, scores.jsc, scores.jsc_theta, scores.rmse) == (1.0, 1.0, 1.0, 1.0, 0.0)
    # Every point exactly at the gate: no match, and each costs the gate, as the dummy does.
    shifted = _tracks([(0, f, f, 5) for f in range(4)] + [(1, f, 20 + f, 5) for f in range(3)])
    scores = challenge_scores(shifted, TRUTH, gate=5.0)
    assert (scores.alpha, scores.jsc, scores.paired_tracks) == (0.0, 0.0, 0)


@pytest.mark.parametrize("gate", [1e-300, 1e300, 1.7e308])
def test_any_finite_gate_gives_measures_in_range(gate):
    from seedtrack.tracking.hota import hota

    result = _tracks([(7, 0, 0, 3), (7, 1, 1, 4), (8, 1, 21, 0)])
    scores = challenge_scores(result, TRUTH, gate)
    assert all(0.0 <= value <= 1.0 for value in (scores.alpha, scores.beta, scores.jsc, scores.jsc_theta))
    assert 0.0 <= hota(result, TRUTH, gate).hota <= 1.0
