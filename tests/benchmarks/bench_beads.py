"""Bead-like random walkers among faint extra points: seedtrack's defaults against trackpy and laptrack.

Run as ``python tests/benchmarks/bench_beads.py [--runs N] [--seeds reporting|tuning] [--only WORD]``.
A generated stand-in for bead footage (``shared/data/bulk-water-240-479.mp4``), made from what the
confident tracks there show (``tests/benchmarks/bench_bulk_water.py``): beads differ in how much they
move (each walker's step sigma is the scene's times a log-normal factor; on bulk water a track's mean
squared step in its first half predicts its second half, correlation 0.62 of the logs), a detection
sometimes jumps 2-4 px off the bead (out of focus), and faint spots come and go near the beads
(satellites 4-8 px from a bead that follow it for a few frames) and apart (short-lived faint walkers).
Only the walkers are scored, within 1 px: the link error, and the share of walkers in view for 25
frames or more of which one track holds at least 80% of the measured points (*reproduced*, as on
bulk water). trackpy (memory 3) and laptrack are given the speed limit 4 sigma of the most mobile
beads (the scene's sigma times e^(2 x log-sd)). Prints medians over runs, and CPU seconds.
"""

from __future__ import annotations

import argparse
import statistics
from typing import Callable

import numpy as np

from bench_motion import SEED_SETS, TRACKERS as MOTION_TRACKERS, measure_runs
from seedtrack.tracking.metrics import UNMATCHED, match_points, score_tracks, true_track_owners
from seedtrack.tracking.tracks import Tracks

# A confident track: in view this many frames; reproduced when one track holds this share of it.
CONFIDENT_FRAMES = 25
REPRODUCED_SHARE = 0.8


def bead_scene(
    seed: int, sigma: float = 0.6, spread: float = 0.6, missed: float = 0.05, jump: float = 0.02, satellites: float = 0.15,
    faint: float = 0.5, walkers: int = 300, frames: int = 60, size: float = 512.0, margin: float = 20.0,
) -> tuple[list[np.ndarray], Tracks, float]:
    """Measured points per frame (walkers and extras, shuffled), the walkers' truth, a speed limit.

    ``sigma`` step sigma, pixels/frame, per axis, times a log-normal factor of log-sd ``spread``
    per walker; ``missed`` share of walker positions unmeasured; ``jump`` share of them displaced
    2-4 px; ``satellites`` new satellites per walker a frame (4-8 px away, following it with
    0.3 px jitter for a geometric life of mean 3 frames); ``faint`` faint walkers alive per walker
    (2-10 frames each, step sigma ``sigma``). The truth holds each walker's measured position.

    Example
    -------
    >>> frames, truth, limit = bead_scene(1, walkers=20, frames=5)
    >>> len(frames), truth.n_tracks <= 20
    (5, True)
    """
    rng = np.random.default_rng(seed)
    own = sigma * np.exp(rng.normal(0.0, spread, walkers))
    steps = rng.normal(0.0, 1.0, (walkers, frames, 2)) * own[:, None, None]
    steps[:, 0] = 0.0
    xy = rng.uniform(-margin, size + margin, (walkers, 1, 2)) + np.cumsum(steps, axis=1)
    inside = ((xy >= 0) & (xy < size)).all(axis=2)
    seen = inside & (rng.random(inside.shape) >= missed)
    shown = xy.copy()
    jumped = rng.random(inside.shape) < jump
    radius, angle = rng.uniform(2.0, 4.0, inside.shape), rng.uniform(0.0, 2.0 * np.pi, inside.shape)
    shown[jumped] += np.stack((radius * np.cos(angle), radius * np.sin(angle)), axis=-1)[jumped]
    extra: list[list[np.ndarray]] = [[] for _ in range(frames)]
    for walker, start in zip(*np.nonzero((rng.random(inside.shape) < satellites) & inside)):
        radius, angle = rng.uniform(4.0, 8.0), rng.uniform(0.0, 2.0 * np.pi)
        offset = radius * np.array([np.cos(angle), np.sin(angle)])
        for k in range(start, min(start + rng.geometric(1.0 / 3.0), frames)):
            if not inside[walker, k]:
                break
            extra[k].append(xy[walker, k] + offset + rng.normal(0.0, 0.3, 2))
    for _ in range(int(faint * walkers * frames / 6.0)):
        start, life, point = rng.integers(0, frames), rng.integers(2, 11), rng.uniform(0.0, size, 2)
        for k in range(start, min(start + life, frames)):
            extra[k].append(point.copy())
            point += rng.normal(0.0, sigma, 2)
    measurement = np.full(inside.shape, -1, dtype=np.int64)
    points = []
    for k in range(frames):
        who = np.flatnonzero(seen[:, k])
        together = np.concatenate((shown[who, k], np.array(extra[k]).reshape(-1, 2)))
        order = rng.permutation(together.shape[0])
        place = np.empty_like(order)
        place[order] = np.arange(order.size)
        measurement[who, k] = place[: who.size]
        points.append(together[order])
    truth = np.where(inside[..., None], np.where(seen[..., None], shown, xy), np.nan)
    ever = inside.any(axis=1)
    return points, Tracks.from_dense(truth[ever], measurement[ever]), 4.0 * sigma * float(np.exp(2.0 * spread))


def reproduced(result: Tracks, truth: Tracks) -> float:
    """Share of the true tracks measured in at least 25 frames of which one result track holds at
    least 80% of the measured points within 1 px."""
    owner = true_track_owners(match_points(result, truth, 1.0), result, truth)
    measured = truth.present & ~truth.interpolated
    held = []
    for track in np.flatnonzero(measured.sum(axis=1) >= CONFIDENT_FRAMES):
        owners = owner[track, measured[track]]
        owners = owners[owners != UNMATCHED]
        held.append(owners.size > 0 and np.bincount(owners).max() >= REPRODUCED_SHARE * measured[track].sum())
    return float(np.mean(held)) if held else 0.0


SCENES: dict[str, dict] = {
    "sigma 0.6 x log-normal 0.6, 5% missed, 2% jumps": {},
    "sigma 1 x log-normal 0.4, 10% missed, 3% jumps, twice the extras": dict(sigma=1.0, spread=0.4, missed=0.1, jump=0.03, satellites=0.3, faint=1.0),
    "sigma 0.6, all alike, 5% missed, no jumps": dict(spread=0.0, jump=0.0),
}

TRACKERS: dict[str, Callable[[list[np.ndarray], float], Tracks]] = {
    name: MOTION_TRACKERS[name] for name in ("seedtrack (no options)", "trackpy memory 3", "laptrack")
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--seeds", choices=tuple(SEED_SETS), default="reporting")
    parser.add_argument("--only", default="", help="trackers whose name contains this")
    args = parser.parse_args()
    first = SEED_SETS[args.seeds]
    print(f"| scene | points a frame | tracker | link error | reproduced | CPU s |  (medians of {args.runs} runs, {args.seeds} seeds {first}..{first + args.runs - 1})")
    print("|---|---|---|---|---|---|")
    for scene_name, options in SCENES.items():
        scenes = [bead_scene(seed, **options) for seed in range(first, first + args.runs)]
        per_frame = statistics.median(sum(f.shape[0] for f in frames) / len(frames) for frames, _, _ in scenes)
        for tracker_name, track in TRACKERS.items():
            if args.only not in tracker_name:
                continue
            (link, share), seconds = measure_runs(track, scenes, (lambda tracks, truth: score_tracks(tracks, truth, 1.0).link_error, reproduced))
            if not link:
                print(f"| {scene_name} | {per_frame:.0f} | {tracker_name} | failed | failed | |")
                continue
            print(
                f"| {scene_name} | {per_frame:.0f} | {tracker_name} | {statistics.median(link):.4f} | {statistics.median(share):.3f} | {statistics.median(seconds):.1f} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
