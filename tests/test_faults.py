"""Issue 18's faults and bad input, one test a case: each ends in a result or in one line, exit 2."""

from __future__ import annotations

import errno
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from seedtrack.cli import main
from seedtrack.data.csvio import read_table, write_table
from seedtrack.data.dish import DishSpec, write_dish_clip
from seedtrack.data.trackfile import read_tracks
from seedtrack.tracking.ipan import IPANConfig, _Linker, ipan
from seedtrack.tracking.trackers import TRACKERS

ALGORITHMS = ["goa", *TRACKERS]


@pytest.fixture(scope="module")
def clip(tmp_path_factory):
    """A small dish clip (8 frames, 320 x 240) and its truth."""
    folder = tmp_path_factory.mktemp("clip")
    write_dish_clip(DishSpec(seeds=8, frames=8, width=320, height=240, rim_speed=8.0, random_seed=5), folder)
    return folder


def run(capsys, *args):
    """``seedtrack ARGS`` in process: (exit status, stdout, stderr)."""
    status = main([str(a) for a in args])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def one_line_error(capsys, *args) -> str:
    status, _, err = run(capsys, *args)
    assert status == 2, err
    lines = err.splitlines()
    assert len(lines) == 1 and "error:" in lines[0] and "Traceback" not in err, err
    return lines[0]


def points_file(path, rows, header="frame,x,y"):
    path.write_text(header + "\n" + "".join(",".join(map(str, row)) + "\n" for row in rows))
    return path


def walkers(frames=6, n=5, step=3.0):
    return [(k, 20 + 15 * i + step * k, 30 + 10 * i) for k in range(frames) for i in range(n)]


# --- a full disk: one line naming the file, nothing half-written --------------------------------


def _no_space(*args, **kwargs):
    raise OSError(errno.ENOSPC, "No space left on device")


@pytest.mark.parametrize(
    "patch, command",
    [
        ("pandas.DataFrame.to_csv", ["track", "{points}", "--out", "{out}/tracks.csv"]),
        ("pandas.DataFrame.to_csv", ["synth", "psmg", "--out", "{out}", "--tracks", "3", "--frames", "4"]),
        ("pandas.DataFrame.to_csv", ["evaluate", "{truth}", "--truth", "{truth}", "--out", "{out}"]),
        ("pathlib.Path.write_bytes", ["render", "{clip}/clip.mp4", "{truth}", "--out", "{out}/frame.png"]),
        ("pathlib.Path.write_bytes", ["review", "{clip}/clip.mp4", "{truth}", "--out", "{out}"]),
    ],
)
def test_a_full_disk_is_one_line_naming_the_file(clip, tmp_path, capsys, monkeypatch, patch, command):
    points = points_file(tmp_path / "points.csv", walkers())
    out = tmp_path / "out"
    out.mkdir()
    module, _, name = patch.rpartition(".")
    monkeypatch.setattr(module + "." + name, _no_space)
    args = [part.format(points=points, out=out, truth=clip / "truth.csv", clip=clip) for part in command]
    line = one_line_error(capsys, *args)
    assert "No space left on device" in line and str(out) in line
    failed = line.split(": error: ")[1].split(": could not be written")[0]
    assert not Path(failed).exists() and not list(out.rglob(".*"))  # no partial file, no temporary left


def test_a_write_error_of_the_temporary_file_names_the_target(tmp_path):
    from seedtrack.data.atomic import atomic_path
    from seedtrack.data.errors import DataError

    target = tmp_path / "tracks.csv"
    with pytest.raises(DataError, match="tracks.csv: could not be written .No space left on device."):
        with atomic_path(target):
            raise OSError(errno.ENOSPC, "No space left on device")
    assert list(tmp_path.iterdir()) == []


# --- numbers out of range -----------------------------------------------------------------------


@pytest.mark.parametrize("algorithm", ALGORITHMS)
@pytest.mark.parametrize("value", ["1e155", "1e300", "-2e6"])
def test_a_coordinate_out_of_range_is_one_line_for_every_algorithm(tmp_path, capsys, algorithm, value):
    rows = walkers()
    rows[7] = (rows[7][0], value, rows[7][2])
    points = points_file(tmp_path / "points.csv", rows)
    line = one_line_error(capsys, "track", points, "--out", tmp_path / "t.csv", "--algorithm", algorithm)
    assert "points.csv: line 9: x = " in line and "out of range" in line
    assert not (tmp_path / "t.csv").exists()


@pytest.mark.parametrize("name, text", [("t.txt", "1,1,1e300,0,0,0,1,-1,-1,-1\n"), ("t.csv", "track_id,frame,x,y\n1,0,5,1e300\n")])
def test_every_track_reader_checks_the_same_range(tmp_path, name, text):
    from seedtrack.data.errors import DataError

    (tmp_path / name).write_text(text)
    with pytest.raises(DataError, match="out of range .a position in pixels"):
        read_tracks(tmp_path / name)


def test_pandas_reads_what_we_write_and_names_the_line_past_blank_lines(tmp_path):
    path = tmp_path / "p.csv"
    write_table(path, {"frame": np.array([0, 1]), "x": np.array([1.25, 2.0]), "y": np.array([3.0, 4.0]), "label": np.array(["a", "b,c"], dtype=object)})
    assert pd.read_csv(path)["label"].tolist() == ["a", "b,c"]
    table = read_table(path, required=("frame", "x", "y"))
    assert table["x"].tolist() == [1.25, 2.0] and table["label"].tolist() == ["a", "b,c"]
    (tmp_path / "q.csv").write_text("frame,x,y\n0,1,2\n\n\n1,2,abc\n")
    from seedtrack.data.errors import DataError

    with pytest.raises(DataError, match="q.csv: line 5: column y holds 'abc', not a number"):
        read_table(tmp_path / "q.csv", required=("frame", "x", "y"))


# --- options out of range -----------------------------------------------------------------------


@pytest.mark.parametrize(
    "options, message",
    [
        (["--scale", "100"], "--scale 100 draws 32000x24000 frames"),
        (["--scale", "0.001"], "--scale 0.001 draws 0x0 frames"),
        (["--fps", "100000"], "--fps must be at least 0.01 and at most 1000"),
        (["--fps", "2.23e-311"], "--fps must be at least 0.01 and at most 1000"),
        (["--frame", "-1"], "--frame must be a 0-based frame index >= 0, got -1"),
    ],
)
def test_render_refuses_options_out_of_range(clip, tmp_path, capsys, options, message):
    out = tmp_path / "r.png" if "--frame" in options else tmp_path / "r.mp4"
    assert message in one_line_error(capsys, "render", clip / "clip.mp4", clip / "truth.csv", "--out", out, *options)
    assert not out.exists()


def test_phi_max_above_its_range_is_refused(tmp_path, capsys):
    points = points_file(tmp_path / "points.csv", walkers())
    assert "--phi-max must be at most 1.1" in one_line_error(capsys, "track", points, "--out", tmp_path / "t.csv", "--phi-max", "5")


@pytest.mark.parametrize(
    "options, message",
    [
        (["--seeds", "0"], "--seeds must be at least 1, got 0"),
        (["--frames", "1"], "--frames must be at least 3"),
        (["--hidden-probability", "2"], "--hidden-probability must be in [0, 1]"),
    ],
)
def test_demo_refuses_a_scene_it_cannot_score(tmp_path, capsys, options, message):
    line = one_line_error(capsys, "demo", "--out", tmp_path / "demo", *options)
    assert message in line and "DishSpec" not in line
    assert not (tmp_path / "demo").exists()


# --- one meaning per extension ------------------------------------------------------------------


def test_evaluate_reads_the_txt_that_track_writes(tmp_path, capsys):
    points = points_file(tmp_path / "points.csv", walkers())
    assert run(capsys, "track", points, "--out", tmp_path / "t.txt")[0] == 0
    assert run(capsys, "track", points, "--out", tmp_path / "t.csv")[0] == 0
    status, out, err = run(capsys, "evaluate", tmp_path / "t.txt", "--truth", tmp_path / "t.csv")
    assert status == 0, err
    assert "link_error       0.000000" in out
    # The same text whichever command wrote it: correct with no edits is a copy.
    (tmp_path / "none.txt").write_text("")
    assert run(capsys, "correct", tmp_path / "t.csv", tmp_path / "none.txt", "--out", tmp_path / "c.txt")[0] == 0
    assert (tmp_path / "c.txt").read_text() == (tmp_path / "t.txt").read_text()


def test_a_points_table_named_as_another_format_is_refused(tmp_path, capsys, clip):
    points = points_file(tmp_path / "points.txt", walkers())
    assert ".txt names mot files, not a CSV table" in one_line_error(capsys, "track", points, "--out", tmp_path / "t.csv")
    assert ".txt names mot files" in one_line_error(capsys, "detect", clip / "clip.mp4", "--out", tmp_path / "d.txt")


# --- inputs that do not belong together ---------------------------------------------------------


def _far_tracks(path):
    write_table(path, {"track_id": np.array([0, 0]), "frame": np.array([0, 1]), "x": np.array([900.0, 905.0]), "y": np.array([700.0, 700.0])})
    return path


def test_review_refuses_another_clips_tracks(clip, tmp_path, capsys):
    line = one_line_error(capsys, "review", clip / "clip.mp4", _far_tracks(tmp_path / "other.csv"), "--out", tmp_path / "pages")
    assert "lie well outside the 320x240 frames" in line and "are these the tracks of this clip?" in line
    assert not (tmp_path / "pages").exists()


def test_review_refuses_tracks_past_the_clips_end(clip, tmp_path, capsys):
    path = tmp_path / "late.csv"
    write_table(path, {"track_id": np.array([0, 0]), "frame": np.array([20, 21]), "x": np.array([50.0, 51.0]), "y": np.array([50.0, 50.0])})
    assert "frames 20..21 lie outside the video" in one_line_error(capsys, "review", clip / "clip.mp4", path, "--out", tmp_path / "pages")


def test_render_refuses_another_clips_detections(clip, tmp_path, capsys):
    detections = points_file(tmp_path / "d.csv", [(0, 900, 700), (1, 901, 700)])
    line = one_line_error(capsys, "render", clip / "clip.mp4", clip / "truth.csv", "--detections", detections, "--out", tmp_path / "r.png")
    assert "d.csv: 2 point(s) lie well outside" in line and "detections of this clip" in line


def test_a_region_of_interest_outside_the_frame_is_warned(clip, tmp_path, capsys):
    status, _, err = run(capsys, "detect", clip / "clip.mp4", "--out", tmp_path / "d.csv", "--roi", "5000,5000,10")
    assert status == 0
    assert "warning: --roi 5000,5000,10: the circle lies wholly outside the 320x240 frames" in err


def test_duplicate_rows_are_reported_and_read_once(tmp_path, capsys):
    rows = walkers()
    points = points_file(tmp_path / "points.csv", rows + [rows[3], rows[3], rows[8]])
    status, out, err = run(capsys, "track", points, "--out", tmp_path / "t.csv", "--algorithm", "nn")
    assert status == 0
    assert "points.csv: 3 row(s) repeat an earlier row's frame, x and y (first line 32, as line 5)" in err
    assert f"{len(rows)} points" in out and read_tracks(tmp_path / "t.csv").n_tracks == 5


# --- messages that said something else ----------------------------------------------------------


def test_a_folder_given_for_a_file_is_named_a_folder(tmp_path, capsys):
    (tmp_path / "points").mkdir()
    assert "points: is a folder; give a file" in one_line_error(capsys, "track", tmp_path / "points", "--out", tmp_path / "t.csv")
    assert "points: is a folder" in one_line_error(capsys, "evaluate", tmp_path / "points", "--truth", tmp_path / "points")


def test_a_missing_mask_is_a_missing_file(clip, tmp_path, capsys):
    line = one_line_error(capsys, "detect", clip / "clip.mp4", "--out", tmp_path / "d.csv", "--roi", tmp_path / "mask.png")
    assert "mask.png: no such mask image file" in line


def test_wrong_tracks_says_a_track_missed_a_frame_rather_than_ended(tmp_path, capsys):
    truth = points_file(tmp_path / "truth.csv", [(0, k, 10 + 5 * k, 10) for k in range(6)], "track_id,frame,x,y")
    # The result follows the truth but has no point in frame 2.
    result = points_file(tmp_path / "result.csv", [(7, k, 10 + 5 * k, 10) for k in range(6) if k != 2], "track_id,frame,x,y")
    assert run(capsys, "evaluate", result, "--truth", truth, "--out", tmp_path / "ev")[0] == 0
    wrong = read_table(tmp_path / "ev" / "wrong_tracks.csv")
    assert wrong["what"].tolist() == ["its result track misses this frame (it goes on from frame 3)"]


# --- TrackMate branches: see test_trackfile.test_trackmate_branching_track_is_read_as_its_branches.

# --- IPAN on dense input ------------------------------------------------------------------------


def test_ipan_weighs_a_bounded_number_of_candidates_on_dense_input():
    rng = np.random.default_rng(0)
    frames = [rng.uniform(0, 100, (60, 2)) for _ in range(4)]
    linker = _Linker(frames, IPANConfig(v_max=1000.0))
    assert max(len(near) for near in linker.ahead[0]) == 8 and max(len(near) for near in linker.behind[1]) == 8


def test_ipan_bounds_change_nothing_where_candidates_are_few():
    from seedtrack.data.psmg import PSMGSpec, generate_psmg

    frames, _ = generate_psmg(PSMGSpec(trajectories=20, frames=12, size=400, mean_speed=5, occlusion=0.1, random_seed=2))
    config = IPANConfig(v_max=10.0)
    bounded = ipan(frames, config)
    unbounded = ipan(frames, IPANConfig(v_max=10.0, max_candidates=10**6, max_gap_candidates=10**6))
    np.testing.assert_array_equal(bounded.xy, unbounded.xy)


# --- start-up: lazy imports and Ctrl-C ----------------------------------------------------------


def test_help_and_version_import_no_command():
    code = textwrap.dedent(
        """
        import sys
        from seedtrack.cli import main
        for args in (["--help"], ["--version"]):
            try:
                main(args)
            except SystemExit:
                pass
        heavy = sorted(m for m in sys.modules if m.split(".")[0] in ("numpy", "scipy", "cv2", "av", "pandas") or m.startswith("seedtrack.commands."))
        print(heavy)
        """
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert result.stdout.strip().splitlines()[-1] == "[]"


@pytest.mark.parametrize("where", ["importlib.import_module", "argparse.ArgumentParser.parse_args"])
def test_ctrl_c_during_start_up_is_one_line_and_130(tmp_path, capsys, monkeypatch, where):
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    module, _, name = where.rpartition(".")
    monkeypatch.setattr(module + "." + name, interrupted)
    status = main(["track", str(tmp_path / "points.csv"), "--out", str(tmp_path / "t.csv")])
    err = capsys.readouterr().err
    assert status == 130 and err == "seedtrack track: interrupted; files already written are complete\n"
