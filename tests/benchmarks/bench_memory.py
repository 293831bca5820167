"""Peak memory of `seedtrack track` against trackpy's `link` on the same random walkers.

Run as ``python tests/benchmarks/bench_memory.py [--walkers 10000] [--frames 100]``. The walkers
(data/walkers.py, sigma 1.5 px, at the density of 300 walkers in 512 x 512 px) are written to a
points CSV; then each tracker runs in a child process of its own, and the child's peak resident
set size (``ru_maxrss`` from ``os.wait4``) is printed: `seedtrack track POINTS --out tracks.csv`
with no options, and ``trackpy.link`` on the same CSV read with pandas, with a search range of
5 sigma per axis (the speed limit seedtrack measures) and memory 3. Also printed: each child's
CPU seconds, and for scale the peaks of a bare ``python -c "import numpy, scipy, pandas"`` and of
the imports alone of each (the modules `seedtrack track` loads; pandas and trackpy).
Goal (issue #14): seedtrack's peak at or below trackpy's.
"""

from __future__ import annotations

import argparse
import math
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from seedtrack.data.walkers import WalkerSpec, generate_walkers

_BASE_WALKERS, _BASE_SIZE, _SIGMA = 300, 512.0, 1.5

_TRACKPY = """
import sys
import pandas, trackpy
trackpy.quiet()
points = pandas.read_csv(sys.argv[1])
linked = trackpy.link(points, search_range=float(sys.argv[2]), memory=3)
linked.to_csv(sys.argv[3], index=False)
"""


def write_points(path: Path, walkers: int, frames: int, seed: int = 0) -> int:
    """Write the walkers' measured points as frame,x,y; returns the number of rows."""
    size = _BASE_SIZE * math.sqrt(walkers / _BASE_WALKERS)
    points, _ = generate_walkers(WalkerSpec(walkers=walkers, frames=frames, size=size, sigma=_SIGMA, random_seed=seed))
    frame = np.repeat(np.arange(len(points)), [len(p) for p in points])
    xy = np.concatenate(points)
    with open(path, "w", encoding="utf-8") as out:
        out.write("frame,x,y\n")
        np.savetxt(out, np.column_stack((frame, xy)), fmt=["%d", "%.4f", "%.4f"], delimiter=",")
    return int(frame.size)


def peak(command: list[str]) -> tuple[float, float]:
    """Peak resident set size (MB) and CPU seconds of one child process running ``command``."""
    child = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(child.pid, 0)
    child.returncode = os.waitstatus_to_exitcode(status)
    error = child.stderr.read().decode(errors="replace")
    if child.returncode != 0:
        raise SystemExit(f"{' '.join(command[:3])}... failed ({child.returncode}):\n{error}")
    # ru_maxrss is in kilobytes on Linux.
    return usage.ru_maxrss / 1024.0, usage.ru_utime + usage.ru_stime


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--walkers", type=int, default=10_000)
    parser.add_argument("--frames", type=int, default=100)
    args = parser.parse_args()
    # Before the walkers are made: a child's peak counts the pages it shares with this process
    # until it starts its own program, and only these small peaks are below this one's.
    bare, _ = peak([sys.executable, "-c", "import numpy, scipy, pandas"])
    our_imports, _ = peak([sys.executable, "-c", "import seedtrack.cli, seedtrack.commands.track"])
    their_imports, _ = peak([sys.executable, "-c", "import pandas, trackpy"])
    with tempfile.TemporaryDirectory() as folder:
        points = Path(folder) / "points.csv"
        rows = write_points(points, args.walkers, args.frames)
        print(f"{args.walkers} walkers x {args.frames} frames: {rows} points")
        ours, ours_cpu = peak([sys.executable, "-m", "seedtrack", "track", str(points), "--out", str(Path(folder) / "ours.csv")])
        theirs, theirs_cpu = peak([sys.executable, "-c", _TRACKPY, str(points), str(5 * _SIGMA), str(Path(folder) / "trackpy.csv")])
    print(f"{'':24}{'peak RSS MB':>12}{'CPU s':>8}")
    print(f"{'python + numpy/scipy/pandas':24}{bare:12.0f}")
    print(f"{'imports of track':24}{our_imports:12.0f}")
    print(f"{'imports of trackpy':24}{their_imports:12.0f}")
    print(f"{'seedtrack track':24}{ours:12.0f}{ours_cpu:8.1f}")
    print(f"{'trackpy.link':24}{theirs:12.0f}{theirs_cpu:8.1f}")
    print(f"seedtrack / trackpy peak: {ours / theirs:.2f} (goal: at most 1)")


if __name__ == "__main__":
    main()
