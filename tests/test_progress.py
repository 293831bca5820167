"""Progress: bars leave nothing behind in a worker stopped abruptly; a long step says how it goes
in a log, a short one says nothing."""

import itertools
import subprocess
import sys
import time

import numpy as np
import pytest

from seedtrack import progress
from seedtrack.cli import main
from seedtrack.data.csvio import write_table
from seedtrack.data.psmg import PSMGSpec, generate_psmg

_WORKER_STOPPED_ABRUPTLY = """
import multiprocessing, os

def worker():
    from seedtrack.progress import progress_bar
    progress_bar(3, "frames")
    os._exit(0)  # as a batch worker stopped by Ctrl-C, its finalizers not run

if __name__ == "__main__":
    process = multiprocessing.get_context("spawn").Process(target=worker)
    process.start()
    process.join()
"""


def test_a_bar_in_a_worker_stopped_abruptly_leaks_no_semaphore(tmp_path):
    script = tmp_path / "worker.py"
    script.write_text(_WORKER_STOPPED_ABRUPTLY)
    result = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0 and result.stderr == "", result.stderr


@pytest.fixture
def clock(monkeypatch):
    """A clock that moves a second each time it is read, looked at only by the steps' updates."""
    seconds = itertools.count()
    monkeypatch.setattr(progress, "_clock", lambda: float(next(seconds)))
    monkeypatch.setattr(progress, "WATCH_SECONDS", 3600.0)


@pytest.fixture
def points(tmp_path):
    frames, _ = generate_psmg(PSMGSpec(trajectories=10, frames=40, random_seed=2))
    path = tmp_path / "points.csv"
    frame = np.concatenate([np.full(len(p), k) for k, p in enumerate(frames)])
    xy = np.concatenate(frames)
    write_table(path, {"frame": frame, "x": xy[:, 0], "y": xy[:, 1]})
    return path


def test_a_long_step_in_a_log_says_it_started_how_it_goes_and_that_it_ended(points, tmp_path, capsys, monkeypatch, clock):
    # Every tracking step takes a second.
    monkeypatch.delenv("SEEDTRACK_PROGRESS", raising=False)
    assert main(["track", points, "--out", tmp_path / "tracks.csv"]) == 0
    lines = capsys.readouterr().err.splitlines()
    steps = int(lines[-1].split("/")[1].split()[0])
    assert lines[0] == f"tracking: started 3 s ago, 3/{steps} steps ({300 / steps:.0f}%)"
    assert lines[-1] == f"tracking: done, {steps}/{steps} steps (100%) in {steps + 1}.0 s"
    # A line every ten steps between, each one ten seconds after the last.
    assert lines[1:-1] == [f"tracking: {n}/{steps} steps ({100 * n / steps:.0f}%) after {n} s" for n in range(13, steps + 1, 10)]


def test_a_short_step_says_nothing(points, tmp_path, capsys, monkeypatch):
    monkeypatch.delenv("SEEDTRACK_PROGRESS", raising=False)
    assert main(["track", points, "--out", tmp_path / "short.csv"]) == 0
    assert capsys.readouterr().err == ""


def test_none_silences_a_long_step(points, tmp_path, capsys, monkeypatch, clock):
    monkeypatch.setenv("SEEDTRACK_PROGRESS", "none")
    assert main(["track", points, "--out", tmp_path / "silenced.csv"]) == 0
    assert capsys.readouterr().err == ""


def test_a_step_stopped_by_an_error_leaves_the_last_line_to_the_command(capsys, monkeypatch):
    seconds = itertools.count(step=4)
    monkeypatch.setattr(progress, "_clock", lambda: float(next(seconds)))
    monkeypatch.setattr(progress, "WATCH_SECONDS", 3600.0)
    with pytest.raises(KeyError), progress.progress_bar(None, "rendering") as bar:
        bar.set_postfix_str("first frame: measuring spots")
        raise KeyError
    assert capsys.readouterr().err.splitlines() == [
        "rendering: started 4 s ago, 0 frames (first frame: measuring spots)",
    ]


def test_a_long_call_between_updates_still_gets_its_lines(capsys, monkeypatch):
    monkeypatch.setattr(progress, "QUIET_SECONDS", 0.1)
    monkeypatch.setattr(progress, "LINE_SECONDS", 0.2)
    monkeypatch.setattr(progress, "WATCH_SECONDS", 0.01)
    with progress.ProgressLines(10, "tracking", "step") as lines:
        lines.update(10)
        time.sleep(1.0)  # as gap closing after the last pass
    said = capsys.readouterr().err.splitlines()
    assert said[0] == "tracking: started 0 s ago, 10/10 steps (100%)"
    assert said[1].startswith("tracking: 10/10 steps (100%) after ") and said[-1].startswith("tracking: done, 10/10 steps (100%) in ")
    assert 3 <= len(said) <= 7, said  # at most one line each 0.2 s between the first and the last
