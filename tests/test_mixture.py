"""Motion states per track (tracking/mixture.py): the moments each head keeps, the states fitted
to a scene, each head's chances, the link cost, and a mixed scene tracked with them."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from seedtrack.data.mixed_motion import MixedSpec, generate_mixed
from seedtrack.data.unseen import UnseenSpec, generate_unseen
from seedtrack.tracking.goa import GOAConfig, HeadState
from seedtrack.tracking.linking import link_goa
from seedtrack.tracking.metrics import score_tracks
from seedtrack.tracking.mixture import MEMORY, MixtureModel, add_chain_moments, fit_states, state_chances
from seedtrack.tracking.motion import Candidates, IndividualModel
from seedtrack.tracking.persistence import Chains, MotionStatistics, PersistentModel, fit_chains

SMOOTH = MotionStatistics(1.0, 0.2, 0.0, (0.0, 0.0), 3.0, 100)
WALK = MotionStatistics(0.0, 2.0, 0.0, (0.0, 0.0), 3.0, 100)


def _history(before: np.ndarray, after: np.ndarray) -> np.ndarray:
    moments = np.zeros((1, 5))
    for b, a in zip(before, after):
        add_chain_moments(moments, np.array([0]), b[None], a[None], np.array([True]))
    return moments


def test_moments_fade_and_skip_pairs_that_are_not_chains():
    moments = np.zeros((3, 5))
    before = np.array([[1.0, 0.0], [np.nan, np.nan], [2.0, 0.0]])
    after = np.array([[0.0, 2.0], [1.0, 1.0], [2.0, 0.0]])
    add_chain_moments(moments, np.arange(3), before, after, np.array([True, True, False]))
    assert moments[0].tolist() == [1.0, 1.0, 0.0, 2.0, 4.0]
    assert not moments[1:].any()
    add_chain_moments(moments, np.array([0]), np.array([[0.0, 2.0]]), np.array([[0.0, 2.0]]), np.array([True]))
    assert moments[0] == pytest.approx([1.0 + MEMORY, MEMORY + 4.0, 4.0, 2.0 * MEMORY, 4.0 * MEMORY + 4.0])


def _chains(paths: np.ndarray) -> Chains:
    """The three-frame chains of velocity sequences (tracks x frames x 2), track after track."""
    return Chains(paths[:, :-1].reshape(-1, 2), paths[:, 1:].reshape(-1, 2), np.zeros(2), float(np.std(paths)))


def _smooth(rng, n: int) -> np.ndarray:
    return rng.normal(0.0, 3.0, (n, 1, 2)) + rng.normal(0.0, 0.2, (n, 8, 2))


def test_one_kind_of_motion_is_one_state_the_scene_fit():
    chains = _chains(_smooth(np.random.default_rng(3), 300))
    scene = fit_chains(chains)
    assert fit_states(chains, scene) == ((scene,), (1.0,))


def test_smooth_movers_walkers_and_reversers_are_three_states():
    rng = np.random.default_rng(4)
    reversing = rng.normal(0.0, 3.0, (100, 1, 2)) * (-1.0) ** np.arange(8)[None, :, None] + rng.normal(0.0, 0.2, (100, 8, 2))
    chains = _chains(np.concatenate((_smooth(rng, 100), rng.normal(0.0, 2.0, (100, 8, 2)), reversing)))
    states, shares = fit_states(chains, fit_chains(chains))
    assert sorted(round(s.persistence, 1) for s in states) == [-1.0, 0.0, 1.0]
    assert shares == pytest.approx([1 / 3] * 3, abs=0.03)


def test_states_that_come_and_go_within_tracks_are_one():
    # Smooth movers whose velocity is redrawn now and then (run and tumble): two kinds of
    # velocity change, but every track has both.
    rng = np.random.default_rng(6)
    runs = np.cumsum(rng.random((300, 8)) < 0.2, axis=1)
    paths = rng.normal(0.0, 3.0, (300, 9, 2))[np.arange(300)[:, None], runs] + rng.normal(0.0, 0.2, (300, 8, 2))
    chains = _chains(paths)
    assert len(fit_states(chains, fit_chains(chains))[0]) == 1


def test_states_of_a_few_links_in_a_row_are_one():
    # Smooth movers each with one point off its path, as a wrong link there and back puts it:
    # three velocity changes in a row. A link on they look like a state of their own (kappa at
    # one link on picked three states), three links on they are gone.
    rng = np.random.default_rng(0)
    positions = np.cumsum(rng.normal(0.0, 3.0, (300, 1, 2)) + rng.normal(0.0, 0.2, (300, 13, 2)), axis=1)
    positions[np.arange(300), rng.integers(2, 11, 300)] += rng.normal(0.0, 2.0, (300, 2))
    chains = _chains(np.diff(positions, axis=1))
    assert len(fit_states(chains, fit_chains(chains))[0]) == 1


def test_states_of_one_persistence_are_one():
    # Smooth movers, half of them with ten times the noise, each keeping its own: two states
    # that differ in noise (their fitted persistences 1.00 and 0.69, noise diluting the second),
    # as wrong links that chain make of one kind of motion.
    rng = np.random.default_rng(7)
    paths = np.concatenate((_smooth(rng, 150), rng.normal(0.0, 3.0, (150, 1, 2)) + rng.normal(0.0, 2.0, (150, 8, 2))))
    chains = _chains(paths)
    assert len(fit_states(chains, fit_chains(chains))[0]) == 1


def test_a_state_as_wide_as_the_spacing_is_no_state():
    rng = np.random.default_rng(4)
    paths = np.concatenate((_smooth(rng, 100), rng.normal(0.0, 2.0, (100, 8, 2))))
    sparse = replace(_chains(paths), density=1.0 / 40.0**2)
    assert len(fit_states(sparse, fit_chains(sparse))[0]) == 2
    crowded = replace(sparse, density=1.0 / 4.0**2)
    assert len(fit_states(crowded, fit_chains(crowded))[0]) == 1


def test_a_head_is_judged_by_its_own_history():
    steady = np.tile([[3.0, 0.0]], (6, 1))
    assert state_chances(_history(steady, steady), (SMOOTH, WALK), (0.5, 0.5))[0, 0] > 0.99
    rng = np.random.default_rng(5)
    wander = rng.normal(0.0, 2.0, (7, 2))
    assert state_chances(_history(wander[:-1], wander[1:]), (SMOOTH, WALK), (0.5, 0.5))[0, 1] > 0.99


def test_one_step_a_sigma_off_does_not_flip_a_smooth_head():
    steady = np.tile([[3.0, 0.0]], (6, 1))
    before = np.vstack((steady, [[3.0, 0.0]]))
    after = np.vstack((steady, [[3.2, 0.2]]))
    assert state_chances(_history(before, after), (SMOOTH, WALK), (0.5, 0.5))[0, 0] > 0.99


def test_a_head_with_no_history_takes_the_scene_shares():
    assert state_chances(np.zeros((2, 5)), (SMOOTH, WALK), (0.2, 0.8)) == pytest.approx(np.tile([0.2, 0.8], (2, 1)))


def _pairs(history: np.ndarray) -> Candidates:
    velocity = np.array([[3.0, 0.0], [3.0, 1.0], [0.0, 3.0], [-1.0, 2.0]])
    n = velocity.shape[0]
    return Candidates(np.zeros(n, np.int64), np.arange(n), velocity, np.ones(n, np.int64), np.tile([[3.0, 0.0]], (n, 1)), history=np.tile(history, (n, 1)))


def test_a_smooth_head_pays_the_smooth_state_and_a_walker_the_walk():
    model = MixtureModel(WALK, gate=9.0, states=(SMOOTH, WALK), shares=(0.5, 0.5))
    steady = np.tile([[3.0, 0.0]], (6, 1))
    smooth_cost = model.cost(_pairs(_history(steady, steady)[0]), 0.1, 10.0)
    # Near its prediction what the smooth state charges; far from it, a turn the walker state
    # could make, at the odds that this head is a walker after all.
    assert smooth_cost[:2] == pytest.approx(PersistentModel(SMOOTH, gate=9.0).cost(_pairs(np.zeros(5)), 0.1, 10.0)[:2], rel=1e-6)
    assert (smooth_cost[2:] > PersistentModel(WALK, gate=9.0).cost(_pairs(np.zeros(5)), 0.1, 10.0)[2:] + 0.05).all()
    wander = np.random.default_rng(5).normal(0.0, 2.0, (7, 2))
    walker_cost = model.cost(_pairs(_history(wander[:-1], wander[1:])[0]), 0.1, 10.0)
    assert walker_cost == pytest.approx(PersistentModel(WALK, gate=9.0).cost(_pairs(np.zeros(5)), 0.1, 10.0), rel=1e-3)


def test_one_state_is_the_scene_wide_model_and_the_gate_covers_every_state():
    pairs = _pairs(np.array([2.0, 18.0, 18.0, 0.0, 18.0]))
    alone = MixtureModel(SMOOTH, gate=9.0)
    assert alone.cost(pairs, 0.1, 10.0).tolist() == PersistentModel(SMOOTH, gate=9.0).cost(pairs, 0.1, 10.0).tolist()
    both = IndividualModel(name="mixture", statistics=SMOOTH, gate=9.0, states=(SMOOTH, WALK), shares=(0.5, 0.5))
    speed, known = np.array([3.0]), np.array([True])
    assert both.gate_radius(speed, known, 0.1) >= PersistentModel(WALK, gate=9.0).gate_radius(speed, known, 0.1)


def test_mixture_model_refuses_a_drift_and_unpaired_shares():
    with pytest.raises(ValueError, match="drift"):
        MixtureModel(MotionStatistics(1.0, 0.2, 0.0, (1.0, 0.0), 3.0, 100))
    with pytest.raises(ValueError, match="share"):
        MixtureModel(SMOOTH, states=(SMOOTH, WALK), shares=(1.0,))
    with pytest.raises(ValueError, match="motion_states"):
        GOAConfig(motion_states="object")


def test_smooth_movers_among_walkers_are_tracked_per_track_by_default():
    # A tuning seed of bench_mixed.py's scenes, smaller: half smooth at 6 px/frame, half random
    # walkers whose steps are as long; one scene-wide persistence fits neither.
    frames, truth = generate_mixed(MixedSpec(points=60, shares=(0.5, 0.5, 0.0), speed=6.0, frames=20, random_seed=1))
    scene = score_tracks(link_goa(frames, config=GOAConfig(motion_states="scene"))[0], truth, 0.5)
    tracks, fit = link_goa(frames)
    per_track = score_tracks(tracks, truth, 0.5)
    assert "motion states per track" in fit.measured
    assert per_track.link_error < scene.link_error
    assert per_track.correct_tracks > scene.correct_tracks


def test_heads_keep_the_moments_of_consecutive_links_only():
    frames = [np.array([[2.0 * k, 0.0]]) for k in range(6)]
    # Held in frames 0-2, a slave in 3, held again in 4 and 5.
    state = HeadState.from_history(frames, np.array([[0, 0, 0, -1, 0, 0]]), 0, 5)
    # Frames 0-1-2 make one chain; 2-(3)-4 spans a gap and 2-4-5 follows one: neither counts.
    assert state.moments[0].tolist() == [1.0, 4.0, 4.0, 0.0, 4.0]


SWARM = UnseenSpec(kind="swarm", points=150, speed=4.0, size=80.0, frames=20, random_seed=1)


@pytest.mark.parametrize("spec", [SWARM, UnseenSpec(kind="tumble", points=60, frames=20, random_seed=2)], ids=["swarm", "tumble"])
def test_one_kind_of_motion_is_tracked_scene_wide_by_default(spec):
    # A crowd whose wrong links come in short runs (bench_unseen.py's swarm, tuning seed 1: the
    # states a link on turned on there and cost 0.09 strict merit), and runs with tumbles on
    # every track: states that do not last along a track leave the scene-wide model.
    frames, _ = generate_unseen(spec)
    tracks, fit = link_goa(frames)
    assert "motion states per track" not in fit.measured
    scene = link_goa(frames, config=GOAConfig(motion_states="scene"))[0]
    assert np.array_equal(tracks.point_track, scene.point_track) and np.array_equal(tracks.point_xy, scene.point_xy, equal_nan=True)
