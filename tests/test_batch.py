"""``seedtrack batch`` against a Dask scheduler started here, on 127.0.0.1 with two worker processes."""

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from seedtrack.cli import main
from seedtrack.commands import batch as batch_command
from seedtrack.data.csvio import read_table
from seedtrack.data.dish import DishSpec, write_dish_clip

distributed = pytest.importorskip("distributed")

FILES = ("detections.csv", "tracks.csv", "overlay.mp4")


@pytest.fixture(scope="module")
def scheduler():
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address="127.0.0.1:0"
    ) as cluster:
        yield cluster.scheduler_address


@pytest.fixture(scope="module")
def clips(tmp_path_factory):
    folder = tmp_path_factory.mktemp("clips")
    for name, seed in (("first", 1), ("second", 2)):
        write_dish_clip(DishSpec(seeds=12, frames=6, width=192, height=160, rim_speed=10.0, random_seed=seed), folder / name)
        shutil.move(folder / name / "clip.mp4", folder / f"{name}.mp4")
    (folder / "broken.mp4").write_bytes(b"not a video at all")
    return folder


def test_each_clip_gets_the_files_run_writes(scheduler, clips, tmp_path, capsys):
    inputs = [str(clips / "first.mp4"), str(clips / "broken.mp4"), str(clips / "second.mp4")]
    assert main(["batch", *inputs, "--out", str(tmp_path / "batch"), "--scheduler", scheduler]) == 1
    for name in ("first", "second"):
        assert main(["run", str(clips / f"{name}.mp4"), "--out", str(tmp_path / "run" / name)]) == 0
        for file in FILES:
            assert (tmp_path / "batch" / name / file).read_bytes() == (tmp_path / "run" / name / file).read_bytes(), (name, file)
    table = read_table(tmp_path / "batch" / "batch.csv", others_as_text=True)
    assert list(table["input"]) == inputs
    assert list(table["status"]) == ["done", "failed", "done"]
    assert list(table["frames"]) == ["6", "0", "6"]
    assert "broken.mp4: not a video" in table["error"][1] and table["error"][0] == ""
    assert not (tmp_path / "batch" / "broken").exists()
    said = capsys.readouterr()
    assert "broken.mp4: not a video" in said.err and "Traceback" not in said.err
    # A line per clip done, with how it was detected and tracked.
    lines = [line for line in said.out.splitlines() if line.startswith(inputs[0] + ": 6 frames")]
    assert len(lines) == 1 and "detector: " in lines[0] and "motion: " in lines[0], said.out


def test_a_rerun_skips_the_clips_done_and_retries_the_failed(scheduler, clips, tmp_path):
    out = tmp_path / "batch"
    inputs = [str(clips / "first.mp4"), str(clips / "broken.mp4")]
    assert main(["batch", *inputs, "--out", str(out), "--scheduler", scheduler]) == 1
    overlay = out / "first" / "overlay.mp4"
    written = overlay.stat().st_mtime_ns
    first = read_table(out / "batch.csv", others_as_text=True)
    assert main(["batch", *inputs, str(clips / "second.mp4"), "--out", str(out), "--scheduler", scheduler]) == 1
    table = read_table(out / "batch.csv", others_as_text=True)
    assert list(table["status"]) == ["skipped", "failed", "done"]
    # A skipped clip reports what its finished run found.
    assert (table["frames"][0], table["tracks"][0]) == (first["frames"][0], first["tracks"][0]) != ("0", "0")
    assert overlay.stat().st_mtime_ns == written


def test_other_options_redo_a_clip(scheduler, clips, tmp_path):
    out = tmp_path / "batch"
    assert main(["batch", str(clips / "first.mp4"), "--out", str(out), "--scheduler", scheduler]) == 0
    assert main(["batch", str(clips / "first.mp4"), "--out", str(out), "--scheduler", scheduler, "--min-length", "4"]) == 0
    assert list(read_table(out / "batch.csv", others_as_text=True)["status"]) == ["done"]


def test_two_inputs_of_one_name_are_refused(clips, tmp_path, capsys):
    (clips / "again").mkdir(exist_ok=True)
    shutil.copy(clips / "first.mp4", clips / "again" / "first.mp4")
    assert main(["batch", str(clips / "first.mp4"), str(clips / "again" / "first.mp4"), "--out", str(tmp_path / "b")]) == 2
    assert "would both write to DIR/first/" in capsys.readouterr().err
    assert not (tmp_path / "b").exists()


def test_an_unreachable_scheduler_is_one_line(clips, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(batch_command, "CONNECT_TIMEOUT", "1s")
    assert main(["batch", str(clips / "first.mp4"), "--out", str(tmp_path / "b"), "--scheduler", "tcp://127.0.0.1:9"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "cannot reach a Dask scheduler" in err


def test_ctrl_c_stops_with_one_line_and_keeps_finished_clips(tmp_path):
    # A local cluster of one worker, started by the command; interrupted after the first clip.
    for index in range(4):
        write_dish_clip(DishSpec(seeds=12, frames=30, width=192, height=160, rim_speed=10.0, random_seed=index), tmp_path / f"c{index}")
    inputs = [tmp_path / f"c{index}" / "clip.mp4" for index in range(4)]
    for index, clip in enumerate(inputs):
        clip.rename(tmp_path / f"c{index}.mp4")
    out = tmp_path / "out"
    command = [sys.executable, "-m", "seedtrack", "batch", *(str(tmp_path / f"c{i}.mp4") for i in range(4)), "--out", str(out), "--workers", "1"]
    # Progress lines in a log, on a slow machine, are not this test's matter.
    quiet = {**os.environ, "SEEDTRACK_PROGRESS": "none"}
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=quiet)
    deadline = time.monotonic() + 120
    while not (out / "batch.csv").exists() and time.monotonic() < deadline and process.poll() is None:
        time.sleep(0.05)
    process.send_signal(signal.SIGINT)
    stdout, stderr = process.communicate(timeout=60)
    assert process.returncode == 130, stderr
    assert stderr.strip().splitlines() == ["seedtrack batch: interrupted; files already written are complete"]
    table = read_table(out / "batch.csv", others_as_text=True)
    assert 1 <= len(table["status"]) < 4 and set(table["status"]) == {"done"}
    for clip in table["input"]:
        assert (out / Path(clip).stem / "overlay.mp4").is_file()
