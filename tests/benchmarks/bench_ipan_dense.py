"""``seedtrack track --algorithm ipan`` with no speed limit on dense input (issue 18).

Issue 18 asks for 100 points at 12 px/frame over 20 frames within 10 s. Without a limit, IPAN's
search radius is estimated from GOA-updown's links, which on random walkers is many times the
true speed, so that every point of a frame is a candidate of every other; this prints the CPU
time of the whole command (reading, estimating, tracking, writing) on random walkers (12 px/frame
steps) in a 200 px and a 400 px view, and on PSMG's smooth trajectories at 12 px/frame, with the
link error against the truth.

    python tests/benchmarks/bench_ipan_dense.py
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np

from seedtrack.cli import main
from seedtrack.data.csvio import write_table
from seedtrack.data.psmg import PSMGSpec, generate_psmg
from seedtrack.data.trackfile import read_tracks
from seedtrack.data.walkers import WalkerSpec, generate_walkers
from seedtrack.tracking.metrics import score_tracks


def scenes():
    for size in (200.0, 400.0):
        yield f"random walkers, {size:g} px view", generate_walkers(WalkerSpec(walkers=100, frames=20, size=size, sigma=12 / np.sqrt(2), random_seed=1))
    yield "PSMG, 400 px view", generate_psmg(PSMGSpec(trajectories=100, frames=20, size=400, mean_speed=12, random_seed=1))


def main_() -> None:
    with tempfile.TemporaryDirectory() as folder:
        for name, (frames, truth) in scenes():
            points = Path(folder) / "points.csv"
            xy = np.concatenate(frames)
            write_table(points, {"frame": np.repeat(np.arange(len(frames)), [len(f) for f in frames]), "x": xy[:, 0], "y": xy[:, 1]})
            out = Path(folder) / "tracks.csv"
            start = time.process_time()
            assert main(["track", str(points), "--out", str(out), "--algorithm", "ipan"]) == 0
            seconds = time.process_time() - start
            scores = score_tracks(read_tracks(out), truth, 1.0)
            print(f"{name:32s} {xy.shape[0] / len(frames):5.1f} points/frame  {seconds:5.2f} s CPU  link error {scores.link_error:.3f}")


if __name__ == "__main__":
    main_()
