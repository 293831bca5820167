"""Held-out motion of issue 29: kinds no default was tuned on, seedtrack beside its peers, a
one-step oracle, and the CPU each takes.

Run as ``python tests/benchmarks/bench_unseen.py [--seeds reporting|tuning] [--only WORD]
[--trackers a,b]``. Scenes come from :mod:`seedtrack.data.unseen` (oscillators about fixed
sites, run-and-tumble, walkers abreast seen every second frame, a crowded swarm, whole-pixel
positions, objects that leave while others enter). Seeds were split before anything was looked
at: tuning 0-4, reporting 1000-1004 (the table printed by default).

Each cell: strict trajectory merit / IDF1 / link error (mean over the clips, tolerance 0.5 px),
then the CPU seconds of the five clips. seedtrack runs as ``seedtrack track`` does, with no
options. trackpy (plain and with ``NearestVelocityPredict``) and laptrack are given the true
fastest speed v of each scene and run at search range 1.0, 1.3 and 1.6 v; the cell shows their
best (by strict merit plus IDF1) and the factor in brackets; memory 0 (no point is missed). The
oracle is told the truth up to frame t and picks frame t + 1's links by one optimal assignment
under each true track's own linear motion model (x[t + 1] = a x[t] + b x[t - 1] + c) and
noise, fitted to its whole true path (squared Mahalanobis distance, unassigned beyond 5 sigma): what one-step linking could do with the true motion known.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from seedtrack.data.unseen import UnseenSpec, generate_unseen
from seedtrack.peers import PEERS, PeerFailure, trackpy_linker
from seedtrack.tracking.clear_mot import clear_mot
from seedtrack.tracking.linking import link_goa
from seedtrack.tracking.metrics import score_tracks
from seedtrack.tracking.tracks import NO_MEASUREMENT, Tracks
from tables import write_table

TOLERANCE = 0.5
SEED_SETS = {"tuning": range(0, 5), "reporting": range(1000, 1005)}
SWEEP = (1.0, 1.3, 1.6)
ORACLE_GATE = 5.0


@dataclass(frozen=True)
class Scene:
    label: str
    spec: dict

    def draw(self, seed: int):
        return generate_unseen(UnseenSpec(**self.spec, random_seed=seed))


SCENES = (
    Scene("oscillate 100, 4 px/f", dict(kind="oscillate", points=100, speed=4.0)),
    Scene("oscillate 100, 9 px/f", dict(kind="oscillate", points=100, speed=9.0)),
    Scene("tumble 100, 4 px/f", dict(kind="tumble", points=100, speed=4.0)),
    Scene("abreast 60, every 2nd frame, 6 px/f", dict(kind="side_by_side", points=60, speed=6.0, spacing=5.0, size=300.0)),
    Scene("swarm 150 in 80 px, 4 px/f", dict(kind="swarm", points=150, speed=4.0, size=80.0, frames=20)),
    Scene("whole pixels 100, 1 px/f", dict(kind="whole_pixel", points=100, speed=1.0, noise=0.3)),
    Scene("relay 40 at a time, 3 px/f", dict(kind="relay", points=40, speed=3.0, size=300.0, frames=40)),
)


def fastest(tracks: Tracks) -> float:
    """Fastest step between consecutive measured points of one track, pixels/frame."""
    measured = tracks.present & (tracks.measurement != NO_MEASUREMENT)
    step = np.diff(tracks.xy, axis=1)[measured[:, 1:] & measured[:, :-1]]
    return float(np.hypot(*step.T).max(initial=0.0))


def oracle(frames: list[np.ndarray], truth: Tracks) -> Tracks:
    """One-step oracle: at each t, each true track predicts t + 1 by its own linear motion model
    (x[t + 1] = a x[t] + b x[t - 1] + c, fitted by least squares on its whole true path: constant
    velocity, a random walk, an oscillation about a site are all of this form), with its own
    residual variance, and one optimal assignment links t's points to t + 1's."""
    xy, measured = truth.xy, truth.present & (truth.measurement != NO_MEASUREMENT)
    index = truth.measurement
    model = np.tile([2.0, -1.0, 0.0, 0.0], (truth.n_tracks, 1))
    sigma2 = np.full(truth.n_tracks, np.nan)
    for i in range(truth.n_tracks):
        t = np.flatnonzero(measured[i, 2:] & measured[i, 1:-1] & measured[i, :-2]) + 2
        if t.size >= 8:
            design = np.zeros((2 * t.size, 4))
            design[:, 0] = xy[i, t - 1].T.ravel()
            design[:, 1] = xy[i, t - 2].T.ravel()
            design[: t.size, 2] = design[t.size :, 3] = 1.0
            model[i] = np.linalg.lstsq(design, xy[i, t].T.ravel(), rcond=None)[0]
        if t.size:
            predicted = model[i, 0] * xy[i, t - 1] + model[i, 1] * xy[i, t - 2] + model[i, 2:]
            sigma2[i] = np.mean((xy[i, t] - predicted) ** 2)
    sigma2 = np.maximum(np.where(np.isnan(sigma2), np.nanmedian(sigma2) if (~np.isnan(sigma2)).any() else 1.0, sigma2), 1e-2)
    steps = np.diff(xy, axis=1)[measured[:, 1:] & measured[:, :-1]]
    spread2 = max(float(np.mean(steps**2)) if steps.size else 1.0, 1e-2)
    successor = [np.full(f.shape[0], -1, np.int64) for f in frames]
    for t in range(len(frames) - 1):
        rows = np.flatnonzero(measured[:, t])
        if not rows.size or not frames[t + 1].shape[0]:
            continue
        moving = (t > 0) & measured[rows, t - 1] if t else np.zeros(rows.size, bool)
        m = model[rows]
        fitted = m[:, :1] * xy[rows, t] + m[:, 1:2] * xy[rows, max(t - 1, 0)] + m[:, 2:]
        predicted = np.where(moving[:, None], fitted, xy[rows, t])
        variance = np.where(moving, sigma2[rows], spread2)
        cost = ((predicted[:, None, :] - frames[t + 1][None, :, :]) ** 2).sum(axis=2) / variance[:, None]
        gate = ORACLE_GATE**2
        padded = np.full((rows.size, frames[t + 1].shape[0] + rows.size), 2 * gate)
        padded[:, : frames[t + 1].shape[0]] = np.where(cost <= gate, cost, 1e12)
        r, c = linear_sum_assignment(padded)
        keep = c < frames[t + 1].shape[0]
        keep &= padded[r, c] < 1e12
        successor[t][index[rows[r[keep]], t]] = c[keep]
    track_of = [np.full(f.shape[0], -1, np.int64) for f in frames]
    ids, frame_of, points = [], [], []
    fresh = 0
    for t, f in enumerate(frames):
        for i in range(f.shape[0]):
            if track_of[t][i] < 0:
                track_of[t][i] = fresh
                fresh += 1
            if t + 1 < len(frames) and successor[t][i] >= 0:
                track_of[t + 1][successor[t][i]] = track_of[t][i]
        ids.append(track_of[t])
        frame_of.append(np.full(f.shape[0], t))
        points.append(f)
    xy_all = np.concatenate(points)
    return Tracks.from_rows(np.concatenate(ids), np.concatenate(frame_of), xy_all[:, 0], xy_all[:, 1])


def _peer(name: str):
    if name == "laptrack":
        return lambda frames, limit: PEERS["laptrack"](frames, limit, 0)
    return lambda frames, limit: trackpy_linker(name.split()[-1] if " " in name else "plain")(frames, limit, 0)


TRACKERS = ("seedtrack", "trackpy", "trackpy predict", "laptrack", "oracle")


def _scores(tracks: Tracks, truth: Tracks) -> tuple[float, float, float]:
    s = score_tracks(tracks, truth, TOLERANCE)
    return s.correct_tracks / s.true_tracks, clear_mot(tracks, truth, TOLERANCE).idf1, s.link_error


def run_cell(name: str, clips, limits, peer=_peer) -> tuple[tuple[float, float, float], float, str]:
    """Mean (strict merit, IDF1, link error) over the clips, CPU seconds, and a note; ``peer``
    makes the peer's tracker from its name."""
    if name in ("seedtrack", "oracle"):
        started = time.process_time()
        tracks = [link_goa(f)[0] if name == "seedtrack" else oracle(f, t) for f, t in clips]
        cpu = time.process_time() - started
        scores = [_scores(r, t) for r, (_, t) in zip(tracks, clips)]
        return tuple(statistics.mean(s[i] for s in scores) for i in range(3)), cpu, ""
    best = None
    for factor in SWEEP:
        started = time.process_time()
        try:
            tracks = [peer(name)(f, factor * v) for (f, _), v in zip(clips, limits)]
        except PeerFailure:
            continue
        cpu = time.process_time() - started
        scores = [_scores(r, t) for r, (_, t) in zip(tracks, clips)]
        mean = tuple(statistics.mean(s[i] for s in scores) for i in range(3))
        if best is None or mean[0] + mean[1] > best[0][0] + best[0][1]:
            best = (mean, cpu, f"{factor:g} v")
    return best if best is not None else ((float("nan"),) * 3, float("nan"), "gave up")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", choices=tuple(SEED_SETS), default="reporting")
    parser.add_argument("--only", default="", help="scenes whose label contains this")
    parser.add_argument("--trackers", default="", help="comma-separated tracker names (default all)")
    parser.add_argument("--write-docs", action="store_true", help="write the table into docs/motion.md, stamped (table unseen)")
    args = parser.parse_args()
    names = [n for n in args.trackers.split(",") if n] or list(TRACKERS)
    seeds = SEED_SETS[args.seeds]
    print(f"{args.seeds} seeds {seeds.start}-{seeds.stop - 1}; cells: strict merit / IDF1 / link error (mean of {len(seeds)} clips), CPU s of all clips; peers at their best search range [factor of the true fastest speed v]")
    print("| scene | points | v | " + " | ".join(names) + " |")
    print("| --- | --- | --- |" + " --- |" * len(names))
    totals: dict[str, list[float]] = {n: [] for n in names}
    rows = []
    for scene in SCENES:
        if args.only not in scene.label:
            continue
        clips = [scene.draw(seed) for seed in seeds]
        limits = [fastest(t) for _, t in clips]
        points = sum(sum(f.shape[0] for f in frames) for frames, _ in clips)
        cells = []
        for name in names:
            (merit, idf1, link), cpu, note = run_cell(name, clips, limits)
            totals[name].append(cpu / points)
            cells.append(f"{merit:.3f} / {idf1:.3f} / {link:.3f}, {cpu:.2f} s" + (f" [{note}]" if note else ""))
            print(f"  {scene.label} {name}: {cells[-1]}", file=sys.stderr, flush=True)
        rows.append([scene.label, points, f"{statistics.mean(limits):.1f}", *cells])
        print(f"| {scene.label} | {points} | {statistics.mean(limits):.1f} | " + " | ".join(cells) + " |", flush=True)
    cost = "CPU microseconds per point, median over scenes (max): " + ", ".join(
        f"{n} {1e6 * statistics.median(c):.0f} ({1e6 * max(c):.0f})" for n, c in totals.items() if c
    )
    print("\n" + cost)
    if args.write_docs:
        write_table("motion.md", "unseen", ["scene", "points", "v", *names], rows, note=cost + ".")


if __name__ == "__main__":
    main()
