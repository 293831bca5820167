"""What the detections' localisation error (``ep``) changes on tracking, in pairs.

Run as ``python tests/benchmarks/bench_localisation_tracking.py [--runs N] [--write-docs]``
(``--write-docs`` writes the table into ``docs/detection.md``). Each clip is
detected once (``seedtrack run``'s detection, defaults), then its points are linked twice with
``run``'s defaults: without a localisation error (the motion noise floored only by the grid and
0.1 px), and with the points' median ``ep`` as the floor (sqrt(6) ep on each velocity change), as
``run``, ``track`` and ``seedtrack.link`` now do. Clips:

- Brownian spots: Gaussian spots (sigma 1.5 px, Poisson noise on 10 photons a pixel, read noise
  1) wandering with a step of ``step`` px a frame per axis, rendered here; 150 spots on 256 x 256,
  30 frames, SNR 3 and 6, random seeds 1000.. (none looked at while building the estimate).
- The demo dish (``seedtrack demo``: 80 seeds, 10 frames, through H.264) and the demo with hidden
  seeds (``--hidden-probability 0.1 --frames 30 --random-seed 3``), blob detector.
- Bulk water (``shared/data/bulk-water-240-479.mp4``, real beads, spot detector): tracks made and
  trackpy's confident tracks reproduced (``bench_bulk_water.py``'s measure); and
  ``seedtrack.link`` on trackpy's own detections without and with trackpy's ``ep`` column.

Scores within 1 px: strict merit (share of true tracks followed correctly over their whole
length), IDF1, link error.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

import seedtrack
from seedtrack.data.dish import DishSpec, write_dish_clip
from seedtrack.pipeline import detect_clip
from seedtrack.points import TrackingSettings, group_points, localised, track_frames
from seedtrack.tracking.evaluation import evaluate_tracks
from seedtrack.tracking.tracks import Tracks
from tables import write_table

TOLERANCE_PX = 1.0


def brownian_spots(seed: int, snr: float, step: float, spots: int = 150, frames: int = 30, size: int = 256) -> tuple[list[np.ndarray], Tracks]:
    """Frames of wandering Gaussian spots (as :mod:`seedtrack.data.spotfield` draws one) and their truth."""
    rng = np.random.default_rng(seed)
    sigma, background, read = 1.5, 10.0, 1.0
    amplitude = (snr**2 + np.sqrt(snr**4 + 4 * snr**2 * (background + read**2))) / 2
    start = rng.uniform(12, size - 12, (spots, 2))
    xy = start[:, None, :] + np.cumsum(np.concatenate([np.zeros((spots, 1, 2)), rng.normal(0, step, (spots, frames - 1, 2))], axis=1), axis=1)
    rows, columns = np.mgrid[0:size, 0:size].astype(np.float32)
    images = []
    for k in range(frames):
        light = np.full((size, size), background, np.float32)
        for x, y in xy[:, k]:
            r0, c0 = int(round(y)), int(round(x))
            box = (slice(max(r0 - 8, 0), r0 + 9), slice(max(c0 - 8, 0), c0 + 9))
            light[box] += amplitude * np.exp(-((columns[box] - x) ** 2 + (rows[box] - y) ** 2) / (2 * sigma**2))
        images.append((rng.poisson(light) + rng.normal(0, read, light.shape)).astype(np.float32))
    inside = ((xy > 0) & (xy < size - 1)).all(axis=2)
    truth = np.where(inside[..., None], xy, np.nan)
    return images, Tracks.from_dense(truth, np.where(inside, 0, -1))


def pair(source, truth: Tracks | None) -> tuple[float, list[tuple[float, float, float] | Tracks]]:
    """The points' median ep and, without and with it as the floor, the scores (or the tracks
    when there is no truth)."""
    found = detect_clip(source, say=None)
    detections = found.detections
    points = group_points(detections.to_rows(), "clip", detections.frame_indices)
    results = []
    for settings in (TrackingSettings(), localised(TrackingSettings(), points)):
        tracks = track_frames(points.frames, settings, say=None)
        if truth is None:
            results.append(tracks)
            continue
        scores, _ = evaluate_tracks(tracks, truth, TOLERANCE_PX)
        results.append((1 - scores.track_error, scores.idf1, scores.link_error))
    return points.localisation, results


HEADER = ["clip", "median ep, px", "without ep: strict merit / IDF1 / link error", "with ep"]


def line(name: str, ep: float, results: list) -> list[str]:
    """One row of the table, printed as it is made: scores, or (tracks, reproduced) pairs."""
    cells = [f"{m:.3f} / {i:.3f} / {e:.3f}" for m, i, e in results] if isinstance(results[0][0], float) else [f"{t:,} tracks; {r} reproduced" for t, r in results]
    print(f"{name:<40} {ep:>6.3f} | {cells[0]:<28} | {cells[1]}")
    return [name, f"{ep:.3f}", *cells]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=2, help="Brownian clips per setting (seeds 1000..)")
    parser.add_argument("--no-bulk", action="store_true", help="leave out the bulk-water clip")
    parser.add_argument("--write-docs", action="store_true", help="write the table into docs/detection.md, stamped")
    args = parser.parse_args()
    rows = []
    print(f"{'clip':<40} {'ep px':>6} | without ep: merit / IDF1 / link error | with ep")
    for snr, step in ((3, 0.3), (3, 1.0), (6, 0.3)):
        for run in range(args.runs):
            images, truth = brownian_spots(1000 + run, snr, step)
            ep, results = pair(images, truth)
            rows.append(line(f"Brownian spots, SNR {snr}, step {step} px, seed {1000 + run}", ep, results))
    with tempfile.TemporaryDirectory() as folder:
        for name, spec in (("demo dish", DishSpec()), ("demo dish, hidden 0.1, 30 frames", DishSpec(hidden_probability=0.1, frames=30, random_seed=3))):
            scene = write_dish_clip(spec, Path(folder) / name)
            ep, results = pair(Path(folder) / name / "clip.mp4", scene.truth)
            rows.append(line(name, ep, results))
    if not args.no_bulk:
        from bench_bulk_water import CLIP, confident_tracks, grey_frames, reproduced

        features, reference = confident_tracks(grey_frames(CLIP))
        total = reference["particle"].nunique()
        ep, linked = pair(CLIP, None)
        counts = [(tracks.n_tracks, reproduced(reference, tracks.to_rows())[0]) for tracks in linked]
        rows.append(line(f"bulk water, `run`'s detections (of {total} confident)", ep, counts))
        # seedtrack.link on trackpy's own detections, whose ep is trackpy's estimate.
        counts = []
        for columns in (["frame", "x", "y"], ["frame", "x", "y", "ep"]):
            tracks = seedtrack.link(features[columns].reset_index(drop=True))
            counts.append((tracks["track_id"].nunique(), reproduced(reference, {name: tracks[name].to_numpy() for name in ("frame", "x", "y", "track_id")})[0]))
        rows.append(line(f"bulk water, trackpy's detections and ep (of {total})", float(features["ep"].median()), counts))
    if args.write_docs:
        write_table("detection.md", "localisation-tracking", HEADER, rows)


if __name__ == "__main__":
    main()
