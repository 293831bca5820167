"""PSMG data, the tracker registry, the peers and ``seedtrack experiment`` at a tiny size."""

import subprocess
import sys

import cv2
import numpy as np
import pytest

from seedtrack.cli import main
from seedtrack.experiments import EXPERIMENTS, RUNNERS, Task, ci95, run_task, runs_on, trackers_of
from seedtrack.peers import PEERS, PeerFailure, peers_available
from seedtrack.data.csvio import read_table
from seedtrack.data.psmg import PSMGSpec, generate_psmg
from seedtrack.tracking.trackers import TRACKERS, estimate_speed_limit, run_tracker


def test_psmg_is_deterministic_stays_in_view_and_matches_its_truth():
    spec = PSMGSpec(trajectories=30, frames=12, mean_speed=4, speed_sigma=0.5, speed_step_sigma=0.3,
                    angle_step_sigma=7, occlusion=0.2, random_seed=11)
    frames, truth = generate_psmg(spec)
    again, _ = generate_psmg(spec)
    assert all(np.array_equal(a, b) for a, b in zip(frames, again))
    assert truth.xy.shape == (30, 12, 2)
    assert ((truth.xy >= 0) & (truth.xy <= spec.size)).all()
    hidden = truth.measurement == -1
    assert not hidden[:, [0, 1, 2, -3, -2, -1]].any()
    assert not (hidden[:, 1:] & hidden[:, :-1]).any()
    assert 0 < hidden.mean() < 0.2
    for k, points in enumerate(frames):
        seen = ~hidden[:, k]
        np.testing.assert_array_equal(points[truth.measurement[seen, k]], truth.xy[seen, k])
        assert len(points) == seen.sum()
    speed = np.hypot(*np.diff(truth.xy, axis=1).T)
    assert speed.max() <= spec.speed_limit + 1e-9


def test_psmg_refuses_speeds_that_cannot_stay_in_view():
    with pytest.raises(ValueError, match="stay in a 20 px view"):
        generate_psmg(PSMGSpec(trajectories=5, frames=20, size=20, mean_speed=10, angle_step_sigma=1))


@pytest.mark.parametrize("name", sorted(TRACKERS))
def test_every_registered_tracker_follows_separate_straight_points(name):
    frames, truth = generate_psmg(PSMGSpec(trajectories=5, frames=8, size=200, mean_speed=3, random_seed=2))
    tracks = run_tracker(name, frames, max_speed=6.0)
    paths = {tuple(np.round(row[~np.isnan(row[:, 0])], 9).ravel()) for row in tracks.xy}
    assert paths == {tuple(np.round(row, 9).ravel()) for row in truth.xy}


def test_estimated_speed_limit_covers_the_true_speeds():
    frames, truth = generate_psmg(PSMGSpec(trajectories=20, frames=10, mean_speed=5, speed_sigma=1, random_seed=3))
    fastest = np.hypot(*np.diff(truth.xy, axis=1).T).max()
    assert fastest <= estimate_speed_limit(frames) <= 3 * fastest


needs_peers = pytest.mark.skipif(not peers_available(), reason="the peers extra (trackpy, laptrack) is not installed")


@needs_peers
@pytest.mark.parametrize("name", sorted(PEERS))
def test_peers_link_separate_points(name):
    frames, truth = generate_psmg(PSMGSpec(trajectories=4, frames=6, size=200, mean_speed=3, random_seed=5))
    tracks = PEERS[name](frames, 6.0, 0)
    assert tracks.n_tracks == 4


@needs_peers
def test_trackpy_giving_up_is_a_recorded_failure():
    rng = np.random.default_rng(0)
    frames = [rng.uniform(0, 10, size=(40, 2)) for _ in range(3)]
    with pytest.raises(PeerFailure, match="SubnetOversize"):
        PEERS["trackpy"](frames, 30.0, 0)


def test_a_run_scores_every_tracker_on_the_same_data():
    experiment = EXPERIMENTS["density"]
    rows = run_task(Task("density", 0, 0, True, trackers_of(experiment)))
    assert [r["tracker"] for r in rows] == list(trackers_of(experiment))
    assert len({r["seed"] for r in rows}) == 1
    assert all(0 <= r["track_error"] <= 1 for r in rows if not r["failed"])


@pytest.mark.parametrize("name", sorted(EXPERIMENTS))
def test_every_experiment_runs_at_a_tiny_size(name, tmp_path, capsys):
    protocol = "given" if name == "models" else "self"
    assert main(["experiment", name, "--out", str(tmp_path), "--runs", "1", "--tiny", "--protocol", protocol]) == 0
    experiment = EXPERIMENTS[name]
    cases = experiment.cases(True)
    results = read_table(tmp_path / f"{name}-{protocol}.csv", required=("run", "seed", "failed"))
    # The slow peers stop at a scene size; every other tracker runs on every case.
    assert len(results["tracker"]) == sum(runs_on(t, case.spec) for case in cases for t in trackers_of(experiment))
    assert set(results["protocol"]) == {protocol}
    summary = read_table(tmp_path / f"{name}-{protocol}-summary.csv", required=("runs", "failures"))
    assert set(summary["runs"]) == {1}
    image = cv2.imread(str(tmp_path / f"{name}-{protocol}.png"))
    assert image is not None and image.shape[1] == 960
    if name == "ipan-table":
        assert "published_ipan" in summary and "merit" in summary
    assert ("seconds" in results) == (name == "volume")
    if name != "models":
        # Every tracker comparison scores the default, the published scheme and IPAN in each case.
        for tracker in ("default", "published", "ipan"):
            rows = summary["tracker"] == tracker
            assert rows.sum() == len(cases) and not summary["failures"][rows].any(), tracker


@pytest.mark.parametrize("name", [pytest.param(n, marks=needs_peers) if n.startswith(("trackpy", "laptrack", "stonesoup")) else n for n in sorted(RUNNERS)])
def test_under_the_given_protocol_every_tracker_keeps_the_given_first_links(name):
    # Two points cross between frames 0 and 1, so nearest-neighbour first links are wrong; the
    # given ones must survive.
    frames = [np.array([[20.0, 20.0], [20.0, 28.0]])] + [np.array([[26.0 + 6 * k, 27.0], [26.0 + 6 * k, 21.0]]) for k in range(5)]
    given = np.array([[0, 0], [1, 1]])
    tracks = RUNNERS[name](frames, 14.0, given)
    owner = {}
    for track, column, measurement, xy in zip(tracks.point_track, tracks.point_column, tracks.point_measurement, tracks.point_xy):
        if column <= 1:
            index = measurement if measurement >= 0 else int(np.flatnonzero((frames[column] == xy).all(axis=1))[0])
            owner[(int(column), int(index))] = int(track)
    assert owner[(0, 0)] == owner[(1, 0)] != owner[(0, 1)] == owner[(1, 1)]


def test_ci95_is_1_96_standard_errors_and_0_without_a_spread():
    # 1 and 3: sample standard deviation sqrt(2), standard error sqrt(2) / sqrt(2) = 1.
    assert ci95([1.0, 3.0]) == pytest.approx(1.96)
    assert ci95([5.0]) == 0.0


def test_same_options_give_the_same_files(tmp_path):
    outputs = []
    for folder in ("a", "b"):
        out = tmp_path / folder
        result = subprocess.run(
            [sys.executable, "-m", "seedtrack", "experiment", "occlusion", "--out", str(out), "--runs", "2", "--jobs", "2", "--tiny"],
            capture_output=True, text=True,
        )
        assert result.returncode == 0, result.stderr
        outputs.append([(out / f"occlusion-self{suffix}").read_bytes() for suffix in (".csv", "-summary.csv", ".png")])
    assert outputs[0] == outputs[1]


def test_values_run_a_subset_of_the_sweep_on_the_same_data(tmp_path, capsys):
    for folder, values in (("all", []), ("one", ["--values", "8"])):
        assert main(["experiment", "density", "--out", str(tmp_path / folder), "--runs", "1", "--tiny", *values]) == 0
    every = read_table(tmp_path / "all" / "density-self.csv", required=("trajectories", "seed"))
    chosen = read_table(tmp_path / "one" / "density-self.csv", required=("trajectories", "seed"))
    assert set(chosen["trajectories"]) == {8}
    np.testing.assert_array_equal(chosen["track_error"], every["track_error"][every["trajectories"] == 8])
    # The sweeps above print timed progress lines when they run long (stderr is no terminal here).
    capsys.readouterr()
    assert main(["experiment", "density", "--out", str(tmp_path), "--runs", "1", "--tiny", "--values", "7"]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and "--values 7 not swept" in error


def test_bad_run_count_is_a_one_line_error(tmp_path, capsys):
    assert main(["experiment", "density", "--out", str(tmp_path), "--runs", "0"]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and "--runs must be at least 1" in error
