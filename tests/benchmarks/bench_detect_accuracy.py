"""Recall, precision and position error of ``seedtrack detect``'s defaults on generated clips.

Run as ``python tests/benchmarks/bench_detect_accuracy.py``; writes cluttered rotating-dish
clips (touching pairs, rim and shadow, uneven light, glare, dust) through H.264 like a user's
recording, detects with the default options and matches to the generator's truth (one to one
within 2 px, optimal assignment); then a dense dish of 200 seeds whose centres may come as close
as 7 px (a seed's length, so many touch), on a 320 x 240 frame, random seeds 100.. (never used
while the detector was written). Also prints detections per frame on the real bulk-water clip.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

from seedtrack.pipeline import detect_clip
from seedtrack.data.dish import DishSpec, write_dish_clip
from seedtrack.tracking.metrics import match_frame

REAL_CLIP = next(
    (folder / "shared" / "data" / "bulk-water-240-479.mp4" for folder in Path(__file__).resolve().parents if (folder / "shared" / "data").is_dir()),
    Path("bulk-water-240-479.mp4"),
)
DENSE = dict(seeds=200, width=320, height=240, rim_speed=10.0, separation=7.0)


def score(spec: DishSpec, folder: Path) -> tuple[int, int, int, list[float], list[float]]:
    """(true points, found points, matched, errors of single seeds, errors of seeds in contact)."""
    scene = write_dish_clip(spec, folder)
    detections = detect_clip(folder / "clip.mp4", say=lambda line: None).detections
    in_contact = np.zeros(spec.seeds, bool)
    in_contact[: spec.touching_pairs] = in_contact[spec.seeds - spec.touching_pairs :] = True
    true_count = found = matched = 0
    single, paired = [], []
    for k in range(detections.frame_indices.size):
        columns = detections.frame(k)
        shown = np.flatnonzero(scene.visible[:, k])
        truth = scene.truth.xy[shown, k]
        points = np.column_stack((columns["x"], columns["y"]))
        rows, cols = match_frame(points, truth, 2.0)
        error = np.hypot(*(points[rows] - truth[cols]).T)
        single.extend(error[~in_contact[shown[cols]]])
        paired.extend(error[in_contact[shown[cols]]])
        true_count, found, matched = true_count + len(truth), found + len(points), matched + len(rows)
    return true_count, found, matched, single, paired


def main() -> None:
    frames = int(sys.argv[1]) if len(sys.argv) > 1 else 50
    totals = np.zeros(3, int)
    single, paired = [], []
    with tempfile.TemporaryDirectory() as folder:
        for seed in range(3):
            spec = DishSpec(
                seeds=120, frames=frames, touching_pairs=20, rim=True, glare_spots=8, dust_specks=60, illumination=60, random_seed=seed
            )
            result = score(spec, Path(folder) / str(seed))
            totals += result[:3]
            single.extend(result[3])
            paired.extend(result[4])
    true_count, found, matched = totals
    rms = lambda errors: float(np.sqrt(np.mean(np.square(errors))))
    print(f"generated: 3 clips x {frames} frames, 120 seeds (40 in touching pairs), rim, glare, 60 dust specks, uneven light")
    print(f"  recall {matched / true_count:.4f}  precision {matched / found:.4f}  ({true_count} true, {found} found, {matched} matched)")
    print(f"  RMS error {rms(single + paired):.3f} px (single seeds {rms(single):.3f}, seeds in contact {rms(paired):.3f})")
    totals = np.zeros(3, int)
    errors = []
    with tempfile.TemporaryDirectory() as folder:
        for seed in (100, 101, 102):
            result = score(DishSpec(frames=frames, random_seed=seed, **DENSE), Path(folder) / str(seed))
            totals += result[:3]
            errors.extend(result[3] + result[4])
    true_count, found, matched = totals
    print(f"dense dish: 3 clips x {frames} frames, 200 seeds on 320x240, centres 7 px apart or more")
    print(f"  recall {matched / true_count:.4f}  precision {matched / found:.4f}  ({true_count} true, {found} found, {matched} matched); RMS error {rms(errors):.3f} px")
    if REAL_CLIP.exists():
        found = detect_clip(REAL_CLIP, say=lambda line: None)
        counts = found.detections.counts
        print(f"bulk-water-240-479.mp4: {np.median(counts):.0f} detections per frame (median; {min(counts)} to {max(counts)}); {found.choice.reason}")


if __name__ == "__main__":
    main()
