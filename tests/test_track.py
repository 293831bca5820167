"""End-to-end: ``seedtrack track`` on point files, and its answers to bad input."""

import subprocess
import sys

import numpy as np
import pytest

from seedtrack.cli import main
from seedtrack.data.csvio import read_table, write_table
from seedtrack.data.psmg import PSMGSpec, generate_psmg
from seedtrack.data.walkers import WalkerSpec, generate_walkers
from seedtrack.tracking.trackers import TRACKERS
from seedtrack.tracking.tracks import Tracks

FIRST_FRAME = 7


def seedtrack(*args):
    return subprocess.run([sys.executable, "-m", "seedtrack", *map(str, args)], capture_output=True, text=True)


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    """PSMG points starting at frame 7, rows shuffled, with a label column; and their truth."""
    folder = tmp_path_factory.mktemp("points")
    frames, truth = generate_psmg(PSMGSpec(trajectories=15, frames=10, occlusion=0.1, random_seed=3))
    frame = np.concatenate([np.full(len(p), k + FIRST_FRAME) for k, p in enumerate(frames)])
    xy = np.concatenate(frames)
    label = np.array([f"m{k}" for k in range(frame.size)], dtype=object)
    shuffle = np.random.default_rng(0).permutation(frame.size)
    columns = {"label": label, "frame": frame, "x": xy[:, 0], "y": xy[:, 1]}
    write_table(folder / "points.csv", {name: values[shuffle] for name, values in columns.items()})
    write_table(folder / "truth.csv", Tracks.from_dense(truth.xy, truth.measurement, FIRST_FRAME).to_rows())
    return folder, columns


def test_track_then_evaluate_finds_every_trajectory(scene, tmp_path):
    folder, columns = scene
    out = tmp_path / "tracks.csv"
    result = seedtrack("track", folder / "points.csv", "--out", out)
    assert result.returncode == 0, result.stderr
    assert out.read_text().splitlines()[0] == "track_id,frame,x,y,interpolated,label"
    tracks = read_table(out, required=("track_id", "frame", "x", "y", "interpolated"))
    assert tracks["frame"].min() == FIRST_FRAME and tracks["frame"].max() == FIRST_FRAME + 9
    # Each measured row carries its own point's label; interpolated rows carry none.
    measured = tracks["interpolated"] == 0
    assert np.all(tracks["label"][~measured] == "")
    by_label = {label: k for k, label in enumerate(columns["label"])}
    source = np.array([by_label[label] for label in tracks["label"][measured]])
    assert np.array_equal(columns["frame"][source], tracks["frame"][measured])
    assert np.allclose(columns["x"][source], tracks["x"][measured], atol=1e-4)
    assert sorted(source) == list(range(columns["frame"].size))
    score = seedtrack("evaluate", out, "--truth", folder / "truth.csv")
    assert score.returncode == 0, score.stderr
    assert "track_error      0.000000" in score.stdout and "link_error       0.000000" in score.stdout


@pytest.mark.parametrize("step", [2, 10])
def test_frames_numbered_every_nth_are_tracked_as_consecutive(scene, tmp_path, capsys, step):
    # What `run --step N` writes: frames 7, 7 + N, 7 + 2N, ...; each one a measurement, not a
    # frame with every point between them missed.
    folder, columns = scene
    spaced = dict(columns, frame=FIRST_FRAME + (columns["frame"] - FIRST_FRAME) * step)
    write_table(tmp_path / "points.csv", spaced)
    truth = read_table(folder / "truth.csv")
    write_table(tmp_path / "truth.csv", dict(truth, frame=FIRST_FRAME + (truth["frame"] - FIRST_FRAME) * step))
    assert main(["track", str(tmp_path / "points.csv"), "--out", str(tmp_path / "tracks.csv")]) == 0
    assert f"10 frames ({step} frame numbers apart, tracked as consecutive)" in capsys.readouterr().out
    tracks = read_table(tmp_path / "tracks.csv")
    assert set(tracks["frame"]) <= set(spaced["frame"])
    assert main(["evaluate", str(tmp_path / "tracks.csv"), "--truth", str(tmp_path / "truth.csv")]) == 0
    assert "link_error       0.000000" in capsys.readouterr().out


def test_evaluate_hints_at_truth_numbered_one_frame_off(scene, tmp_path, capsys):
    folder, _ = scene
    truth = read_table(folder / "truth.csv")
    write_table(tmp_path / "truth.csv", dict(truth, frame=truth["frame"] + 1))
    main(["track", str(folder / "points.csv"), "--out", str(tmp_path / "tracks.csv")])
    capsys.readouterr()
    assert main(["evaluate", str(tmp_path / "tracks.csv"), "--truth", str(tmp_path / "truth.csv")]) == 0
    assert "shifted by -1" in capsys.readouterr().err
    assert main(["evaluate", str(tmp_path / "tracks.csv"), "--truth", str(folder / "truth.csv")]) == 0
    assert "hint" not in capsys.readouterr().err


@pytest.mark.parametrize("algorithm", ["goa", *TRACKERS])
def test_every_algorithm_writes_tracks_of_the_input_points(scene, tmp_path, algorithm):
    folder, columns = scene
    out = tmp_path / "tracks.csv"
    assert main(["track", str(folder / "points.csv"), "--out", str(out), "--algorithm", algorithm]) == 0
    tracks = read_table(out)
    measured = tracks["interpolated"] == 0
    assert measured.sum() == columns["frame"].size
    assert set(tracks["label"][measured]) == set(columns["label"])


def test_row_order_does_not_change_the_output(scene, tmp_path):
    folder, columns = scene
    reversed_rows = {name: values[::-1] for name, values in columns.items()}
    write_table(tmp_path / "reversed.csv", reversed_rows)
    outputs = []
    for name, points in (("a", folder / "points.csv"), ("b", tmp_path / "reversed.csv")):
        assert main(["track", str(points), "--out", str(tmp_path / f"{name}.csv")]) == 0
        outputs.append((tmp_path / f"{name}.csv").read_bytes())
    assert outputs[0] == outputs[1]


@pytest.mark.parametrize("algorithm", ["goa", "goa-updown", "goa-updown-fixed"])
def test_a_frame_number_without_points_is_bridged(tmp_path, algorithm):
    # Two points moving steadily; frame 6 is absent from the file (nothing measured there).
    # Three frames on each side: the open GOA-updown opens a track only on three measured frames in a row.
    frames = [3, 4, 5, 7, 8, 9]
    rows = [f"{k},{10 + 2 * (k - 3)},10,5\n{k},50,{50 + 3 * (k - 3)},6\n" for k in frames]
    points = tmp_path / "points.csv"
    points.write_text("frame,x,y,area\n" + "".join(rows))
    out = tmp_path / "tracks.csv"
    assert main(["track", str(points), "--out", str(out), "--algorithm", algorithm]) == 0
    tracks = read_table(out)
    assert list(tracks["frame"]) == list(range(3, 10)) * 2
    assert list(tracks["interpolated"]) == [0, 0, 0, 1, 0, 0, 0] * 2
    assert np.allclose(tracks["x"][:7], np.arange(10, 24, 2)) and np.allclose(tracks["y"][7:], np.arange(50, 71, 3))
    # Interpolated rows leave the kept column blank, which reads back as NaN, as in pandas.
    assert np.array_equal(tracks["area"], [5, 5, 5, np.nan, 5, 5, 5, 6, 6, 6, np.nan, 6, 6, 6], equal_nan=True)


def test_random_walkers_with_a_frame_number_without_points_are_tracked(tmp_path, capsys):
    # Enough walkers for the motion to be measured as random, which asks how many links would
    # arise by chance: that check once failed on the empty frame.
    frames, _ = generate_walkers(WalkerSpec(walkers=150, frames=8, size=256.0, random_seed=1))
    kept = [k for k in range(len(frames)) if k != 4]
    frame = np.concatenate([np.full(len(frames[k]), k) for k in kept])
    xy = np.concatenate([frames[k] for k in kept])
    write_table(tmp_path / "points.csv", {"frame": frame, "x": xy[:, 0], "y": xy[:, 1]})
    out = tmp_path / "tracks.csv"
    assert main(["track", str(tmp_path / "points.csv"), "--out", str(out)]) == 0
    assert "motion: random motion" in capsys.readouterr().out
    tracks = read_table(out)
    assert np.all(tracks["interpolated"][tracks["frame"] == 4] == 1) and np.any(tracks["frame"] == 4)


def test_track_goa_options_are_refused_by_other_trackers(scene, tmp_path):
    folder, _ = scene
    result = seedtrack("track", folder / "points.csv", "--out", tmp_path / "t.csv", "--algorithm", "nn", "--individual-model", "im3")
    assert result.returncode == 2
    assert "--individual-model only apply to --algorithm goa or goa-updown" in result.stderr
    assert not (tmp_path / "t.csv").exists()


@pytest.mark.parametrize("model", ["--individual-model=im1", "--individual-model=im3", "--combined-model=cm2", "--first-links=nearest", "--first-links=paper"])
def test_model_options_reach_the_tracker(scene, tmp_path, model):
    folder, columns = scene
    out = tmp_path / "tracks.csv"
    assert main(["track", str(folder / "points.csv"), "--out", str(out), model, "--max-speed", "12", "--fixed-count"]) == 0
    tracks = read_table(out)
    # Fixed-count GOA-updown keeps one track per first-frame point; a point no track takes is left out, none is used twice.
    labels = tracks["label"][tracks["interpolated"] == 0]
    assert len(set(labels)) == labels.size and set(labels) <= set(columns["label"])
    assert len(set(tracks["track_id"])) == (columns["frame"] == FIRST_FRAME).sum()


def _one_line_exit_2(capsys, argv, message):
    # In process for speed; test_track_goa_options_are_refused_by_other_trackers runs the real command.
    assert main(list(map(str, argv))) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and message in error, error


GOOD_POINTS = "frame,x,y\n0,1,1\n1,2,1\n"


def test_empty_lines_at_the_end_of_the_points_are_ignored(tmp_path):
    (tmp_path / "points.csv").write_text(GOOD_POINTS + "\n\n")
    assert main(["track", str(tmp_path / "points.csv"), "--out", str(tmp_path / "tracks.csv")]) == 0
    assert read_table(tmp_path / "tracks.csv")["frame"].tolist() == [0, 1]


@pytest.mark.parametrize(
    "text, message",
    [
        ("frame,x\n0,1\n1,2\n", "points.csv: missing column(s) y"),
        ("frame,x,y\n0,1,1\n1,abc,1\n", "points.csv: line 3: column x holds 'abc', not a number"),
        ("frame,x,y\n0,1,1\n1,2,nan\n", "points.csv: line 3: column y holds 'nan', not a finite number"),
        ("frame,x,y\n0,1,1\n1.5,2,1\n", "points.csv: line 3: column frame holds '1.5', not a whole number"),
        ("frame,x,y\n0,1,1\n-1,2,1\n", "points.csv: line 3: frame = -1 is out of range (a 0-based frame index"),
        ("frame,x,y\n", "points.csv: no points (only a header)"),
        ("frame,x,y,x\n0,1,1,5\n1,2,1,6\n", "points.csv: line 1: column(s) x appear more than once in the header"),
        ("", "points.csv: the file is empty"),
        ("frame,x,y\n4,1,1\n4,2,1\n", "points.csv: all points are in frame 4; tracking needs points in at least two frames"),
    ],
)
def test_track_bad_points_is_one_line_exit_2_nothing_written(tmp_path, capsys, text, message):
    (tmp_path / "points.csv").write_text(text)
    _one_line_exit_2(capsys, ["track", tmp_path / "points.csv", "--out", tmp_path / "tracks.csv"], message)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["points.csv"]


@pytest.mark.parametrize(
    "options, message",
    [
        (["--max-speed", "0"], "--max-speed must be a positive finite number, got 0"),
        (["--max-speed", "-3"], "--max-speed must be a positive finite number, got -3"),
        (["--max-speed", "nan"], "--max-speed must be a positive finite number, got nan"),
        (["--phi-max", "0"], "--phi-max must be a positive finite number, got 0"),
        (["--min-speed", "-1"], "--min-speed must be a non-negative finite number, got -1"),
        (["--min-speed", "5", "--max-speed", "3"], "--min-speed (5) must be below --max-speed (3)"),
        (["--algorithm", "ss", "--max-speed", "-1"], "--max-speed must be a positive finite number, got -1"),
    ],
)
def test_track_bad_limits_are_one_line_exit_2_nothing_written(tmp_path, capsys, options, message):
    (tmp_path / "points.csv").write_text(GOOD_POINTS)
    _one_line_exit_2(capsys, ["track", tmp_path / "points.csv", "--out", tmp_path / "tracks.csv", *options], message)
    assert not (tmp_path / "tracks.csv").exists()


def test_track_output_that_is_a_folder_is_one_line_exit_2(tmp_path, capsys):
    (tmp_path / "points.csv").write_text(GOOD_POINTS)
    _one_line_exit_2(capsys, ["track", tmp_path / "points.csv", "--out", tmp_path], "is a folder; give a file name")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["points.csv"]


def test_track_output_in_a_missing_folder_is_refused_before_the_points_are_read(tmp_path, capsys):
    out = tmp_path / "missing" / "tracks.csv"
    _one_line_exit_2(capsys, ["track", tmp_path / "absent.csv", "--out", out], f"{out}: folder {out.parent} does not exist")


TRUTH = "track_id,frame,x,y\n0,0,1,1\n0,1,2,1\n"


@pytest.mark.parametrize(
    "tracks, truth, message",
    [
        ("track_id,frame,x\n0,0,1\n", TRUTH, "tracks.csv: line 1: a track CSV needs columns track_id,frame,x,y"),
        ("track_id,frame,x,y\n0,0,1,one\n", TRUTH, "tracks.csv: line 2: column y holds 'one', not a number"),
        ("track_id,frame,x,y\n0,0,nan,1\n", TRUTH, "tracks.csv: line 2: column x holds 'nan', not a finite number"),
        ("", TRUTH, "tracks.csv: line 1: a track CSV needs columns"),
        (TRUTH, "track_id,frame,x,y\n", "truth.csv: holds no true tracks"),
        (TRUTH, "track_id,frame,x,y\n0,3,1,1\n1,3,5,5\n", "truth.csv: holds a single frame (3)"),
    ],
)
def test_evaluate_bad_files_are_one_line_exit_2_nothing_written(tmp_path, capsys, tracks, truth, message):
    (tmp_path / "tracks.csv").write_text(tracks)
    (tmp_path / "truth.csv").write_text(truth)
    argv = ["evaluate", tmp_path / "tracks.csv", "--truth", tmp_path / "truth.csv", "--out", tmp_path / "out"]
    _one_line_exit_2(capsys, argv, message)
    assert not (tmp_path / "out").exists()


def test_evaluate_scores_a_single_frame_result(tmp_path, capsys):
    (tmp_path / "tracks.csv").write_text("track_id,frame,x,y\n5,0,1,1\n")
    (tmp_path / "truth.csv").write_text(TRUTH)
    assert main(["evaluate", str(tmp_path / "tracks.csv"), "--truth", str(tmp_path / "truth.csv")]) == 0
    table = capsys.readouterr().out
    assert "track_error      1.000000" in table and "link_error       1.000000" in table


def test_track_output_ending_in_a_slash_is_refused(tmp_path, capsys):
    (tmp_path / "points.csv").write_text(GOOD_POINTS)
    with pytest.raises(SystemExit) as exit_:
        main(["track", str(tmp_path / "points.csv"), "--out", f"{tmp_path}/result/"])
    assert exit_.value.code == 2 and "names a folder; give a file name" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["points.csv"]


def test_goa_takes_its_first_links_from_a_tracks_file(tmp_path, capsys):
    # The paper's protocol: GOA given the true correspondences of the first two frames.
    from seedtrack.data.trackfile import write_tracks
    from seedtrack.tracking.metrics import score_tracks

    frames, truth = generate_psmg(PSMGSpec(trajectories=15, mean_speed=4.0, random_seed=3))
    frame = np.concatenate([np.full(len(f), k) for k, f in enumerate(frames)])
    xy = np.concatenate(frames)
    write_table(tmp_path / "points.csv", {"frame": frame, "x": xy[:, 0], "y": xy[:, 1]})
    write_tracks(tmp_path / "truth.csv", truth, np.arange(len(frames)))
    out = tmp_path / "tracks.csv"
    assert main(["track", str(tmp_path / "points.csv"), "--out", str(out), "--algorithm", "goa", "--first-links", str(tmp_path / "truth.csv")]) == 0
    tracks = read_table(out)
    result = Tracks.from_rows(tracks["track_id"], tracks["frame"], tracks["x"], tracks["y"], tracks["interpolated"])
    assert score_tracks(result, truth, 0.5).correct_tracks == 15
    # A first link that is no measured point is refused with the file's line.
    write_table(tmp_path / "bad.csv", {"track_id": np.array([0]), "frame": np.array([0]), "x": np.array([-5.0]), "y": np.array([-5.0])})
    capsys.readouterr()
    code = main(["track", str(tmp_path / "points.csv"), "--out", str(out), "--algorithm", "goa", "--first-links", str(tmp_path / "bad.csv")])
    assert code == 2 and "bad.csv: line 2: no point of frame 0" in capsys.readouterr().err


def test_table_written_in_blocks_is_the_table_written_whole(tmp_path, monkeypatch):
    import pandas as pd

    from seedtrack.data import csvio

    columns = {
        "track_id": np.arange(10) % 3,
        "x": np.linspace(-1.0, 2.0, 10),
        "y": np.where(np.arange(10) % 4 == 0, np.nan, 0.5),
        "interpolated": np.arange(10) % 2 == 0,
        "note": np.array([f"n{k}" for k in range(10)], dtype=object),
    }
    whole = pd.DataFrame({name: csvio._for_writing(values) for name, values in columns.items()})
    expected = whole.to_csv(index=False, float_format=csvio._FLOAT_FORMAT, na_rep="", lineterminator="\n")
    monkeypatch.setattr(csvio, "_WRITE_ROWS", 3)
    write_table(tmp_path / "t.csv", columns)
    assert (tmp_path / "t.csv").read_text(encoding="utf-8") == expected
