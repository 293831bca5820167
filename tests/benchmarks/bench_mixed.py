"""Motion states per track (issue 29 item 3): scenes that mix smooth movers, random walkers and
oscillators, tracked by the scene-wide measured model (``motion_states="scene"``) and by the
default (motion states per track where the tracks keep them, else the scene-wide model), beside
trackpy (plain and with its predictor), laptrack and the one-step oracle.

Run as ``python tests/benchmarks/bench_mixed.py [--seeds reporting|tuning] [--table mixed|unseen|held-out]
[--only WORD] [--trackers a,b] [--write-docs]``. ``--table mixed`` (default) draws :mod:`seedtrack.data.mixed_motion`
scenes; ``unseen`` bench_unseen.py's scenes and ``held-out`` bench_held_out.py's dishes and PSMG,
to show what the default changes where one kind of motion fills the scene. Seeds were
split before anything was looked at: tuning 0-4, reporting 1000-1004 (the table printed by
default; on ``held-out`` the first three of each).

Cells as bench_unseen.py's: strict merit / IDF1 / link error (mean over the clips, tolerance
0.5 px), CPU seconds of all clips; peers at their best search range of 1.0, 1.3 and 1.6 times the
true fastest speed v (the factor in brackets; "adaptive search": trackpy gave up on too many
candidates and its adaptive search made the figure, as in bench_held_out.py); the oracle as
bench_unseen.py's.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time

import bench_held_out as held
import bench_unseen as unseen
from tables import write_table

from seedtrack.data.mixed_motion import MixedSpec, generate_mixed
from seedtrack.tracking.goa import GOAConfig
from seedtrack.tracking.linking import link_goa

SEED_SETS = {"tuning": range(0, 5), "reporting": range(1000, 1005)}
VARIANTS = {"seedtrack scene-wide": "scene", "seedtrack": "track"}
TRACKERS = (*VARIANTS, "trackpy", "trackpy predict", "laptrack", "oracle")


class Mixed:
    def __init__(self, label: str, **spec):
        self.label, self.spec = label, spec

    def draw(self, seed: int):
        return generate_mixed(MixedSpec(**self.spec, random_seed=seed))


MIXED = (
    Mixed("smooth 40%, walk 40%, swing 20%; 120, 4 px/f", points=120),
    Mixed("smooth 50%, walk 50%; 120, 6 px/f", points=120, shares=(0.5, 0.5, 0.0), speed=6.0),
    Mixed("smooth 30%, walk 30%, swing 40%; 200, 4 px/f", points=200, shares=(0.3, 0.3, 0.4)),
    Mixed("smooth 70%, walk 10%, swing 20%; 150, 5 px/f", points=150, shares=(0.7, 0.1, 0.2), speed=5.0),
)
HELD_OUT = tuple(s for s in held.SCENES if s.label.startswith(("dish 80", "dish 150", "PSMG")))
TABLES = {"mixed": MIXED, "unseen": unseen.SCENES, "held-out": HELD_OUT}
# The docs/motion.md table each writes.
DOC_TABLES = {"mixed": "states-mixed", "unseen": "states-unseen", "held-out": "states-held-out"}


def peer(name: str):
    """bench_unseen.py's peers, trackpy falling back to its adaptive search where a search range
    gives it too many candidates (as bench_held_out.py's does; walkers' longest steps are far
    longer than their typical ones)."""
    if name.startswith("trackpy"):
        run = held.trackpy_tracker("predict" if name.endswith("predict") else "plain")
        return lambda frames, limit: run(frames, limit, False)
    return unseen._peer(name)


def run_seedtrack(states: str, clips) -> tuple[tuple[float, float, float], float]:
    """Mean (strict merit, IDF1, link error) of seedtrack with no options but ``motion_states``."""
    started = time.process_time()
    tracks = [link_goa(frames, config=GOAConfig(motion_states=states))[0] for frames, _ in clips]
    cpu = time.process_time() - started
    scores = [unseen._scores(r, t) for r, (_, t) in zip(tracks, clips)]
    return tuple(statistics.mean(s[i] for s in scores) for i in range(3)), cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", choices=tuple(SEED_SETS), default="reporting")
    parser.add_argument("--table", choices=tuple(TABLES), default="mixed")
    parser.add_argument("--only", default="", help="scenes whose label contains this")
    parser.add_argument("--trackers", default="", help="comma-separated tracker names (default all)")
    parser.add_argument("--write-docs", action="store_true", help="write the table into docs/motion.md, stamped")
    args = parser.parse_args()
    names = [n for n in args.trackers.split(",") if n] or list(TRACKERS)
    seeds = SEED_SETS[args.seeds][: 3 if args.table == "held-out" else None]
    print(f"{args.table} scenes, {args.seeds} seeds {seeds.start}-{seeds.stop - 1}; cells: strict merit / IDF1 / link error (mean of {len(seeds)} clips), CPU s of all clips; peers at their best search range [factor of the true fastest speed v]")
    print("| scene | points | v | " + " | ".join(names) + " |")
    print("| --- | --- | --- |" + " --- |" * len(names))
    rows = []
    for scene in TABLES[args.table]:
        if args.only not in scene.label:
            continue
        clips = [scene.draw(seed) for seed in seeds]
        limits = [unseen.fastest(t) for _, t in clips]
        points = sum(sum(f.shape[0] for f in frames) for frames, _ in clips)
        cells = []
        for name in names:
            if name in VARIANTS:
                (merit, idf1, link), cpu = run_seedtrack(VARIANTS[name], clips)
                note = ""
            else:
                held.ADAPTIVE.clear()
                (merit, idf1, link), cpu, note = unseen.run_cell(name, clips, limits, peer)
                note += " adaptive search" if held.ADAPTIVE else ""
            cells.append(f"{merit:.3f} / {idf1:.3f} / {link:.3f}, {cpu:.2f} s" + (f" [{note}]" if note else ""))
            print(f"  {scene.label} {name}: {cells[-1]}", file=sys.stderr, flush=True)
        rows.append([scene.label, points, f"{statistics.mean(limits):.1f}", *cells])
        print(f"| {scene.label} | {points} | {statistics.mean(limits):.1f} | " + " | ".join(cells) + " |", flush=True)
    if args.write_docs:
        write_table("motion.md", DOC_TABLES[args.table], ["scene", "points", "v", *names], rows)


if __name__ == "__main__":
    main()
