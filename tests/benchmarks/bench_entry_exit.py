"""Points entering and leaving (PSMG, IPAN's setting): strict trajectory merit of each tracker.

Run as ``python tests/benchmarks/bench_entry_exit.py [--clips N] [--write-docs]`` (``--write-docs`` also
writes the table into docs/tracking.md, stamped: ``entry-exit``). The experiments' base scene
(50 points in 200 x 200 px on average, speed 5 px/frame) with points drawn in a larger square so
that they enter and leave, speed limit 10 px/frame for every tracker. Prints the strict
trajectory merit (a trajectory counts only if one track follows it over every frame it is
measured in, 0.5 px) as the mean over N clips with a 95% interval (1.96 standard errors, seedtrack.experiments.ci95).
"""

from __future__ import annotations

import argparse
import statistics
from dataclasses import replace

from seedtrack.experiments import BASE, ci95
from seedtrack.data.psmg import generate_psmg
from seedtrack.tracking.goa import GOAConfig
from seedtrack.tracking.lifecycle import LifecycleConfig
from seedtrack.tracking.linking import link_goa
from seedtrack.tracking.metrics import score_tracks
from seedtrack.tracking.trackers import run_tracker
from tables import write_table

SCENES = (
    ("20 frames, no occlusion", dict(frames=20)),
    ("20 frames, 5% occlusion of 1 frame", dict(frames=20, occlusion=0.05, max_gap=1)),
    ("25 frames, 5% occlusion of 1-3 frames", dict(frames=25, occlusion=0.05, max_gap=3)),
)
TRACKERS = {
    "goa-updown (open, default)": lambda frames, limit: run_tracker("goa-updown", frames, limit),
    "goa-updown --max-gap 4": lambda frames, limit: link_goa(frames, "goa-updown", GOAConfig(d_max=limit), LifecycleConfig(max_gap=4))[0],
    "ipan": lambda frames, limit: run_tracker("ipan", frames, limit),
    "goa-updown-fixed (the paper's)": lambda frames, limit: run_tracker("goa-updown-fixed", frames, limit),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--clips", type=int, default=12)
    parser.add_argument("--write-docs", action="store_true", help="write the table into docs/tracking.md, stamped")
    args = parser.parse_args()
    print("| tracker | " + " | ".join(label for label, _ in SCENES) + " |")
    print("| --- |" + " --- |" * len(SCENES))
    clips = {
        label: [generate_psmg(replace(BASE, entry_exit=True, random_seed=seed, **options)) for seed in range(args.clips)]
        for label, options in SCENES
    }
    limit = 2 * BASE.mean_speed
    rows = []
    for name, track in TRACKERS.items():
        cells = []
        for label, _ in SCENES:
            merit = []
            for frames, truth in clips[label]:
                scores = score_tracks(track(frames, limit), truth, 0.5)
                merit.append(100.0 * scores.correct_tracks / scores.true_tracks)
            cells.append(f"{statistics.mean(merit):.1f} % +- {ci95(merit):.1f}")
        print(f"| {name} | " + " | ".join(cells) + " |", flush=True)
        rows.append([name, *cells])
    if args.write_docs:
        write_table("tracking.md", "entry-exit", ["tracker", *(label for label, _ in SCENES)], rows)


if __name__ == "__main__":
    main()
