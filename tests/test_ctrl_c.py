"""Ctrl-C at a terminal signals every process of the command's group, workers included: the
command alone answers, with one line and exit status 130."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from seedtrack.data.dish import DishSpec, write_dish_clip


def _descendants(pid: int) -> list[int]:
    children = Path(f"/proc/{pid}/task/{pid}/children")
    if not children.exists():
        return []
    found = [int(child) for child in children.read_text().split()]
    return found + [grandchild for child in found for grandchild in _descendants(child)]


def _fork_server(pid: int) -> int | None:
    for child in _descendants(pid):
        try:
            if "forkserver" in Path(f"/proc/{child}/cmdline").read_bytes().decode(errors="replace"):
                return child
        except OSError:
            pass
    return None


def _importing_or_deaf(pid: int) -> bool:
    """Whether the process ignores Ctrl-C (SIGINT, bit 1 of SigIgn) or has begun importing the
    preloads (numpy's libraries mapped)."""
    try:
        ignored = next(line for line in Path(f"/proc/{pid}/status").read_text().splitlines() if line.startswith("SigIgn:"))
        return bool(int(ignored.split()[1], 16) & (1 << (signal.SIGINT - 1))) or "numpy" in Path(f"/proc/{pid}/maps").read_text()
    except (OSError, StopIteration):
        return False


@pytest.mark.skipif(not Path("/proc/self/task").exists(), reason="needs Linux's /proc to see the worker processes")
def test_ctrl_c_while_the_workers_start_is_one_line(tmp_path):
    write_dish_clip(DishSpec(seeds=12, frames=20, width=192, height=160, rim_speed=10.0), tmp_path / "dish")
    command = [sys.executable, "-m", "seedtrack", "run", str(tmp_path / "dish" / "clip.mp4"), "--out", str(tmp_path / "out"), "--workers", "2"]
    # A session of its own, so that the signal goes to the command's group as a terminal sends it.
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    deadline = time.monotonic() + 60
    # The fork server imports numpy, OpenCV and PyAV before it forks a worker (a second or more):
    # Ctrl-C then used to print its traceback beside the command's line.
    while process.poll() is None and time.monotonic() < deadline:
        server = _fork_server(process.pid)
        if server is not None and _importing_or_deaf(server):
            break
        time.sleep(0.005)
    else:
        pytest.fail(f"no fork server started: {process.communicate()}")
    os.killpg(process.pid, signal.SIGINT)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 130
    assert err.splitlines() == ["seedtrack run: interrupted; files already written are complete"]
