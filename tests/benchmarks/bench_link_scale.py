"""Linking at scale: ``seedtrack.link`` beside ``trackpy.link`` (with numba), CPU seconds in one run.

Run as ``python tests/benchmarks/bench_link_scale.py [--bulk DETECTIONS.csv] [--sizes 1000 10000 100000] [--write-docs]``
(``--write-docs`` also writes the table into docs/speed-linking.md, stamped: ``link-scale``).

Random walkers (``seedtrack.data.walkers``, step sigma 1.5 px/axis, 300 walkers per 512 x 512 px,
the view grown with the count) over ``--frames`` frames, and the detections of the bulk-water
clip (``--bulk``: a csv of ``seedtrack detect``; without it the clip in shared/data beside the checkout is
detected once into a temporary folder). Both linkers run in this process, warmed up first
(imports, numba's compilation), in turns, each size ``--repeats`` times (median). trackpy's
``search_range`` is the fastest speed seedtrack measured on the same points (its speed limit over
``SPEED_MARGIN``, the 99th percentile of the speeds: what one who knew the motion would set; at
the limit itself trackpy gives up on crowded subnets), memory 0 (its default).

Printed per row: CPU seconds of each (``time.process_time``: threads included, other work on a
shared machine not), microseconds per point, the ratio seedtrack / trackpy, and the accuracy of
both against the walkers' truth (link error at every size, IDF1 at the smallest; tracks and rows
per frame on bulk water, which has no truth); then the log-log slope of seedtrack's CPU from the second size to the third. Goals
(issue 31): ratio at most 0.7 at 10k, 100k and on bulk water, slope at most 1.05, ratio at most
1 at 1k.
"""

from __future__ import annotations

import argparse
import math
import re
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

import seedtrack
from seedtrack.data.walkers import WalkerSpec, generate_walkers
from seedtrack.tracking.adaptive import SPEED_MARGIN

# trackpy's clip, found where bench_bulk_water finds it (shared/data beside the checkout).
from bench_bulk_water import CLIP as BULK_CLIP
from tables import write_table

# Walkers per 512 x 512 px: WalkerSpec's default scene.
DENSITY = 300 / 512**2
# IDF1 (seedtrack.evaluate) up to this many walkers a frame; link error at every size.
IDF1_UP_TO = 1000


def walkers(count: int, frames: int, seed: int):
    size = math.sqrt(count / DENSITY)
    positions, truth = generate_walkers(WalkerSpec(walkers=count, frames=frames, size=size, random_seed=seed))
    return table_of(positions), truth


def table_of(frames: list[np.ndarray]) -> pd.DataFrame:
    joined = np.concatenate(frames)
    return pd.DataFrame({"frame": np.repeat(np.arange(len(frames)), [len(f) for f in frames]), "x": joined[:, 0], "y": joined[:, 1]})


def fastest(tracks: pd.DataFrame) -> float:
    """The fastest speed seedtrack measured (from its motion line), pixels/frame."""
    return float(re.search(r"speed limit ([0-9.]+) px/frame", tracks.attrs["motion"]).group(1)) / SPEED_MARGIN


def timed(link, table: pd.DataFrame):
    start = time.process_time()
    result = link(table)
    return time.process_time() - start, result


def compare(table: pd.DataFrame, repeats: int):
    """Median CPU seconds of seedtrack.link and of trackpy.link, taken in turns, and their last tracks."""
    import trackpy

    ours, theirs = [], []
    mine = peer = None
    for _ in range(repeats):
        seconds, mine = timed(seedtrack.link, table)
        ours.append(seconds)
        search_range = fastest(mine)
        seconds, peer = timed(lambda t: trackpy.link(t, search_range), table)
        theirs.append(seconds)
    return statistics.median(ours), statistics.median(theirs), mine, peer


def link_error(tracks: pd.DataFrame, column: str, table: pd.DataFrame, truth) -> float:
    """Share of the truth's links (a walker measured in frames k and k + 1) that no track makes.

    Points are matched to the input rows by frame and position, which both linkers keep
    exactly; seedtrack.evaluate, which matches by distance and scores IDF1 too, built dense
    frame-by-frame matrices that took gigabytes at 10,000 points a frame.
    """
    points = table.reset_index(drop=True).rename_axis("point").reset_index()
    held = points.merge(tracks[["frame", "x", "y", column]], on=["frame", "x", "y"], how="left")
    track_of = held.sort_values("point")[column].to_numpy(dtype=float)
    offsets = np.concatenate(([0], np.cumsum(table.groupby("frame").size().to_numpy())))
    measured = truth.measurement >= 0
    point = np.where(measured, offsets[:-1][None, : measured.shape[1]] + truth.measurement, -1)
    linked = measured[:, 1:] & measured[:, :-1]
    before, after = track_of[point[:, :-1][linked]], track_of[point[:, 1:][linked]]
    return float(np.mean(~((before == after) & ~np.isnan(before))))


def accuracy(mine: pd.DataFrame, peer: pd.DataFrame, table: pd.DataFrame, truth, idf1: bool) -> str:
    said = []
    for tracks, column in ((mine, "track_id"), (peer, "particle")):
        text = f"link error {link_error(tracks, column, table, truth):.4f}"
        if idf1:
            text += f", IDF1 {seedtrack.evaluate(tracks, truth).idf1:.3f}"
        said.append(text)
    return " | ".join(said)


def bulk_points(path: str | None, folder: str) -> pd.DataFrame | None:
    if path is not None:
        return pd.read_csv(path)[["frame", "x", "y"]]
    if not BULK_CLIP.exists():
        return None
    out = Path(folder) / "bulk.csv"
    seedtrack.detect(BULK_CLIP).to_csv(out, index=False)
    return pd.read_csv(out)[["frame", "x", "y"]]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs=3, default=[1000, 10000, 100000], help="walkers: in-process size, then the two of the slope")
    parser.add_argument("--frames", type=int, default=10)
    parser.add_argument("--repeats", type=int, nargs=3, default=[5, 3, 1], help="per size")
    parser.add_argument("--bulk", help="detections csv of the bulk-water clip")
    parser.add_argument("--write-docs", action="store_true", help="write the table into docs/speed-linking.md, stamped")
    args = parser.parse_args()
    import trackpy

    trackpy.quiet()
    # numba compiles trackpy's subnet code on first use of each path: warmed on a scene like the first.
    warm, _ = walkers(args.sizes[0], args.frames, seed=99)
    compare(warm, 1)

    rows = []
    print(f"{'points':>24} {'seedtrack s':>11} {'trackpy s':>9} {'us/pt':>6} {'ratio':>6}  accuracy (seedtrack | trackpy)")

    def show(name: str, count: int, ours: float, theirs: float, said: str) -> None:
        rows.append((name, count, ours, theirs, said))
        print(f"{name:>24} {ours:11.2f} {theirs:9.2f} {1e6 * ours / count:6.1f} {ours / theirs:6.2f}  {said}", flush=True)

    per_size = {}
    for count, repeats in zip(args.sizes, args.repeats):
        table, truth = walkers(count, args.frames, seed=1)
        ours, theirs, mine, peer = compare(table, repeats)
        per_size[count] = (ours, len(table))
        show(f"walkers {count:,}/frame", len(table), ours, theirs, accuracy(mine, peer, table, truth, idf1=count <= IDF1_UP_TO))
    with tempfile.TemporaryDirectory() as folder:
        table = bulk_points(args.bulk, folder)
    if table is not None:
        ours, theirs, mine, peer = compare(table, 1)
        frames = table.frame.nunique()
        show(f"bulk water, {frames} frames", len(table), ours, theirs, f"{mine.track_id.nunique():,} tracks | {peer.particle.nunique():,} tracks")
    (low, low_points), (high, high_points) = per_size[args.sizes[1]], per_size[args.sizes[2]]
    slope = math.log(high / low) / math.log(high_points / low_points)
    said = f"log-log slope of seedtrack's CPU, {args.sizes[1]:,} to {args.sizes[2]:,} points a frame: {slope:.2f}"
    print(said)
    if args.write_docs:
        header = ["points", "seedtrack, s", "trackpy, s", "seedtrack, us/point", "seedtrack / trackpy", "accuracy (seedtrack | trackpy)"]
        cells = [[f"{name} ({count:,} points)", f"{ours:.2f}", f"{theirs:.2f}", f"{1e6 * ours / count:.1f}", f"{ours / theirs:.2f}", text]
                 for name, count, ours, theirs, text in rows]
        note = (f"{args.frames} frames of walkers, CPU seconds in one process, medians of {'/'.join(map(str, args.repeats))} runs. "
                f"{said[0].upper()}{said[1:]}.")
        write_table("speed-linking.md", "link-scale", header, cells, note=note)


if __name__ == "__main__":
    main()
