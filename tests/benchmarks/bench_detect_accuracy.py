"""Recall, precision and position error of ``seedtrack detect``'s defaults on generated clips.

Run as ``python tests/benchmarks/bench_detect_accuracy.py``; writes cluttered rotating-dish
clips (touching pairs, rim and shadow, uneven light, glare, dust) through H.264 like a user's
recording, detects with the default options and matches to the generator's truth (one to one
within 2 px, optimal assignment). Also prints blobs per frame on the real bulk-water clip.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

from seedtrack.pipeline import detect_clip
from seedtrack.data.dish import DishSpec, write_dish_clip
from seedtrack.tracking.metrics import match_frame

REAL_CLIP = Path(__file__).resolve().parents[3] / "shared" / "data" / "bulk-water-240-479.mp4"


def score(spec: DishSpec, folder: Path) -> tuple[int, int, int, list[float], list[float]]:
    """(true points, found points, matched, errors of single seeds, errors of seeds in contact)."""
    scene = write_dish_clip(spec, folder)
    detections = detect_clip(folder / "clip.mp4").detections
    in_contact = np.zeros(spec.seeds, bool)
    in_contact[: spec.touching_pairs] = in_contact[spec.seeds - spec.touching_pairs :] = True
    true_count = found = matched = 0
    single, paired = [], []
    for k, columns in enumerate(detections.columns):
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
    if REAL_CLIP.exists():
        counts = [len(c["x"]) for c in detect_clip(REAL_CLIP).detections.columns]
        print(f"bulk-water-240-479.mp4: {np.median(counts):.0f} blobs per frame (median; {min(counts)} to {max(counts)})")


if __name__ == "__main__":
    main()
