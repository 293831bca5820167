"""The paper's other trackers (NN, SS, RS, IPAN) on small exact scenes with the tracks written out."""

import numpy as np
import pytest

from seedtrack.tracking.ipan import IPANConfig, bridge_cost, ipan
from seedtrack.tracking.nn import link_nearest, nearest_neighbour
from seedtrack.tracking.rs import greedy_conditioned_assignment, rangarajan_shah
from seedtrack.tracking.ss import sethi_jain
from seedtrack.tracking.trackers import TRACKERS as REGISTRY, run_tracker
from seedtrack.tracking.tracks import tracks_from_links

T = np.arange(8.0)
# Two points crossing between frames 3 and 4; at frames 3 and 4 each is nearer the other's
# next position than its own, so nearest neighbour swaps them.
P1 = np.column_stack((10 + 6 * T, 20 + 1.0 * T))
P2 = np.column_stack((52 - 6 * T, 21 + 0.8 * T))
# A point moving 5 px/frame along x.
LINE = np.column_stack((5 + 5 * T, 10 + 0 * T))

TRACKERS = {
    "nn": lambda frames: nearest_neighbour(frames, d_max=10),
    "ss": lambda frames: sethi_jain(frames, phi_max=0.1, d_max=10),
    "rs": lambda frames: rangarajan_shah(frames, d_max=10),
    "ipan": lambda frames: ipan(frames, IPANConfig(v_max=10)),
}


def paths(tracks):
    """Each track as (first frame, positions of its frames), sorted; NaN-free."""
    out = []
    for row in tracks.xy:
        frames = np.flatnonzero(~np.isnan(row[:, 0]))
        out.append((int(frames[0]), row[frames].round(9).tolist()))
    return sorted(out)


def expected(*segments):
    """Paths from (first frame, array of positions) pairs."""
    return sorted((start, np.asarray(points, float).round(9).tolist()) for start, points in segments)


def frames_of(*paths_, missing=()):
    """Frames holding each path's point, except the (path, frame) pairs in ``missing``."""
    n = max(len(p) for p in paths_)
    return [
        np.array([p[k] for i, p in enumerate(paths_) if k < len(p) and (i, k) not in missing]).reshape(-1, 2)
        for k in range(n)
    ]


def test_crossing_points_swap_under_nearest_neighbour():
    tracks = TRACKERS["nn"](frames_of(P1, P2))
    swapped_1 = np.vstack((P1[:4], P2[4:]))
    swapped_2 = np.vstack((P2[:4], P1[4:]))
    assert paths(tracks) == expected((0, swapped_1), (0, swapped_2))


@pytest.mark.parametrize("name", ["ss", "rs", "ipan"])
def test_crossing_points_keep_their_identity_with_smooth_motion(name):
    tracks = TRACKERS[name](frames_of(P1, P2))
    assert paths(tracks) == expected((0, P1), (0, P2))


@pytest.mark.parametrize("name", ["nn", "ss"])
def test_missed_detection_splits_the_track_without_gap_closing(name):
    tracks = TRACKERS[name](frames_of(LINE, missing={(0, 3)}))
    assert paths(tracks) == expected((0, LINE[:3]), (4, LINE[4:]))


def test_missed_detection_is_extrapolated_by_rs():
    tracks = TRACKERS["rs"](frames_of(LINE, missing={(0, 3)}))
    assert paths(tracks) == expected((0, LINE))
    assert tracks.interpolated[0].tolist() == [k == 3 for k in range(8)]


@pytest.mark.parametrize("gap", [1, 2])
def test_ipan_post_processing_bridges_gaps_of_one_and_two_frames(gap):
    missing = {(0, 3 + g) for g in range(gap)}
    tracks = TRACKERS["ipan"](frames_of(LINE, missing=missing))
    assert paths(tracks) == expected((0, LINE))
    assert tracks.interpolated[0].tolist() == [(0, k) in missing for k in range(8)]


def test_ipan_leaves_a_three_frame_gap_open():
    line = np.column_stack((5 + 5 * np.arange(10.0), np.full(10, 10.0)))
    missing = {(0, 3), (0, 4), (0, 5)}
    tracks = TRACKERS["ipan"](frames_of(line, missing=missing))
    assert paths(tracks) == expected((0, line[:3]), (6, line[6:]))


def test_ipan_without_post_processing_leaves_the_gap():
    tracks = ipan(frames_of(LINE, missing={(0, 3)}), IPANConfig(v_max=10, max_gap=0))
    assert paths(tracks) == expected((0, LINE[:3]), (4, LINE[4:]))


FALSE = LINE[3] + [3.0, 4.0]  # 8.9 px from the point's frame-2 position, 4.5 px from its frame-4 one


def with_false_detection():
    frames = frames_of(LINE)
    frames[3] = np.vstack((FALSE, frames[3]))
    return frames


@pytest.mark.parametrize("name", ["ss", "ipan"])
def test_false_detection_becomes_a_point_of_its_own(name):
    tracks = TRACKERS[name](with_false_detection())
    assert paths(tracks) == expected((0, LINE), (3, [FALSE]))


def test_false_detection_near_the_path_steals_the_nearest_neighbour_track():
    tracks = TRACKERS["nn"](with_false_detection())
    assert paths(tracks) == expected((0, LINE[:4]), (3, np.vstack(([FALSE], LINE[4:]))))


def test_false_detection_is_ignored_by_rs():
    assert paths(TRACKERS["rs"](with_false_detection())) == expected((0, LINE))


LATE = np.column_stack((40 - 4 * T, 40 + 3 * T))


@pytest.mark.parametrize("name", ["nn", "ss", "ipan"])
def test_point_appearing_late_starts_its_own_track(name):
    missing = {(1, 0), (1, 1), (1, 2)}
    tracks = TRACKERS[name](frames_of(LINE, LATE, missing=missing))
    assert paths(tracks) == expected((0, LINE), (3, LATE[3:]))


def test_rs_tracks_only_the_points_of_the_first_frame():
    missing = {(1, 0), (1, 1), (1, 2)}
    tracks = TRACKERS["rs"](frames_of(LINE, LATE, missing=missing))
    assert paths(tracks) == expected((0, LINE))


# The paper's constructed example (its Fig. 5, coordinates lost): the two crossing points, p1
# missed in frame 3 and p2 in frame 4, right where they cross.
CROSSING_MISSES = {(0, 3), (1, 4)}


def test_constructed_example_rs_extrapolates_both_gaps_correctly():
    tracks = TRACKERS["rs"](frames_of(P1, P2, missing=CROSSING_MISSES))
    assert paths(tracks) == expected((0, P1), (0, P2))


def test_constructed_example_breaks_ss_into_four_parts_at_phi_max_005():
    tracks = sethi_jain(frames_of(P1, P2, missing=CROSSING_MISSES), phi_max=0.05, d_max=20)
    assert paths(tracks) == expected((0, P1[:3]), (0, P2[:4]), (4, P1[4:]), (5, P2[5:]))


def test_constructed_example_ipan_is_right_only_after_post_processing():
    frames = frames_of(P1, P2, missing=CROSSING_MISSES)
    # delta_max 0.3: at the default 0.6 the halt of p2 onto p1's frame-4 point (cost 0.47) passes.
    config = IPANConfig(v_max=20, delta_max=0.3)
    assert paths(ipan(frames, config)) == expected((0, P1), (0, P2))
    assert paths(ipan(frames, IPANConfig(v_max=20, delta_max=0.3, max_gap=0))) == expected(
        (0, P1[:3]), (0, P2[:4]), (4, P1[4:]), (5, P2[5:])
    )


@pytest.mark.parametrize("name", sorted(REGISTRY))
def test_registered_trackers_refuse_bad_frames_and_limits(name):
    with pytest.raises(ValueError, match="must be positive"):
        run_tracker(name, frames_of(LINE), max_speed=0.0)
    with pytest.raises(ValueError, match="frame 1 must hold"):
        run_tracker(name, [LINE[:2], np.zeros((2, 3))], max_speed=10.0)
    with pytest.raises(ValueError, match="frame 0 holds a non-finite"):
        run_tracker(name, [[[np.nan, 1.0]], LINE[1:2]], max_speed=10.0)


def test_rs_greedy_prefers_the_pair_whose_alternatives_are_poor():
    # Cheapest first would take (0, 0) and force head 1 onto its 0.9; head 1's alternative is so
    # much worse that RS gives it measurement 0 first, and head 0 loses little.
    cost = np.array([[0.10, 0.11], [0.12, 0.90]])
    assert greedy_conditioned_assignment(cost).tolist() == [1, 0]


def test_link_nearest_is_optimal_and_gated():
    before = np.array([[0.0, 0.0], [4.0, 0.0], [100.0, 0.0]])
    after = np.array([[3.0, 0.0], [7.0, 0.0], [200.0, 0.0]])
    rows, columns = link_nearest(before, after, d_max=5.0)
    # Greedy would link 1 -> 0 (1 px) and strand point 0; the optimum links both within 5 px.
    assert dict(zip(rows.tolist(), columns.tolist())) == {0: 0, 1: 1}


def test_ss_cuts_a_track_whose_turn_exceeds_phi_max():
    # A right-angle turn at frame 3 costs w1 = 0.1 > phi_max; cutting before frame 3 or before
    # frame 4 removes the triplet equally well.
    turn = np.vstack((LINE[:4], LINE[3] + np.column_stack((0 * T[:4], 5 + 5 * T[:4]))))
    tracks = sethi_jain(frames_of(turn), phi_max=0.05, d_max=10)
    assert paths(tracks) in (expected((0, turn[:3]), (3, turn[3:])), expected((0, turn[:4]), (4, turn[4:])))
    assert paths(sethi_jain(frames_of(turn), phi_max=0.2, d_max=10)) == expected((0, turn))


def test_bridge_cost_refuses_a_reversal_and_prices_a_straight_line_near_zero():
    config = IPANConfig(v_max=10)
    before, end = np.array([0.0, 0.0]), np.array([5.0, 0.0])
    # The speed grid (1 px steps) need not hit 5 px/frame exactly, so the cost is near 0.
    assert bridge_cost(before, end, np.array([15.0, 0.0]), np.array([20.0, 0.0]), 1, config) < 0.01
    assert bridge_cost(before, end, np.array([-5.0, 0.0]), np.array([-10.0, 0.0]), 1, config) == np.inf


def test_tracks_from_links_rejects_two_successors():
    frames = [np.zeros((1, 2)), np.zeros((2, 2))]
    with pytest.raises(ValueError, match="two successors"):
        tracks_from_links(frames, np.array([[0, 0, 1, 0], [0, 0, 1, 1]]))


@pytest.mark.parametrize("name", sorted(TRACKERS))
def test_empty_and_single_frames(name):
    assert TRACKERS[name]([np.empty((0, 2))] * 3).n_tracks == 0
    assert TRACKERS[name]([LINE[:1]]).n_tracks == 1
