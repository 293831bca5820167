"""Choosing the motion model from the measurements: smooth, noisy or random motion."""

import re

import numpy as np
import pytest

from seedtrack.cli import main
from seedtrack.data.csvio import write_table
from seedtrack.data.dish import DishSpec, make_dish_scene
from seedtrack.data.trackfile import read_tracks
from seedtrack.data.walkers import WalkerSpec, generate_walkers
from seedtrack.data.psmg import PSMGSpec, generate_psmg
from seedtrack.tracking.goa import GOAConfig
from seedtrack.tracking.metrics import score_tracks
from seedtrack.tracking.motion import IndividualModel
from seedtrack.tracking.regime import choose_motion, fit_motion, step_sigma, track_without_drift
from seedtrack.tracking.tracks import Tracks


def walkers(count=300, sigma=1.5, drift=(0.0, 0.0), frames=20):
    return generate_walkers(WalkerSpec(walkers=count, frames=frames, sigma=sigma, drift=drift, random_seed=1))


def test_random_walkers_get_nearest_neighbour_and_a_speed_limit_from_their_steps():
    points, _ = walkers(sigma=1.5)
    choice = choose_motion(points)
    assert choice.individual_model == "im1"
    assert abs(choice.persistence) < 0.2
    # 5 sigma of 1.5 px/axis, from steps seen only where they are unambiguous.
    assert 6.8 < choice.speed_limit < 8.2 and np.hypot(*choice.drift) < 0.2
    assert choice.reason.startswith("random motion")


def test_flow_with_diffusion_is_tracked_as_noisy_not_smooth():
    points, _ = walkers(sigma=1.0, drift=(3.0, 0.0))
    choice = choose_motion(points)
    assert choice.individual_model == "im1" and choice.persistence > 0.8
    assert choice.reason.startswith("noisy motion")
    # 5 sigma of 1 px/axis about the drift of 3 px/frame.
    assert 4.4 < choice.speed_limit < 5.6 and choice.drift == pytest.approx((3.0, 0.0), abs=0.15)


@pytest.mark.parametrize("rim_speed", [5.0, 42.0])
def test_a_turning_dish_keeps_the_smooth_motion_model(rim_speed):
    scene = make_dish_scene(DishSpec(seeds=80, frames=10, rim_speed=rim_speed, random_seed=2))
    points = [scene.truth.xy[:, k] for k in range(10)]
    choice = choose_motion(points)
    assert (choice.individual_model, choice.speed_limit) == ("im2", None), choice.reason


def test_smooth_psmg_keeps_the_smooth_motion_model():
    frames, _ = generate_psmg(PSMGSpec(trajectories=100, frames=20, random_seed=4))
    choice = choose_motion(frames)
    assert (choice.individual_model, choice.speed_limit) == ("im2", None)
    assert choice.persistence > 0.9


def test_a_frame_without_points_is_measured_around():
    points, _ = walkers(sigma=1.5)
    points[10] = np.empty((0, 2))
    choice = choose_motion(points)
    assert choice.individual_model == "im1" and 6.8 < choice.speed_limit < 8.2


def test_two_or_three_random_walkers_are_not_taken_for_chance():
    # Two points are their own half turn, and nearly their own mirror image when they lie near
    # an axis: measured that way, every link of theirs looked like chance.
    rng = np.random.default_rng(7)
    start = np.array([[60.0, 136.0], [178.0, 113.0]])
    pair = list(start + np.cumsum(rng.normal(0, 2.0, (20, 2, 2)), axis=0))
    trio, _ = walkers(count=3, frames=20)
    for points in (pair, trio):
        assert choose_motion(points).individual_model == "im1"


def test_too_few_points_to_tell_keep_the_default():
    points, _ = walkers(count=5, frames=4)
    choice = choose_motion(points)
    assert choice.individual_model == "im2" and "need 30" in choice.reason


def test_motion_can_be_told_instead_of_measured():
    frames, _ = generate_psmg(PSMGSpec(trajectories=100, frames=20, random_seed=4))
    assert choose_motion(frames, "random").individual_model == "im1"
    walking, _ = walkers()
    assert choose_motion(walking, "smooth").individual_model == "im2"
    with pytest.raises(ValueError, match="motion must be one of"):
        choose_motion(walking, "brownian")


def test_fit_motion_keeps_what_the_user_set():
    walking, _ = walkers(drift=(1.0, 0.5))
    choice = choose_motion(walking)
    fitted, drift = fit_motion(GOAConfig(), choice)
    assert fitted.individual == IndividualModel("im1", power=2) and fitted.initialisation == "im1"
    # The limit is about the drift, which is taken out of the positions.
    assert fitted.d_max == choice.speed_limit and drift == choice.drift
    assert drift == pytest.approx((1.0, 0.5), abs=0.2)
    mine, kept_drift = fit_motion(GOAConfig(individual=IndividualModel("im3"), d_max=9.0), choice, keep_model=True)
    assert mine.individual.name == "im3" and mine.d_max == 9.0 and kept_drift == choice.drift
    assert fit_motion(GOAConfig(), choose_motion(walking, "smooth")) == (GOAConfig(), (0.0, 0.0))


def test_tracks_are_found_without_the_drift_and_returned_with_it():
    frames = [np.array([[10.0 + 3 * k, 5.0]]) for k in range(4)]
    seen = []

    def track(moved):
        seen.extend(moved)
        xy = np.stack([f[0] for f in moved])[None]
        return Tracks.from_dense(xy, np.zeros((1, len(moved)), np.int64))

    tracks = track_without_drift(frames, (3.0, 0.0), track)
    assert all(np.array_equal(f, [[10.0, 5.0]]) for f in seen)
    assert np.array_equal(tracks.xy[0], np.concatenate(frames))


def test_step_sigma_undoes_the_cut_at_each_steps_bound():
    rng = np.random.default_rng(0)
    lengths = np.hypot(*rng.normal(0, 2.0, (2, 20000)))
    bound = rng.uniform(1.0, 4.0, lengths.size)
    kept = lengths < bound
    # The kept steps alone are biased short; the truncated fit is not.
    assert np.sqrt(np.mean(lengths[kept] ** 2) / 2) < 1.4
    assert step_sigma(lengths[kept], bound[kept]) == pytest.approx(2.0, rel=0.05)


def _write_points(path, points):
    frame = np.concatenate([np.full(len(p), k) for k, p in enumerate(points)])
    xy = np.concatenate(points)
    write_table(path, {"frame": frame, "x": xy[:, 0], "y": xy[:, 1]})


def test_track_with_default_options_follows_random_walkers(tmp_path, capsys):
    points, truth = walkers(count=200, sigma=1.5, frames=15)
    _write_points(tmp_path / "points.csv", points)
    scores = {}
    for motion in ("auto", "smooth"):
        out = tmp_path / f"{motion}.csv"
        assert main(["track", str(tmp_path / "points.csv"), "--out", str(out), "--motion", motion]) == 0
        scores[motion] = score_tracks(read_tracks(out), truth)
    assert capsys.readouterr().out.startswith("motion: random motion")
    # The smooth-motion model links random walkers to their neighbours; measuring the motion first does not.
    assert scores["auto"].link_error < 0.02 < 0.3 < scores["smooth"].link_error


@pytest.mark.parametrize("options", [[], ["--max-speed", "9"]])
def test_track_follows_drifting_walkers_in_the_frame_of_their_drift(tmp_path, capsys, options):
    # Steps of 3 px/frame to the right plus 1 px of noise: about the drift the walkers are easy to
    # tell apart; tracked where they stand, each one's 5 sigma disc holds its neighbours' points.
    # A limit the user gives (here 3 px of drift + 6 sigma) bounds the steps about the drift too.
    points, truth = walkers(count=200, sigma=1.0, drift=(3.0, 0.0), frames=15)
    _write_points(tmp_path / "points.csv", points)
    assert main(["track", str(tmp_path / "points.csv"), "--out", str(tmp_path / "t.csv"), *options]) == 0
    drift = re.search(r"^motion: .* drift \((\S+), (\S+)\) px/frame\), speed limit", capsys.readouterr().out)
    assert drift and float(drift[1]) == pytest.approx(3.0, abs=0.2) and float(drift[2]) == pytest.approx(0.0, abs=0.2)
    scores = score_tracks(read_tracks(tmp_path / "t.csv"), truth)
    assert scores.link_error < 0.01


def test_motion_is_refused_by_trackers_that_do_not_read_it(tmp_path, capsys):
    points, _ = walkers(count=20, frames=3)
    _write_points(tmp_path / "points.csv", points)
    assert main(["track", str(tmp_path / "points.csv"), "--out", str(tmp_path / "t.csv"), "--algorithm", "nn", "--motion", "random"]) == 2
    assert "--motion only apply to --algorithm goa or goa-updown" in capsys.readouterr().err
    assert not (tmp_path / "t.csv").exists()


@pytest.mark.parametrize("scene, slaves", [("walkers", (3, 4)), ("dish", (10,))])
def test_heads_of_a_measured_random_walk_keep_about_three_slaves_and_smooth_motion_max_gap(monkeypatch, scene, slaves):
    import seedtrack.tracking.linking as linking

    if scene == "walkers":
        points, _ = generate_walkers(WalkerSpec(walkers=150, frames=12, sigma=1.5, missed=0.05, random_seed=3))
    else:
        points = make_dish_scene(DishSpec(seeds=40, frames=10, hidden_probability=0.1, random_seed=3)).visible_points()
    seen = []
    passes = linking.goa_updown_open

    def recording(frames, config, lifecycle, *args, **kwargs):
        seen.append(lifecycle.max_slaves)
        return passes(frames, config, lifecycle, *args, **kwargs)

    monkeypatch.setattr(linking, "goa_updown_open", recording)
    linking.link_goa(points)
    # The first pass (nearest neighbour or IM2) keeps max_gap; the measured passes are the ones fitted.
    assert seen[0] is None and len(seen) == 3 and all(kept in slaves for kept in seen[1:])
