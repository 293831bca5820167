"""Seeds hidden for several frames on a turning dish: how many come back on their own track.

Run as ``python tests/benchmarks/bench_hidden.py [--clips N] [--write-docs]`` (``--write-docs`` also writes
the first table into docs/tracking.md, stamped: ``hidden``). The dish generator's seed
positions (80 seeds, 30 frames, a quarter of them hidden once for 2, 5 or 10 frames in a row,
optionally 5 seeds added and 5 removed mid-clip) are tracked as ``seedtrack track`` does with no
option (the motion is measured, then open GOA-updown). Prints the seeds whose track follows them
over every frame they are seen (strict trajectory merit at 0.5 px), mean over N clips.

Two more tables give the figures behind two defaults of ``GOAConfig``: seeds missed at random in
single frames with the augmented matrix's corner "phi" (default) against the reference code's
"zero" (80 seeds, 20 frames, clips 3 to 5, seeds right of 240), and a crowded fast dish (200 and
250 seeds, rim speed 42 px/frame, 10 frames, clips 0 to 2) with 8, 12 or 24 candidate neighbours.
"""

from __future__ import annotations

import argparse
import statistics

from seedtrack.data.dish import DishSpec, make_dish_scene
from seedtrack.tracking.goa import GOAConfig
from seedtrack.tracking.linking import link_goa
from seedtrack.tracking.metrics import score_tracks
from tables import write_table

SEEDS = 80
GAPS = (2, 5, 10)
ROWS = (
    ("5 px/frame", dict(rim_speed=5.0)),
    ("10 px/frame", dict(rim_speed=10.0)),
    ("20 px/frame", dict(rim_speed=20.0)),
    ("5 px/frame, 5 seeds added and 5 removed", dict(rim_speed=5.0, added_seeds=5, removed_seeds=5)),
    ("10 px/frame, 5 seeds added and 5 removed", dict(rim_speed=10.0, added_seeds=5, removed_seeds=5)),
)


def seeds_kept(spec: DishSpec, **config) -> int:
    """Seeds that one track follows over every frame they are seen, with ``GOAConfig(**config)``."""
    scene = make_dish_scene(spec)
    frames = scene.visible_points()
    tracks = link_goa(frames, "goa-updown", GOAConfig(**config))[0]
    return score_tracks(tracks, scene.truth, tolerance=0.5).correct_tracks


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--clips", type=int, default=4)
    parser.add_argument("--write-docs", action="store_true", help="write the first table into docs/tracking.md, stamped")
    args = parser.parse_args()
    print("| rim speed | " + " | ".join(f"hidden {gap} frames" for gap in GAPS) + " |")
    print("| --- |" + " --- |" * len(GAPS))
    rows = []
    for label, options in ROWS:
        cells = []
        for gap in GAPS:
            kept = [
                seeds_kept(DishSpec(seeds=SEEDS, frames=30, hidden_seeds=SEEDS // 4, hidden_frames=gap, random_seed=clip, **options))
                for clip in range(args.clips)
            ]
            cells.append(f"{statistics.mean(kept):.0f}/{SEEDS}")
        print(f"| {label} | " + " | ".join(cells) + " |", flush=True)
        rows.append([label, *cells])
    if args.write_docs:
        write_table("tracking.md", "hidden", ["rim speed", *(f"hidden {gap} frames" for gap in GAPS)], rows)
    print("\n| seeds missed per frame | rim speed | corner phi | corner zero |\n| --- | --- | --- | --- |")
    for missed, rim_speed in ((0.05, 20.0), (0.05, 42.0), (0.10, 10.0), (0.10, 30.0)):
        cells = []
        for corner in ("phi", "zero"):
            specs = [DishSpec(seeds=SEEDS, frames=20, rim_speed=rim_speed, hidden_probability=missed, random_seed=clip) for clip in (3, 4, 5)]
            cells.append(f"{sum(seeds_kept(spec, corner=corner) for spec in specs)}/{3 * SEEDS}")
        print(f"| {missed:.0%} | {rim_speed:g} px/frame | " + " | ".join(cells) + " |", flush=True)
    print("\n| seeds at rim speed 42 | 8 neighbours | 12 neighbours | 24 neighbours |\n| --- | --- | --- | --- |")
    for seeds in (200, 250):
        specs = [DishSpec(seeds=seeds, frames=10, rim_speed=42.0, random_seed=clip) for clip in range(3)]
        cells = [f"{sum(seeds_kept(spec, neighbours=n) for spec in specs) / (3 * seeds):.0%}" for n in (8, 12, 24)]
        print(f"| {seeds} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
