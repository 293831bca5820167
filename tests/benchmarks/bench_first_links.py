"""How GOA-updown starts: the paper's plain up-down scheme against seedtrack's, in figures.

Run as ``python tests/benchmarks/bench_first_links.py [--write-docs]`` (``--write-docs`` also writes both
tables into docs/tracking.md, stamped: ``first-links-dish``, ``first-links-psmg``). Schemes:

- paper: first links by optimal nearest-neighbour assignment of frames 0 and 1 (IM1), and a down
  pass that starts only from the up pass's last links;
- lookahead: first links scored by the smoothest five-frame path they start (a path may pass a
  missed point as a slave), paper's down pass;
- restart: paper's first links, and a down pass that also starts tracks from the last frame's
  points that the up pass lost;
- seedtrack (default): lookahead and restart.

Prints the seeds tracked perfectly on 10 simulated rotating dishes (80 seeds, 10 frames, rim
speed 42 px/frame) per speed limit d_max, as min-max over the dishes, and the mean track error
on PSMG scenes (100 points at speed 5 px/frame in 200 x 200 px, 20 frames, 10 seeds) per
occlusion probability.
"""

from __future__ import annotations

import argparse
from dataclasses import replace

import numpy as np

from seedtrack.experiments import BASE
from seedtrack.data.dish import DishSpec, make_dish_scene
from seedtrack.data.psmg import generate_psmg
from seedtrack.tracking.goa import GOAConfig, goa_updown
from seedtrack.tracking.metrics import score_tracks
from tables import write_table

SCHEMES = {
    "paper": GOAConfig(initialisation="im1", restart_lost=False),
    "lookahead": GOAConfig(restart_lost=False),
    "restart": GOAConfig(initialisation="im1"),
    "seedtrack": GOAConfig(),
}
D_MAX = (None, 45.0, 60.0, 100.0, 200.0)
OCCLUSION = (0.0, 0.1, 0.2)
RUNS = 10


def dish_table() -> tuple[list[str], list[list[str]]]:
    scenes = []
    for seed in range(1, RUNS + 1):
        truth = make_dish_scene(DishSpec(random_seed=seed)).truth
        rng = np.random.default_rng(seed)
        scenes.append(([truth.xy[rng.permutation(truth.n_tracks), k] for k in range(truth.n_frames)], truth))
    print(f"rotating dish, seeds tracked perfectly of 80 (min-max over {RUNS} dishes)")
    header = ["first links", *(f"d_max {d if d is not None else 'none'}" for d in D_MAX)]
    print("| " + " | ".join(header) + " |")
    print("| --- " * (len(D_MAX) + 1) + "|")
    rows = []
    for name, config in SCHEMES.items():
        cells = []
        for d_max in D_MAX:
            correct = [
                score_tracks(goa_updown(frames, replace(config, d_max=d_max)), truth, 1e-6).correct_tracks
                for frames, truth in scenes
            ]
            cells.append(f"{min(correct)}" if min(correct) == max(correct) else f"{min(correct)}-{max(correct)}")
        print(f"| {name} | " + " | ".join(cells) + " |")
        rows.append([name, *cells])
    return header, rows


def psmg_table() -> tuple[list[str], list[list[str]]]:
    print(f"\nPSMG, 100 points, speed {BASE.mean_speed:g}, mean track error over {RUNS} seeds (no d_max / d_max 2 x speed)")
    header = ["first links", *(f"occlusion {p:g}" for p in OCCLUSION)]
    print("| " + " | ".join(header) + " |")
    print("| --- " * (len(OCCLUSION) + 1) + "|")
    rows = []
    data = {p: [generate_psmg(replace(BASE, trajectories=100, occlusion=p, random_seed=s)) for s in range(RUNS)] for p in OCCLUSION}
    for name, config in SCHEMES.items():
        cells = []
        for p in OCCLUSION:
            errors = [
                [score_tracks(goa_updown(frames, replace(config, d_max=d_max)), truth, 0.5).track_error for frames, truth in data[p]]
                for d_max in (None, 2 * BASE.mean_speed)
            ]
            cells.append(" / ".join(f"{np.mean(e):.3f}" for e in errors))
        print(f"| {name} | " + " | ".join(cells) + " |")
        rows.append([name, *cells])
    return header, rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write-docs", action="store_true", help="write both tables into docs/tracking.md, stamped")
    args = parser.parse_args()
    dish, psmg = dish_table(), psmg_table()
    if args.write_docs:
        write_table("tracking.md", "first-links-dish", *dish)
        write_table("tracking.md", "first-links-psmg", *psmg)


if __name__ == "__main__":
    main()
