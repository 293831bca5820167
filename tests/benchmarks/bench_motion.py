"""Default options against trackpy and laptrack, from random walkers to a turning dish.

Run as ``python tests/benchmarks/bench_motion.py [--runs N] [--seeds reporting|tuning]
[--only WORD]``. Each scene is generated N times, from the reporting random seeds (1000, 1001,
...) or the tuning ones (0, 1, ...) that defaults may be looked at on. seedtrack runs as ``seedtrack track`` does with no option at all (it measures the
motion, then tracks open GOA-updown); trackpy (``link``, memory 0 and 3) and laptrack (gap closing
over 2 frames) are given the speed limit a user who knows the data would choose: 4 sigma plus the
drift for walkers, the generator's speed limit for PSMG, 1.1 x the rim speed for the dish. Prints
the median IDF1 and link error (tolerance 1 px) and the median CPU seconds per run (medians over
runs) of each tracker on each scene; ``--write-docs`` also writes the table into
docs/benchmarks.md (table ``motion``), stamped.
"""

from __future__ import annotations

import argparse
import statistics
import time
from typing import Callable

import numpy as np

from seedtrack.peers import PEERS, PeerFailure, trackpy_linker
from seedtrack.data.dish import DishSpec, make_dish_scene
from seedtrack.data.psmg import PSMGSpec, generate_psmg
from seedtrack.data.walkers import WalkerSpec, generate_walkers
from seedtrack.tracking.clear_mot import clear_mot
from seedtrack.tracking.goa import GOAConfig
from seedtrack.tracking.linking import link_goa
from seedtrack.tracking.metrics import score_tracks
from seedtrack.tracking.tracks import Tracks
from tables import write_table

Scene = tuple[list[np.ndarray], Tracks, float]
SEED_SETS = {"tuning": 0, "reporting": 1000}


def walkers(**options) -> Callable[[int], Scene]:
    def make(seed: int) -> Scene:
        spec = WalkerSpec(random_seed=seed, **options)
        frames, truth = generate_walkers(spec)
        return frames, truth, 4 * spec.sigma + float(np.hypot(*spec.drift))

    return make


def psmg(**options) -> Callable[[int], Scene]:
    def make(seed: int) -> Scene:
        spec = PSMGSpec(random_seed=seed, **options)
        frames, truth = generate_psmg(spec)
        return frames, truth, spec.speed_limit

    return make


def dish(**options) -> Callable[[int], Scene]:
    def make(seed: int) -> Scene:
        spec = DishSpec(seeds=80, frames=20, rim_speed=42.0, random_seed=seed, **options)
        scene = make_dish_scene(spec)
        frames = scene.visible_points()
        return frames, scene.truth, 1.1 * spec.rim_speed

    return make


SCENES: dict[str, Callable[[int], Scene]] = {
    "brownian sigma 0.5": walkers(sigma=0.5),
    "brownian sigma 1.5": walkers(sigma=1.5),
    "brownian sigma 3": walkers(sigma=3.0),
    "brownian sigma 1.5, 5% missed": walkers(sigma=1.5, missed=0.05),
    "flow 3 px/frame + sigma 1": walkers(sigma=1.0, drift=(3.0, 0.0)),
    "PSMG 100 points, speed 5": psmg(trajectories=100, frames=20),
    "PSMG entry/exit, 10% missed": psmg(trajectories=100, frames=20, entry_exit=True, occlusion=0.1),
    "dish 80 seeds, rim 42": dish(),
    "dish 80 seeds, rim 42, 5% missed": dish(hidden_probability=0.05),
}


def seedtrack_default(frames: list[np.ndarray], _limit: float) -> Tracks:
    """What ``seedtrack track`` does with no options (the motion line of every run unsaid)."""
    return link_goa(frames, "goa-updown", GOAConfig())[0]


TRACKERS: dict[str, Callable[[list[np.ndarray], float], Tracks]] = {
    "seedtrack (no options)": seedtrack_default,
    "trackpy": lambda frames, limit: PEERS["trackpy"](frames, limit, 0),
    "trackpy memory 3": lambda frames, limit: trackpy_linker("plain", memory=3)(frames, limit, 0),
    "laptrack": lambda frames, limit: PEERS["laptrack"](frames, limit, 0),
}


def measure_runs(track: Callable, scenes: list[Scene], measures: tuple[Callable[[Tracks, Tracks], float], ...]) -> tuple[list[list[float]], list[float]]:
    """Each measure's values over the ``(frames, truth, limit)`` scenes and the CPU seconds of
    ``track`` on each, leaving out the runs a peer could not finish."""
    values: list[list[float]] = [[] for _ in measures]
    seconds = []
    for frames, truth, limit in scenes:
        start = time.process_time()
        try:
            result = track(frames, limit)
        except PeerFailure:
            continue
        seconds.append(time.process_time() - start)
        for column, measure in zip(values, measures):
            column.append(measure(result, truth))
    return values, seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--seeds", choices=tuple(SEED_SETS), default="reporting")
    parser.add_argument("--only", default="", help="scenes whose name contains this")
    parser.add_argument("--write-docs", action="store_true", help="write the table into docs/benchmarks.md, stamped")
    args = parser.parse_args()
    first = SEED_SETS[args.seeds]
    print(f"| scene | tracker | IDF1 | link error | CPU s |  (medians of {args.runs} runs, {args.seeds} seeds {first}..{first + args.runs - 1})")
    print("|---|---|---|---|---|")
    rows = []
    for scene_name, make in SCENES.items():
        if args.only not in scene_name:
            continue
        scenes = [make(seed) for seed in range(first, first + args.runs)]
        for tracker_name, track in TRACKERS.items():
            (idf1, link), seconds = measure_runs(track, scenes, (lambda tracks, truth: clear_mot(tracks, truth, 1.0).idf1, lambda tracks, truth: score_tracks(tracks, truth, 1.0).link_error))
            if not idf1:
                rows.append([scene_name, tracker_name, "failed", "failed", ""])
            else:
                failed = f" ({args.runs - len(idf1)} failed)" if len(idf1) < args.runs else ""
                rows.append([scene_name, tracker_name, f"{statistics.median(idf1):.3f}{failed}", f"{statistics.median(link):.4f}", f"{statistics.median(seconds):.2f}"])
            print("| " + " | ".join(rows[-1]) + " |", flush=True)
    if args.write_docs:
        write_table("benchmarks.md", "motion", ["scene", "tracker", "IDF1", "link error", "CPU s"], rows)


if __name__ == "__main__":
    main()
