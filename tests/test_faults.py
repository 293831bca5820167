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
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

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


# === issue 32: never overwrite what the user has; never accept what the project cannot read back ===


def _snapshot(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` (hidden ones included), by relative path, with its bytes."""
    return {str(path.relative_to(folder)): path.read_bytes() for path in sorted(folder.rglob("*")) if path.is_file()}


def _visible(folder: Path) -> dict[str, bytes]:
    return {name: data for name, data in _snapshot(folder).items() if not name.startswith(".")}


@pytest.fixture(scope="module")
def other_clip(tmp_path_factory):
    """Another small dish clip of the same size: an older run's input."""
    folder = tmp_path_factory.mktemp("other")
    write_dish_clip(DishSpec(seeds=5, frames=8, width=320, height=240, rim_speed=6.0, random_seed=9), folder)
    return folder


# --- 1. an output never replaces an input -------------------------------------------------------


@pytest.mark.parametrize(
    "command",
    [
        ["render", "{w}/x.mp4", "{w}/t.csv", "--out", "{w}/x.mp4"],
        ["render", "{w}/x.mp4", "{w}/t.csv", "--out", "{w}/./x.mp4"],
        ["render", "{w}/x.mp4", "{w}/t.csv", "--out", "{w}/hard.mp4"],
        ["render", "{w}/x.mp4", "{w}/t.csv", "--out", "{w}/link.mp4"],
        ["render", "{w}/x.mp4", "{w}/t.csv", "--out", "{w}/f.png", "--summary", "{w}/t.csv"],
        ["compare", "{w}/x.mp4", "{w}/t.csv", "{w}/t.csv", "--out", "{w}/hard.mp4"],
        ["run", "{w}/set/overlay.mp4", "--out", "{w}/set"],
        ["detect", "{w}/p.csv", "--out", "{w}/p.csv"],
        ["track", "{w}/p.csv", "--out", "{w}/p.csv"],
        ["track", "{w}/p.csv", "--out", "{w}/sub/../p.csv"],
        ["correct", "{w}/t.csv", "{w}/e.txt", "--out", "{w}/t.csv"],
        ["evaluate", "{w}/set/wrong_tracks.csv", "--truth", "{w}/t.csv", "--out", "{w}/set"],
        ["annotate", "{w}/x.mp4", "{w}/set/tracks.csv", "--out", "{w}/set", "--no-browser"],
        ["review", "{w}/x.mp4", "{w}/t.csv", "--out", "{w}/x.mp4"],
        ["batch", "{w}/set/batch.csv", "--out", "{w}/set"],
    ],
)
def test_an_output_that_is_an_input_is_refused_and_the_input_kept(clip, tmp_path, capsys, command):
    import os
    import shutil

    w = tmp_path
    shutil.copy(clip / "clip.mp4", w / "x.mp4")
    shutil.copy(clip / "truth.csv", w / "t.csv")
    os.link(w / "x.mp4", w / "hard.mp4")
    os.symlink(w / "x.mp4", w / "link.mp4")
    points_file(w / "p.csv", walkers())
    (w / "e.txt").write_text("delete 1\n")
    (w / "sub").mkdir()
    (w / "set").mkdir()
    for name in ("overlay.mp4", "tracks.csv", "wrong_tracks.csv", "batch.csv"):
        shutil.copy(w / ("x.mp4" if name.endswith(".mp4") else "t.csv"), w / "set" / name)
    before = _snapshot(w)
    line = one_line_error(capsys, *[part.format(w=w) for part in command])
    assert "is an input of this command" in line and "would replace the input" in line
    assert _snapshot(w) == before


def test_an_output_in_a_folder_of_frames_read_as_input_is_refused(tmp_path, capsys):
    import cv2

    frames = tmp_path / "frames"
    frames.mkdir()
    for k in range(3):
        cv2.imwrite(str(frames / f"f{k}.png"), np.full((40, 40), 60 * k, np.uint8))
    points_file(tmp_path / "t.csv", [(0, k, 10, 10) for k in range(3)], "track_id,frame,x,y")
    before = _snapshot(tmp_path)
    assert "a folder of frames read as input" in one_line_error(capsys, "render", frames, tmp_path / "t.csv", "--out", frames / "over.png")
    assert _snapshot(tmp_path) == before


# --- 2. a run's files as one set -----------------------------------------------------------------


RUN_SET = ["detections.csv", "manifest.json", "overlay.mp4", "tracks.csv"]


def test_run_writes_a_manifest_last_naming_inputs_and_files(clip, tmp_path, capsys):
    import hashlib
    import json

    assert run(capsys, "run", clip / "clip.mp4", "--out", tmp_path / "out", "--workers", "1")[0] == 0
    assert sorted(path.name for path in (tmp_path / "out").iterdir()) == RUN_SET
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert manifest["command"] == "seedtrack run" and manifest["seedtrack"]
    clip_bytes = (clip / "clip.mp4").read_bytes()
    assert manifest["inputs"] == [{"path": str(clip / "clip.mp4"), "size": len(clip_bytes), "sha256": hashlib.sha256(clip_bytes).hexdigest()}]
    for entry in manifest["files"]:
        data = (tmp_path / "out" / entry["name"]).read_bytes()
        assert entry["size"] == len(data) and entry["sha256"] == hashlib.sha256(data).hexdigest()


def test_readers_say_when_a_set_lacks_its_manifest_or_mixes_runs(clip, other_clip, tmp_path, capsys):
    import shutil

    from seedtrack.data.errors import DataWarning

    for name, source in (("a", clip), ("b", other_clip)):
        assert run(capsys, "run", source / "clip.mp4", "--out", tmp_path / name, "--workers", "1")[0] == 0
    with warnings_as_list() as caught:
        read_tracks(tmp_path / "a" / "tracks.csv")
    assert caught == []
    shutil.copy(tmp_path / "b" / "tracks.csv", tmp_path / "a" / "tracks.csv")
    with pytest.warns(DataWarning, match=r"tracks.csv: is not the file manifest.json lists \(another run's"):
        read_tracks(tmp_path / "a" / "tracks.csv")
    shutil.copy(tmp_path / "b" / "overlay.mp4", tmp_path / "b" / "overlay.copy")
    shutil.copy(tmp_path / "a" / "overlay.mp4", tmp_path / "b" / "overlay.mp4")
    with pytest.warns(DataWarning, match="overlay.mp4 beside it is not the file manifest.json lists: the folder mixes two runs"):
        read_tracks(tmp_path / "b" / "tracks.csv")
    (tmp_path / "b" / "manifest.json").unlink()
    status, _, err = run(capsys, "evaluate", tmp_path / "b" / "tracks.csv", "--truth", other_clip / "truth.csv")
    assert status == 0 and "warning: " in err and "no manifest.json beside it: not known to be of one run" in err


def warnings_as_list():
    import warnings

    return warnings.catch_warnings(record=True)


def test_a_failed_run_into_an_old_runs_folder_keeps_the_old_set(clip, other_clip, tmp_path, capsys, monkeypatch):
    out = tmp_path / "out"
    assert run(capsys, "run", other_clip / "clip.mp4", "--out", out, "--workers", "1")[0] == 0
    old = _snapshot(out)
    monkeypatch.setattr("seedtrack.data.trackfile.write_rows", _no_space)
    line = one_line_error(capsys, "run", clip / "clip.mp4", "--out", out, "--workers", "1")
    assert "No space left on device" in line
    assert _snapshot(out) == old


# Run in a process of its own, which forks once per kill: the child runs `seedtrack ARGS` and
# kills itself with SIGKILL at its EVENT-th step (a stage of the pipeline, a frame drawn, or a file
# system call that renames, syncs or removes). A fresh process has no other thread that a fork
# could catch holding a lock. The first child is not killed and counts the steps; then 20 kills
# spread over them, each into a fresh copy of OLD; each folder left is copied to RESULTS/EVENT.
_KILLER = """
import json, os, shutil, signal, sys
from pathlib import Path

import numpy as np
import pandas  # noqa: F401  (imported once here, not in every child)
import seedtrack.commands.run  # noqa: F401
import seedtrack.pipeline as pipeline
from seedtrack.cli import main

args, old, out, results = json.loads(sys.argv[1])
results = Path(results)


def killed_at(event):
    shutil.rmtree(out, ignore_errors=True)
    shutil.copytree(old, out)
    pid = os.fork()
    if pid:
        status = os.waitpid(pid, 0)[1]
        shutil.copytree(out, results / str(event))
        (results / f"{event}.status").write_text(str(status))
        return
    try:
        taken = [0]

        def counted(function):
            def step(*a, **k):
                taken[0] += 1
                if taken[0] == event:
                    os.kill(os.getpid(), signal.SIGKILL)
                return function(*a, **k)

            return step

        for name in ("detect_clip", "write_table", "track_frames", "write_tracks", "_render", "_annotate_pair"):
            setattr(pipeline, name, counted(getattr(pipeline, name)))
        for name in ("replace", "fsync", "unlink", "rename"):
            setattr(os, name, counted(getattr(os, name)))
        null = os.open(os.devnull, os.O_WRONLY)
        os.dup2(null, 1)
        os.dup2(null, 2)
        status = main(args)
        (results / "steps").write_text(str(taken[0]))
        os._exit(status)
    finally:
        os._exit(99)


killed_at(0)
steps = int((results / "steps").read_text())
for event in sorted(set(np.linspace(1, steps, 20).round().astype(int).tolist())):
    killed_at(event)
"""


def test_kill_9_at_20_points_through_run_leaves_the_old_set_or_the_new_one_whole(clip, other_clip, tmp_path, capsys):
    import json
    import os

    from seedtrack.data.errors import DataWarning
    from seedtrack.data.outputset import JOURNAL

    old_folder, out, results = tmp_path / "old", tmp_path / "out", tmp_path / "results"
    results.mkdir()
    args = ["run", str(clip / "clip.mp4"), "--out", str(out), "--workers", "1"]
    assert run(capsys, "run", other_clip / "clip.mp4", "--out", old_folder, "--workers", "1")[0] == 0
    subprocess.run([sys.executable, "-c", _KILLER, json.dumps([args, str(old_folder), str(out), str(results)])], check=True, timeout=300)
    assert (results / "0.status").read_text() == "0"
    new = _visible(results / "0")
    old = _visible(old_folder)
    assert set(new) == set(old) == set(RUN_SET) and all(new[name] != old[name] for name in RUN_SET)
    steps = int((results / "steps").read_text())
    points = sorted(int(path.stem) for path in results.glob("*.status") if path.stem != "0")
    assert len(points) == 20 and points[-1] == steps
    seen = {"old": 0, "new": 0, "finished by the next reader": 0}
    for event in points:
        assert os.WIFSIGNALED(int((results / f"{event}.status").read_text())), event
        left = results / str(event)
        if (left / JOURNAL).exists():
            # The next reader of a file of the set finishes putting it in place, and says so.
            with pytest.warns(DataWarning, match="finished putting in place the files of a run that was stopped part-way"):
                assert read_tracks(left / "tracks.csv").n_tracks == read_tracks(results / "0" / "tracks.csv").n_tracks
            assert _visible(left) == new, event
            seen["finished by the next reader"] += 1
        else:
            now = _visible(left)
            assert now in (old, new), f"killed at step {event} of {steps}: a mix of two runs"
            seen["old" if now == old else "new"] += 1
    # The kills span the run: some before its set was committed, some after.
    assert seen["old"] >= 10 and seen["new"] + seen["finished by the next reader"] >= 2, seen
    # A new run into a folder where one was killed leaves no temporary of the killed run behind.
    assert run(capsys, *[a if a != str(out) else str(results / str(points[0])) for a in args])[0] == 0
    assert _snapshot(results / str(points[0])) == new


# --- 3. annotate: every edit checked as the readers check it ------------------------------------


@pytest.fixture
def annotating(clip, tmp_path):
    import threading

    from seedtrack.annotate.frames import FrameCache
    from seedtrack.annotate.server import AnnotateServer
    from seedtrack.annotate.session import Session

    out = tmp_path / "session"
    out.mkdir()
    server = AnnotateServer(Session(read_tracks(clip / "truth.csv"), out, clip / "truth.csv"), FrameCache(clip / "clip.mp4"))
    threading.Thread(target=server.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True).start()
    yield server
    server.shutdown()
    server.session.close()
    server.server_close()
    server.frames.close()


def _post(server, path, body):
    import http.client
    import json

    connection = http.client.HTTPConnection("127.0.0.1", server.port, timeout=10)
    connection.request("POST", f"{path}?token={server.token}", body=json.dumps(body), headers={"Host": f"127.0.0.1:{server.port}"})
    response = connection.getresponse()
    reply = json.loads(response.read())
    connection.close()
    return response.status, reply


@pytest.mark.parametrize(
    "path, body, reason",
    [
        ("/api/click", {"frame": 3, "x": 1e308, "y": 20}, "x must lie inside the 320x240 frame"),
        ("/api/click", {"frame": 3, "x": 20, "y": -3}, "y must lie inside the 320x240 frame"),
        ("/api/click", {"frame": 3, "x": 320, "y": 20}, "x must lie inside"),
        ("/api/click", {"frame": 99999, "x": 20, "y": 20}, "frame must be a frame of the clip, 0..7, got 99999"),
        ("/api/click", {"frame": 8, "x": 20, "y": 20}, "frame must be a frame of the clip"),
        ("/api/click", {"frame": -1, "x": 20, "y": 20}, "frame must be a frame of the clip"),
        ("/api/click", {"frame": 2, "x": "20", "y": 20}, "x must be a finite number"),
        ("/api/click", {"frame": 2, "x": 20, "y": None}, "y must be a finite number"),
        ("/api/click", {"frame": 2.5, "x": 20, "y": 20}, "frame must be a whole number"),
        ("/api/click", {"frame": 2, "x": 20, "y": 20, "selected": 2**70}, "selected must be at most"),
        ("/api/split", {"track": 1, "frame": 99999}, "frame must be a frame of the clip"),
        ("/api/delete", {"track": 1, "frame": 8}, "frame must be a frame of the clip"),
        ("/api/delete", {"track": True}, "track must be a whole number"),
    ],
)
def test_annotate_refuses_an_edit_the_readers_would_refuse(annotating, path, body, reason):
    folder = annotating.session.folder
    before = _snapshot(folder)
    status, reply = _post(annotating, path, body)
    assert status == 400 and reason in reply["error"], reply
    assert _snapshot(folder) == before


def test_annotate_edits_at_the_frames_edge_are_read_back_by_correct_and_render(annotating, clip, tmp_path, capsys):
    assert _post(annotating, "/api/click", {"frame": 7, "x": 319.5, "y": -0.5})[0] == 200
    assert _post(annotating, "/api/click", {"frame": 0, "x": -0.5, "y": 239.5})[0] == 200
    folder = annotating.session.folder
    annotating.session.close()  # tracks.csv is written a moment after the last edit, or now
    assert run(capsys, "correct", clip / "truth.csv", folder / "corrections.txt", "--out", tmp_path / "c.csv")[0] == 0
    assert (tmp_path / "c.csv").read_bytes() == (folder / "tracks.csv").read_bytes()
    assert run(capsys, "render", clip / "clip.mp4", folder / "tracks.csv", "--out", tmp_path / "r.png")[0] == 0


def test_a_click_on_another_tracks_point_says_what_it_would_do_first(annotating):
    session = annotating.session
    rows = session.tracks.to_rows()
    frame = 4
    a, b = (int(t) for t in sorted(set(rows["track_id"][rows["frame"] == frame]))[:2])
    at_b = (rows["track_id"] == b) & (rows["frame"] == frame)
    x, y = float(rows["x"][at_b][0]), float(rows["y"][at_b][0])
    before = _snapshot(session.folder)
    status, reply = _post(annotating, "/api/click", {"selected": a, "frame": frame, "x": x, "y": y})
    assert status == 409 and reply["reassign"] == f"this is track {b}'s point: the click would swap tracks {a} and {b} from frame {frame} on"
    assert _snapshot(session.folder) == before and session.edits == []
    status, reply = _post(annotating, "/api/click", {"selected": a, "frame": frame, "x": x, "y": y, "reassign": True})
    assert status == 200 and reply["edits"] == [f"swap {a} {b} {frame}"]


def test_the_page_asks_before_taking_another_tracks_point():
    from importlib import resources

    script = resources.files("seedtrack.annotate").joinpath("static", "app.js").read_text()
    # The server's 409 is shown to the user, who says yes before the click is sent again.
    assert "response.status === 409 && reply.reassign" in script and "window.confirm(" in script
    assert "reassign: true" in script and "pointAt(event.offsetX, event.offsetY, event.shiftKey)" in script


def test_the_replay_line_of_corrections_txt_works_in_the_folder_it_names(clip, tmp_path, monkeypatch):
    import os
    import shutil

    from seedtrack.annotate.session import Session

    start_folder = tmp_path / "run 1"
    start_folder.mkdir()
    shutil.copy(clip / "truth.csv", start_folder / "tracks.csv")
    folder = tmp_path / "truth ü"
    folder.mkdir()
    # Started from a third folder with relative names, as a user would.
    monkeypatch.chdir(tmp_path)
    session = Session(read_tracks("run 1/tracks.csv"), Path("truth ü"), Path("run 1/tracks.csv"))
    session.delete(2, 5)
    session.click(1, 6, 100.0, 100.0)
    session.close()
    saved = (folder / "tracks.csv").read_bytes()
    header = (folder / "corrections.txt").read_text().splitlines()[:2]
    assert header[0].endswith(f"in {folder}, apply with")
    (folder / "tracks.csv").unlink()
    command = header[1].removeprefix("#").strip()
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}"}
    result = subprocess.run(command, shell=True, cwd=folder, env=env, capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    assert (folder / "tracks.csv").read_bytes() == saved


# --- 4. workers, escaped text, a client that goes away ---------------------------------------


@pytest.mark.parametrize(
    "command",
    [
        ["run", "{clip}/clip.mp4", "--out", "{out}", "--workers", "1000"],
        ["batch", "{clip}/clip.mp4", "--out", "{out}", "--workers", "1000"],
        ["experiment", "density", "--out", "{out}", "--jobs", "1000", "--tiny"],
    ],
)
def test_more_workers_than_the_machine_can_run_is_one_line(clip, tmp_path, capsys, command):
    import os

    out = tmp_path / "out"
    line = one_line_error(capsys, *[part.format(clip=clip, out=out) for part in command])
    assert "1000 is more than this machine can run: at most" in line and f"{os.cpu_count()} cores" in line
    assert not out.exists()


@pytest.mark.parametrize(
    "content, shown",
    [
        (b"fr\x1b[2Jame,x,y\n0,1,2\n", "found fr\\x1b[2Jame, x, y"),
        (b"frame,x,y\n0,\x01\x07\x1b[31m,2\n", "holds '\\x01\\x07\\x1b[31m'"),
        (b"frame,x,y\n0,1,2\x00\x00\n", None),
        (bytes(range(256)) * 8, None),
        (b"\x7fELF\x02\x01\x01" + bytes(4000), None),
    ],
)
def test_a_binary_file_given_as_csv_is_named_in_printable_text(tmp_path, capsys, content, shown):
    (tmp_path / "points.csv").write_bytes(content)
    line = one_line_error(capsys, "track", tmp_path / "points.csv", "--out", tmp_path / "t.csv")
    assert line.isprintable() and len(line) < 1200, line
    if shown is not None:
        assert shown in line


def test_a_huge_header_makes_a_line_of_bounded_length(tmp_path, capsys):
    (tmp_path / "points.csv").write_text("frame," + "y" * 100_000 + ",x\n0,1,2\n")
    line = one_line_error(capsys, "track", tmp_path / "points.csv", "--out", tmp_path / "t.csv")
    assert "characters left out" in line and len(line) < 1200


def test_a_client_that_goes_away_prints_nothing(annotating, capfd):
    import socket
    import struct
    import time

    for _ in range(5):
        client = socket.create_connection(("127.0.0.1", annotating.port))
        client.sendall(f"GET /api/frame?i=0&token={annotating.token} HTTP/1.1\r\nHost: 127.0.0.1:{annotating.port}\r\n\r\n".encode())
        # Closed at once with a reset: the server's answer meets a connection that is gone.
        client.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
        client.close()
    time.sleep(0.5)
    for error in (BrokenPipeError, ConnectionResetError):
        try:
            raise error(32, "gone")
        except error:
            annotating.handle_error(None, ("127.0.0.1", 1))
    assert capfd.readouterr().err == ""
    assert _post(annotating, "/api/undo", {})[0] == 200, "and the server goes on answering"


# --- 5. a sweep of what a hostile user would try ------------------------------------------------
# Each case makes its inputs in a fresh folder and gives the arguments; the command must end in
# one line and exit 2 (with the words given), or succeed; either way every file that was there
# before is byte-identical after, and a refused command adds none.


def _points(w, name="points.csv", text="frame,x,y\n" + "".join(f"{k},{20 + 15 * i + 3 * k},{30 + 10 * i}\n" for k in range(6) for i in range(5))):
    path = w / name
    path.write_bytes(text.encode() if isinstance(text, str) else text)
    return path


def _clip_copy(w, clip):
    import shutil

    shutil.copy(clip / "clip.mp4", w / "clip.mp4")
    shutil.copy(clip / "truth.csv", w / "truth.csv")
    return w / "clip.mp4"


def _track(w, points_text, *options):
    return ["track", _points(w, text=points_text), "--out", w / "tracks.csv", *options]


def _render(w, clip, *options, out="r.mp4"):
    return ["render", _clip_copy(w, clip), w / "truth.csv", "--out", w / out, *options]


def _correct(w, clip, edits):
    _clip_copy(w, clip)
    (w / "edits.txt").write_bytes(edits)
    return ["correct", w / "truth.csv", w / "edits.txt", "--out", w / "fixed.csv"]


def _run(w, clip, *options):
    return ["run", _clip_copy(w, clip), "--out", w / "out", "--workers", "1", *options]


def _denied(monkeypatch, name):
    import builtins

    real = builtins.open

    def guarded(file, *args, **kwargs):
        if str(file).endswith(name):
            raise PermissionError(errno.EACCES, "Permission denied", str(file))
        return real(file, *args, **kwargs)

    # Tests run as root, whom file modes do not stop: the refusal is made here instead.
    monkeypatch.setattr(builtins, "open", guarded)


def _read_only_folder(monkeypatch):
    import tempfile

    def refused(*args, **kwargs):
        raise PermissionError(errno.EACCES, "Permission denied")

    monkeypatch.setattr(tempfile, "mkstemp", refused)


def _interrupt(monkeypatch, where):
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(where, interrupted)


def _fifo(path):
    import os

    os.mkfifo(path)
    return path


def _loop(path):
    import os

    os.symlink(path.name, path)
    return path


def _after_an_old_run(w, clip, monkeypatch, stage, fault=_interrupt):
    assert main([str(a) for a in _run(w, clip)]) == 0
    fault(monkeypatch, stage)
    return _run(w, clip, "--threshold", "30")


HEADER = "frame,x,y\n"
HOSTILE = {
    # points given to `track`
    "empty file": (lambda w, c, m: _track(w, ""), "is empty"),
    "header only": (lambda w, c, m: _track(w, HEADER), "no points (only a header)"),
    "a folder as the points": (lambda w, c, m: ["track", (w / "p.csv").mkdir() or w / "p.csv", "--out", w / "t.csv"], "is a folder"),
    "points unreadable": (lambda w, c, m: _denied(m, "points.csv") or _track(w, HEADER + "0,1,2\n"), "Permission denied"),
    "unicode path": (lambda w, c, m: ["track", _points(w, "pünkte ✓ 点.csv"), "--out", w / "spür ✓.csv"], "ok"),
    "spaces in paths": (lambda w, c, m: ["track", _points(w, "my points.csv"), "--out", w / "my tracks.csv"], "ok"),
    "x = 1e400 (infinite)": (lambda w, c, m: _track(w, HEADER + "0,1e400,2\n1,2,2\n"), "not a finite number"),
    "negative frame": (lambda w, c, m: _track(w, HEADER + "-1,1,2\n0,2,2\n"), "out of range"),
    "frame 1e12": (lambda w, c, m: _track(w, HEADER + "0,1,2\n1000000000000,2,2\n"), "out of range"),
    "duplicate columns": (lambda w, c, m: _track(w, "frame,x,y,x\n0,1,2,3\n1,2,2,3\n"), "column(s) x appear more than once"),
    "NaN in x": (lambda w, c, m: _track(w, HEADER + "0,nan,2\n1,2,2\n"), "not a finite number"),
    "inf in y": (lambda w, c, m: _track(w, HEADER + "0,1,inf\n1,2,2\n"), "not a finite number"),
    "empty field": (lambda w, c, m: _track(w, HEADER + "0,,2\n1,2,2\n"), "is empty"),
    "CRLF line ends": (lambda w, c, m: _track(w, "frame,x,y\r\n0,1,2\r\n1,2,2\r\n"), "ok"),
    "byte-order mark": (lambda w, c, m: _track(w, "\ufeffframe,x,y\n0,1,2\n1,2,2\n"), "ok"),
    "semicolons": (lambda w, c, m: _track(w, "frame;x;y\n0;1;2\n1;2;2\n"), "missing column"),
    "frame 1.5": (lambda w, c, m: _track(w, HEADER + "0,1,2\n1.5,2,2\n"), "not a whole number"),
    "no y column": (lambda w, c, m: _track(w, "frame,x\n0,1\n"), "missing column"),
    "ragged row": (lambda w, c, m: _track(w, HEADER + "0,1,2,7,8\n1,2,2\n"), "a row has more fields than the header's 3"),
    "a longer row further on": (lambda w, c, m: _track(w, HEADER + "0,1,2\n1,2,2,5\n"), "line 3 has 4 fields, the header has 3"),
    "--max-speed -1": (lambda w, c, m: _track(w, HEADER + "0,1,2\n", "--max-speed", "-1"), "--max-speed"),
    "--max-speed nan": (lambda w, c, m: _track(w, HEADER + "0,1,2\n", "--max-speed", "nan"), "--max-speed"),
    "--max-gap -1": (lambda w, c, m: _track(w, HEADER + "0,1,2\n", "--max-gap", "-1"), "--max-gap"),
    "--phi-max nan": (lambda w, c, m: _track(w, HEADER + "0,1,2\n", "--phi-max", "nan"), "--phi-max"),
    # where the output goes
    "output folder missing": (lambda w, c, m: ["track", _points(w), "--out", w / "no" / "t.csv"], "does not exist"),
    "output folder read-only": (lambda w, c, m: _read_only_folder(m) or ["track", _points(w), "--out", w / "t.csv"], "cannot write here (Permission denied)"),
    "output is a folder": (lambda w, c, m: ["track", _points(w), "--out", (w / "t.csv").mkdir() or w / "t.csv"], "is a folder"),
    "output is a pipe": (lambda w, c, m: ["track", _points(w), "--out", _fifo(w / "t.csv")], "is not a regular file"),
    "disk full": (lambda w, c, m: m.setattr("pandas.DataFrame.to_csv", _no_space) or ["track", _points(w), "--out", w / "t.csv"], "No space left on device"),
    "points are a symlink loop": (lambda w, c, m: ["track", _loop(w / "loop.csv"), "--out", w / "t.csv"], "loop.csv"),
    "points are a pipe": (lambda w, c, m: ["track", _fifo(w / "pipe.csv"), "--out", w / "t.csv"], "not a regular file"),
    "Ctrl-C while tracking": (lambda w, c, m: _interrupt(m, "seedtrack.commands.track.link_points") or ["track", _points(w), "--out", w / "t.csv"], "interrupted"),
    # render
    "--scale nan": (lambda w, c, m: _render(w, c, "--scale", "nan"), "--scale"),
    "--step 0": (lambda w, c, m: _render(w, c, "--step", "0"), "--step must be at least 1"),
    "--trail -1": (lambda w, c, m: _render(w, c, "--trail", "-1"), "--trail"),
    "--crop empty": (lambda w, c, m: _render(w, c, "--crop", "5,5,5,5"), "--crop"),
    "--crop words": (lambda w, c, m: _render(w, c, "--crop", "a,b,c,d"), "--crop"),
    "--end before --start": (lambda w, c, m: _render(w, c, "--start", "5", "--end", "2"), "end must be a frame index after start (5), got 2"),
    "--fps 0": (lambda w, c, m: _render(w, c, "--fps", "0"), "--fps"),
    "--frame past the clip": (lambda w, c, m: _render(w, c, "--frame", "1000000000", out="r.png"), "past the last frame"),
    "output .avi": (lambda w, c, m: _render(w, c, out="r.avi"), "unsupported output extension"),
    "binary tracks": (lambda w, c, m: ["render", _clip_copy(w, c), _points(w, "t.csv", bytes(range(256))), "--out", w / "r.png"], "t.csv"),
    # evaluate, correct
    "--tol 0": (lambda w, c, m: ["evaluate", _clip_copy(w, c) and w / "truth.csv", "--truth", w / "truth.csv", "--tol", "0"], "--tol"),
    "--tol nan": (lambda w, c, m: ["evaluate", _clip_copy(w, c) and w / "truth.csv", "--truth", w / "truth.csv", "--tol", "nan"], "--tol"),
    "edit of no such verb": (lambda w, c, m: _correct(w, c, b"explode 1 2\n"), "unknown edit"),
    "edit at frame -1": (lambda w, c, m: _correct(w, c, b"delete 1 -1\n"), "frame must be >= 0"),
    "edit at x 1e308": (lambda w, c, m: _correct(w, c, b"move 1 2 1e308 5\n"), "out of range"),
    "binary edits": (lambda w, c, m: _correct(w, c, b"\x00\xff\xfe\x1b[2J" * 50), "edits.txt"),
    # run
    "--workers 0": (lambda w, c, m: _run(w, c, "--workers", "0"), "--workers must be a whole number >= 1"),
    "--workers -5": (lambda w, c, m: _run(w, c, "--workers", "-5"), "--workers must be a whole number >= 1"),
    "--workers a million": (lambda w, c, m: _run(w, c, "--workers", "1000000"), "more than this machine can run"),
    "a folder with no images": (lambda w, c, m: ["run", (w / "frames").mkdir() or w / "frames", "--out", w / "out"], "no images"),
    "an empty .mp4": (lambda w, c, m: ["run", _points(w, "e.mp4", b""), "--out", w / "out"], "e.mp4"),
    "text named .mp4": (lambda w, c, m: ["run", _points(w, "t.mp4", "hello\n"), "--out", w / "out"], "t.mp4"),
    "--out is a file": (lambda w, c, m: ["run", _clip_copy(w, c), "--out", w / "truth.csv"], "is not a folder"),
    "--start -1": (lambda w, c, m: _run(w, c, "--start", "-1"), "--start"),
    "a folder named tracks.csv in --out": (lambda w, c, m: (w / "out" / "tracks.csv").mkdir(parents=True) or _run(w, c), "out/tracks.csv: is a folder"),
    "disk full at the commit": (lambda w, c, m: _after_an_old_run(w, c, m, "json.dump", lambda m, where: m.setattr(where, _no_space)), ".seedtrack-commit.json: could not be written (No space left on device)"),
    "--roi radius -5": (lambda w, c, m: _run(w, c, "--roi", "10,10,-5"), "--roi"),
    "--threshold nan": (lambda w, c, m: _run(w, c, "--threshold", "nan"), "--threshold"),
    "Ctrl-C while tracking into an old run's folder": (lambda w, c, m: _after_an_old_run(w, c, m, "seedtrack.pipeline.track_frames"), "interrupted"),
    "Ctrl-C while drawing into an old run's folder": (lambda w, c, m: _after_an_old_run(w, c, m, "seedtrack.pipeline._render"), "interrupted"),
    "disk full in an old run's folder": (lambda w, c, m: _after_an_old_run(w, c, m, "pandas.DataFrame.to_csv", lambda m, where: m.setattr(where, _no_space)), "out/detections.csv: could not be written (No space left on device)"),
    # other commands
    "synth --tracks 0": (lambda w, c, m: ["synth", "psmg", "--out", w / "s", "--tracks", "0"], "--tracks"),
    "synth --frames 1e9": (lambda w, c, m: ["synth", "psmg", "--out", w / "s", "--frames", "1000000000"], "--frames"),
    "demo --seeds ten million": (lambda w, c, m: ["demo", "--out", w / "d", "--seeds", "10000000"], "at most 623 seeds fit on the dish"),
    "annotate --port 70000": (lambda w, c, m: ["annotate", _clip_copy(w, c), "--out", w / "a", "--port", "70000", "--no-browser"], "--port"),
    "TrackMate XML cut short": (lambda w, c, m: ["evaluate", _points(w, "t.xml", "<TrackMate><Model><AllTracks>"), "--truth", _clip_copy(w, c) and w / "truth.csv"], "t.xml"),
    "a track twice in a frame": (lambda w, c, m: ["evaluate", _points(w, "t.csv", "track_id,frame,x,y\n1,0,5,5\n1,0,6,6\n"), "--truth", w / "t.csv"], "t.csv"),
}


@pytest.mark.parametrize("case", list(HOSTILE))
def test_a_hostile_user(clip, tmp_path, capsys, monkeypatch, case):
    make, expected = HOSTILE[case]
    w = tmp_path / "w"
    w.mkdir()
    args = make(w, clip, monkeypatch)
    capsys.readouterr()  # what making the inputs printed
    before = _snapshot(w)
    status, _, err = run(capsys, *args)
    monkeypatch.undo()
    assert "Traceback" not in err, err
    after = _snapshot(w)
    if expected == "ok":
        assert status == 0, err
        assert {name: after[name] for name in before} == before
        return
    lines = err.splitlines()
    assert status == (130 if expected == "interrupted" else 2), err
    assert len(lines) == 1 and ("error:" in lines[0] or expected == "interrupted"), err
    assert lines[0].isprintable() and expected in lines[0], lines[0]
    assert after == before


# Edits a hostile page could send: well-formed ones with numbers at and past every bound, and
# bodies of any JSON type.
_FRAMES = st.one_of(st.sampled_from([-1, 0, 7, 8, 99999, 2**70]), st.integers(0, 7))
_COORDINATES = st.one_of(st.sampled_from([-0.5, -0.6, 319.5, 320, 239.5, 240, 1e308, -1e308, 1e6 + 1]), st.floats(-50, 400))
_IDS = st.one_of(st.integers(0, 10), st.just(2**70))
_JUNK = st.one_of(st.none(), st.text(max_size=3), st.booleans(), st.floats(allow_nan=True, allow_infinity=True), st.integers())
_EDIT = st.one_of(
    st.tuples(st.just("/api/click"), st.fixed_dictionaries({"frame": _FRAMES, "x": _COORDINATES, "y": _COORDINATES}, optional={"selected": _IDS, "reassign": st.booleans()})),
    st.tuples(st.sampled_from(["/api/split", "/api/delete"]), st.fixed_dictionaries({"track": _IDS}, optional={"frame": _FRAMES})),
    st.tuples(st.sampled_from(["/api/undo", "/api/redo"]), st.just({})),
    st.tuples(st.sampled_from(["/api/click", "/api/split", "/api/delete"]), st.dictionaries(st.sampled_from(["frame", "x", "y", "track", "selected"]), _JUNK, max_size=5)),
)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(edits=st.lists(_EDIT, max_size=12))
def test_whatever_the_page_sends_the_session_files_are_read_back(clip, tmp_path_factory, edits):
    from seedtrack.annotate.frames import FrameCache
    from seedtrack.annotate.server import _ACTIONS, AnnotateServer
    from seedtrack.annotate.session import EditRefused, Session
    from seedtrack.rendering import check_fits
    from seedtrack.data.corrections import apply_corrections, read_corrections
    from seedtrack.data.frames import open_frames

    out = tmp_path_factory.mktemp("session")
    start = read_tracks(clip / "truth.csv")
    server = AnnotateServer(Session(start, out, clip / "truth.csv"), FrameCache(clip / "clip.mp4"))
    try:
        for path, body in edits:
            try:
                _ACTIONS[path](server, body)
            except (EditRefused, ValueError, TypeError, KeyError):
                pass  # the server answers 400 or 409 to these
    finally:
        server.session.close()
        server.server_close()
        server.frames.close()
    # What the session wrote, `correct` and `render` read back.
    rebuilt = apply_corrections(start, read_corrections(out / "corrections.txt"), out / "corrections.txt")
    saved = read_tracks(out / "tracks.csv")
    np.testing.assert_allclose(rebuilt.to_rows()["x"], saved.to_rows()["x"], atol=1e-4)
    rows = saved.to_rows()
    with open_frames(clip / "clip.mp4") as source:
        check_fits(out / "tracks.csv", rows["frame"], rows["x"], rows["y"], source, clip / "clip.mp4")
