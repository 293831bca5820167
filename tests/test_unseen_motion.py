"""Issue 29's failures on motion the defaults were not tuned on, each on a small exact scene:
whole-pixel positions, an end and a start far apart, velocity that reverses."""

import numpy as np
import pytest

from seedtrack.data.unseen import UnseenSpec, generate_unseen
from seedtrack.tracking.gap_closing import join_track_ends, split_through_held
from seedtrack.tracking.goa import GOAConfig
from seedtrack.tracking.linking import link_goa
from seedtrack.tracking.metrics import score_tracks
from seedtrack.tracking.persistence import fit_chains, fit_statistics, grid_step, measured_chains
from seedtrack.tracking.tracks import Tracks, tracks_from_assignment
from seedtrack.wording import motion_lines


def _scene(paths: np.ndarray, seed: int = 0) -> tuple[list[np.ndarray], Tracks]:
    """Frames in random order and the truth, from paths (objects, frames, 2), NaN where absent."""
    rng = np.random.default_rng(seed)
    present = ~np.isnan(paths[..., 0])
    measurement = np.full(present.shape, -1, np.int64)
    frames = []
    for k in range(paths.shape[1]):
        who = rng.permutation(np.flatnonzero(present[:, k]))
        measurement[who, k] = np.arange(who.size)
        frames.append(paths[who, k])
    return frames, Tracks.from_dense(paths, measurement)


def _owners(tracks: Tracks, truth: Tracks) -> list[set]:
    """Per result track, the true tracks whose points it holds (positions matched exactly)."""
    where = {tuple(xy): i for i, xy in zip(truth.point_track, truth.point_xy)}
    held: list[set] = [set() for _ in range(tracks.n_tracks)]
    for track, xy, measured in zip(tracks.point_track, tracks.point_xy, tracks.point_measurement >= 0):
        if measured:
            held[track].add(where[tuple(xy)])
    return held


def test_whole_pixel_walkers_give_one_track_each():
    # Slow straight walkers on whole pixels: a third of the velocity changes are exactly 0, and
    # the fitted noise fell to 0.1 px (197 tracks for 30 walkers before the grid's floor).
    rng = np.random.default_rng(2)
    start, speed, heading = rng.uniform(20, 130, (30, 2)), rng.uniform(0.2, 1.0, 30), rng.uniform(0, 2 * np.pi, 30)
    step = speed[:, None] * np.column_stack((np.cos(heading), np.sin(heading)))
    paths = np.round(start[:, None] + np.arange(30)[None, :, None] * step[:, None])
    frames, truth = _scene(paths)
    assert grid_step(np.concatenate(frames)) == 1.0
    tracks, _ = link_goa(frames)
    assert tracks.n_tracks == 30
    assert score_tracks(tracks, truth, 0.5).link_error < 0.01


def test_an_end_and_a_start_far_apart_are_not_joined():
    # 24 objects on smooth paths at 3 px/frame, each in the clip for 5 to 19 frames, none ever
    # missed: every end is an object gone. Before, 5 of 19 tracks carried one object on into
    # another that started later elsewhere.
    frames, truth = generate_unseen(UnseenSpec(kind="relay", points=8, speed=3.0, size=200.0, frames=30, random_seed=3))
    tracks, _ = link_goa(frames)
    assert all(len(held) == 1 for held in _owners(tracks, truth))
    assert tracks.n_tracks == truth.n_tracks


def test_reversing_velocity_is_measured_and_linked():
    # Points swinging about fixed sites with periods of 2.2 to 3.5 frames: the velocity reverses
    # nearly every frame (before: "random motion", persistence clipped to 0).
    rng = np.random.default_rng(1)
    n, t = 30, np.arange(30)
    site, period, amplitude = rng.uniform(0, 150, (n, 2)), rng.uniform(2.2, 3.5, n), rng.uniform(1.5, 3.0, n)
    angle, phase = rng.uniform(0, np.pi, n), rng.uniform(0, 2 * np.pi, n)
    swing = amplitude[:, None] * np.sin(2 * np.pi * t[None] / period[:, None] + phase[:, None])
    paths = site[:, None] + swing[..., None] * np.column_stack((np.cos(angle), np.sin(angle)))[:, None]
    frames, truth = _scene(paths + rng.normal(0, 0.1, paths.shape))
    tracks, fit = link_goa(frames)
    assert "random motion" not in fit.summary and "reversing motion" in fit.summary
    assert motion_lines(fit)[0].startswith("motion: reversing motion")
    assert fit_statistics(tracks).persistence < -0.3
    scores = score_tracks(tracks, truth, 0.5)
    assert scores.correct_tracks == 30


def test_unseen_kinds_draw_the_objects_asked_for():
    for kind in ("oscillate", "tumble", "side_by_side", "swarm", "whole_pixel"):
        frames, truth = generate_unseen(UnseenSpec(kind=kind, points=20, frames=10, random_seed=3))
        assert len(frames) == 10 and truth.n_tracks == 20
    frames, truth = generate_unseen(UnseenSpec(kind="relay", points=10, frames=20, random_seed=3))
    first, last = truth.spans()
    assert (first > 0).any() and (last < 19).any()


def test_the_crossing_repair_weighs_a_bounded_number_of_pairs(monkeypatch):
    # A swarm whose nearest neighbour is within a step: every track kinks near many others, and
    # pairs were weighed again one at a time without end (28 of 32 s of CPU on 3,000 points).
    from seedtrack.tracking import repair
    from seedtrack.tracking.persistence import MotionStatistics

    frames, _ = generate_unseen(UnseenSpec(kind="swarm", points=150, speed=4.0, size=80.0, frames=20, random_seed=0))
    tracks, _ = link_goa(frames, motion="random")
    calls = []
    weigh = repair._pairings
    monkeypatch.setattr(repair, "_pairings", lambda *args: calls.append(1) or weigh(*args))
    stats = MotionStatistics(0.9, 0.5, 0.2, (0.0, 0.0), 4.0, 1000)
    repair.resolve_crossings(tracks, stats)
    points = sum(f.shape[0] for f in frames)
    assert 0 < len(calls) <= repair._SWEEPS * len(frames) + repair._REWEIGHED_SHARE * points


def _filled_on_others(tracks: Tracks) -> int:
    """Filled-in positions within 0.5 px of a measured point another track holds in that frame."""
    measured = tracks.present & (tracks.measurement >= 0)
    count = 0
    for track, frame in zip(*np.nonzero(tracks.present & ~measured)):
        others = measured[:, frame].copy()
        others[track] = False
        count += int((np.hypot(*(tracks.xy[others, frame] - tracks.xy[track, frame]).T) <= 0.5).any())
    return count


def test_no_filled_point_lies_on_a_point_another_track_holds():
    # One walker whose points two tracks took in turns (as whole-pixel walkers once were): each
    # track's gaps were filled with points on the other's measured points, 8 of them here. A
    # second object missed in frame 4, with nothing where it was, keeps its filled point.
    walker = [np.array([[10.0 + 2 * k, 10.0]]) for k in range(10)]
    other = [np.array([[10.0 + 2 * k, 60.0]]) for k in range(10)]
    frames = [np.concatenate((w, o)) if k != 4 else w for k, (w, o) in enumerate(zip(walker, other))]
    turns = np.full((3, 10), -1, np.int64)
    turns[0, ::2] = turns[1, 1::2] = 0
    turns[2] = 1
    turns[2, 4] = -1
    before = tracks_from_assignment(frames, turns)
    assert _filled_on_others(before) == 8
    tracks = split_through_held(before)
    assert _filled_on_others(tracks) == 0
    assert tracks.interpolated.sum() == 1 and tracks.present.sum() == 20
    assert split_through_held(tracks) is tracks


def test_link_goa_leaves_no_filled_point_on_another_tracks_point():
    # The swarm of the held-out table (tuning seed 0): 150 points in 80 px, where before some
    # filled-in points lay on points other tracks held.
    frames, _ = generate_unseen(UnseenSpec(kind="swarm", points=150, speed=4.0, size=80.0, frames=20, random_seed=0))
    tracks, _ = link_goa(frames)
    assert tracks.interpolated.any()
    assert _filled_on_others(tracks) == 0


def test_a_join_is_not_made_through_a_point_another_track_holds():
    # A track ends at frame 4 and another starts at frame 7 on its line; a third track holds a
    # point on that line in frame 5: the object was seen there, so the two are not joined.
    line = [np.array([[10.0 + 2 * k, 10.0]]) for k in range(12)]
    frames = [np.concatenate((p, [[30.0 + k, 40.0 - 3 * k]])) for k, p in enumerate(line)]
    parts = np.full((3, 12), -1, np.int64)
    parts[0, :5] = parts[1, 7:] = 0
    parts[2] = 1
    joined = join_track_ends(frames, parts, GOAConfig(d_max=5.0), max_gap=10)
    assert joined.shape[0] == 2
    frames[5] = np.concatenate((frames[5], [[20.0, 10.0]]))
    parts[2, 5] = 2
    assert join_track_ends(frames, parts, GOAConfig(d_max=5.0), max_gap=10).shape[0] == 3


def test_the_fitted_noise_never_falls_below_the_given_localisation_error():
    # Straight walkers off any grid, with almost no noise: the fit alone finds the 0.1 px floor;
    # given a localisation error of 0.3 px per axis, a velocity change carries sqrt(6) x 0.3.
    rng = np.random.default_rng(1)
    start, step = rng.uniform(0, 200, (20, 2)), rng.uniform(-2, 2, (20, 2))
    paths = start[:, None] + np.arange(15)[None, :, None] * step[:, None] + rng.normal(0, 1e-3, (20, 15, 2))
    tracks = Tracks.from_dense(paths, np.tile(np.arange(20)[:, None], (1, 15)))
    assert fit_chains(measured_chains(tracks)).noise < 0.11
    stats = fit_chains(measured_chains(tracks, 0.3))
    assert stats.noise >= np.sqrt(6.0) * 0.3 - 1e-12
    assert min(stats.along[0], stats.across[0]) >= np.sqrt(6.0) * 0.3 - 1e-12
    frames, _ = _scene(paths)
    _, fit = link_goa(frames, config=GOAConfig(localisation_error=0.3))
    assert fit.config.individual.statistics.noise >= np.sqrt(6.0) * 0.3 - 1e-12
    with pytest.raises(ValueError, match="localisation_error"):
        GOAConfig(localisation_error=-0.1)
