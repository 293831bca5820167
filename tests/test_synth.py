"""End-to-end: ``seedtrack synth psmg``, alone and followed by ``track`` and ``evaluate``."""

import re
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from seedtrack.cli import main
from seedtrack.data.csvio import read_table


def seedtrack(*args):
    return subprocess.run([sys.executable, "-m", "seedtrack", *map(str, args)], capture_output=True, text=True)


def _measure(report: str, name: str) -> float:
    return float(next(line.split()[1] for line in report.splitlines() if line.startswith(name + " ")))


def test_synth_track_evaluate_round_trip(tmp_path):
    made = seedtrack("synth", "psmg", "--out", tmp_path, "--tracks", 30, "--frames", 12, "--occlusion", 0.05, "--seed", 3)
    assert made.returncode == 0, made.stderr
    tracked = seedtrack("track", tmp_path / "points.csv", "--out", tmp_path / "tracks.csv")
    assert tracked.returncode == 0, tracked.stderr
    report = seedtrack("evaluate", tmp_path / "tracks.csv", "--truth", tmp_path / "truth.csv")
    assert report.returncode == 0, report.stderr
    assert _measure(report.stdout, "true_tracks") == 30
    assert _measure(report.stdout, "track_error") <= 0.05 and _measure(report.stdout, "link_error") <= 0.01


def test_options_reach_the_generator(tmp_path):
    argv = ["synth", "psmg", "--out", str(tmp_path), "--tracks", "12", "--frames", "9", "--size", "150", "--occlusion", "0.2"]
    assert main(argv + ["--mean-speed", "2", "--max-speed", "2.5", "--speed-sigma", "1", "--seed", "1"]) == 0
    points = read_table(tmp_path / "points.csv", required=("frame", "x", "y"))
    truth = read_table(tmp_path / "truth.csv", required=("track_id", "frame", "x", "y", "interpolated"))
    assert list(points) == ["frame", "x", "y"]
    assert sorted(set(truth["track_id"])) == list(range(12)) and sorted(set(truth["frame"])) == list(range(9))
    assert 0 < truth["interpolated"].sum() == truth["frame"].size - points["frame"].size
    assert points["x"].min() >= 0 and max(points["x"].max(), points["y"].max()) <= 150
    order = np.lexsort((truth["frame"], truth["track_id"]))
    xy = np.column_stack((truth["x"], truth["y"]))[order].reshape(12, 9, 2)
    assert np.hypot(*np.diff(xy, axis=1).T).max() <= 2.5 + 1e-3


def test_same_seed_same_files_other_seed_other_files(tmp_path):
    for name, seed in (("a", 7), ("b", 7), ("c", 8)):
        assert main(["synth", "psmg", "--out", str(tmp_path / name), "--tracks", "10", "--frames", "6", "--seed", str(seed)]) == 0
    for file in ("points.csv", "truth.csv"):
        assert (tmp_path / "a" / file).read_bytes() == (tmp_path / "b" / file).read_bytes()
        assert (tmp_path / "a" / file).read_bytes() != (tmp_path / "c" / file).read_bytes()


@pytest.mark.parametrize(
    "options, message",
    [
        (["--occlusion", "1.5"], "occlusion must lie in [0, 1)"),
        (["--mean-speed", "-1"], "mean_speed non-negative"),
        (["--size", "nan"], "--size must be a finite number, got nan"),
        (["--max-speed", "0"], "--max-speed must be positive, got 0"),
        (["--tracks", "0"], "need at least 1 track and 2 frames"),
        (["--size", "10", "--mean-speed", "20"], "could not draw 50 trajectories that stay in a 10 px view"),
    ],
)
def test_bad_options_are_one_line_exit_2_nothing_written(tmp_path, capsys, options, message):
    assert main(["synth", "psmg", "--out", str(tmp_path / "out"), *options]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and message in error, error
    assert not (tmp_path / "out").exists()


def test_longer_gaps_and_points_entering_and_leaving(tmp_path):
    argv = ["synth", "psmg", "--out", str(tmp_path), "--tracks", "40", "--occlusion", "0.3", "--max-gap", "3", "--entry-exit"]
    assert main(argv) == 0
    truth = read_table(tmp_path / "truth.csv", required=("track_id", "frame", "x", "y", "interpolated"))
    points = read_table(tmp_path / "points.csv", required=("frame", "x", "y"))
    assert points["frame"].size == (truth["interpolated"] == 0).sum()
    assert min(truth["x"].min(), truth["y"].min()) >= 0 and max(truth["x"].max(), truth["y"].max()) <= 200
    first = {t: truth["frame"][truth["track_id"] == t].min() for t in range(40)}
    last = {t: truth["frame"][truth["track_id"] == t].max() for t in range(40)}
    assert any(f > 0 for f in first.values()) and any(f < 19 for f in last.values())
    # Runs of hidden frames inside a track: some longer than one frame, none longer than three.
    runs = []
    for t in range(40):
        mine = truth["track_id"] == t
        flags = truth["interpolated"][mine][np.argsort(truth["frame"][mine])]
        runs += [len(r) for r in "".join(map(str, flags)).split("0") if r]
    assert max(runs) == 3 and min(runs) == 1


def test_the_readme_psmg_example_prints_the_figures_it_quotes(tmp_path, monkeypatch, capsys):
    readme = (Path(__file__).parents[1] / "docs" / "cli.md").read_text(encoding="utf-8")
    block = readme.split("With 10% of the points missed:", 1)[1].split("```bash\n", 1)[1].split("```", 1)[0]
    monkeypatch.chdir(tmp_path)
    for line in block.splitlines():
        command, _, comment = line.partition("#")
        assert main(shlex.split(command)[1:]) == 0
    quoted = re.fullmatch(r"\s*(\d+) of (\d+) tracks perfect, link error ([\d.]+)\s*", comment)
    report = capsys.readouterr().out
    assert (int(quoted[1]), int(quoted[2])) == (_measure(report, "correct_tracks"), _measure(report, "true_tracks"))
    assert quoted[3] == f"{_measure(report, 'link_error'):.3f}"
