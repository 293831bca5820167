"""Where Stone Soup's multi-frame assignment peer stops: time and peak memory per scene size.

    python tests/benchmarks/bench_stonesoup_mfa.py [--limit SECONDS] [POINTS ...]

Runs ``stonesoup_mfa`` once per size on the density sweep's PSMG scene (20 frames, speed 5
px/frame, 200 x 200 px, speed limit 10 px/frame), self-initialised and
with the first links given, each in a fresh process, and prints a markdown table: seconds, peak
resident memory of the process (MB, imports included) and track error. A size that takes longer
than ``--limit`` seconds (default 300) is stopped and the larger ones are not tried.
"""

from __future__ import annotations

import argparse
import multiprocessing
import resource
import sys
import time
from dataclasses import replace

from seedtrack.data.psmg import generate_psmg
from seedtrack.experiments import BASE
from seedtrack.peers import stonesoup_mfa
from seedtrack.tracking.metrics import score_tracks


def _one(points: int, given: bool, queue) -> None:
    spec = replace(BASE, trajectories=points, random_seed=1)
    frames, truth = generate_psmg(spec)
    start = time.perf_counter()
    tracks = stonesoup_mfa(frames, 2 * BASE.mean_speed, 0, truth.measurement[:, :2] if given else None)
    seconds = time.perf_counter() - start
    error = score_tracks(tracks, truth, 0.5).track_error
    queue.put((seconds, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, error))


def measure(points: int, given: bool, limit: float):
    queue = multiprocessing.Queue()
    process = multiprocessing.Process(target=_one, args=(points, given, queue))
    process.start()
    process.join(limit)
    if process.is_alive():
        process.terminate()
        process.join()
        return None
    return queue.get()


def run() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("points", nargs="*", type=int, default=[10, 25, 50, 100])
    parser.add_argument("--limit", type=float, default=300.0)
    args = parser.parse_args()
    print("| points | self-initialised: s, MB, track error | first links given: s, MB, track error |")
    print("| --- | --- | --- |")
    for points in args.points:
        cells, stopped = [], False
        for given in (False, True):
            result = measure(points, given, args.limit)
            if result is None:
                cells.append(f"stopped after {args.limit:.0f} s")
                stopped = True
            else:
                cells.append(f"{result[0]:.1f} s, {result[1]:.0f} MB, {result[2]:.3f}")
        print(f"| {points} | " + " | ".join(cells) + " |", flush=True)
        if stopped:
            break
    return 0


if __name__ == "__main__":
    sys.exit(run())
