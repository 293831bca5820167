"""Recall, precision and position error of the spot detector beside trackpy.locate and blob_log.

Run as ``python tests/benchmarks/bench_detect_spots.py [FRAMES]``. Frames of Gaussian spots
(:mod:`seedtrack.data.spotfield`: Poisson and read noise, 200 spots on 512 x 512 of which 20 in
touching pairs and 10 out of focus rings) at signal-to-noise ratios 2 to 10, as in the ISBI
particle tracking challenge; a found point is matched one to one to a true centre within 2 px.

- seedtrack: ``fit_spot_settings`` on the first frame (diameter and least mass measured), then
  ``detect_spots``, nothing given.
- trackpy.locate: diameter 2 round(3 sigma) + 1 (its documentation: odd, a little larger than
  the spot) and its ``minmass``, and skimage's blob_log: sigma 1..3 and its ``threshold``, each
  swept on tuning frames (random seeds 0..) and the best F1 taken, then reported on other frames
  (seeds 1000..), as its users would tune it. seedtrack is not tuned on these frames.

Frames per second are CPU seconds on one core (trackpy with numba if installed). RMS is the 2-D
distance to the true centre over all matched spots, and over single spots alone (the detectors
match different touching spots, so that column compares like with like); beside it, per level,
the Cramer-Rao bound of any unbiased estimator on a single spot of this generator (Mortensen et
al., Nature Methods 7, 377, 2010, maximum likelihood with a known Gaussian PSF and background).
"""

from __future__ import annotations

import sys
import time

import cv2
import numpy as np
import trackpy
from skimage.feature import blob_log

from seedtrack.data.spotfield import SpotFieldSpec, make_spot_field
from seedtrack.detection.spots import detect_spots, fit_spot_settings
from seedtrack.tracking.metrics import match_frame

TOLERANCE_PX = 2.0
SNRS = (2.0, 3.0, 4.0, 6.0, 10.0)
TUNING_SEEDS = range(0, 2)
REPORTING_SEED = 1000


def seedtrack_points(images: list[np.ndarray]) -> list[np.ndarray]:
    settings = fit_spot_settings(images[0], "light")
    return [np.column_stack((t["x"], t["y"])) for t in (detect_spots(image, settings) for image in images)]


def trackpy_points(images: list[np.ndarray], diameter: int, minmass: float) -> list[np.ndarray]:
    return [trackpy.locate(image, diameter, minmass=minmass)[["x", "y"]].to_numpy() for image in images]


def blob_log_points(images: list[np.ndarray], threshold: float) -> list[np.ndarray]:
    found = []
    for image in images:
        scaled = (image - image.min()) / max(float(np.ptp(image)), 1e-9)
        peaks = blob_log(scaled, min_sigma=1, max_sigma=3, num_sigma=5, threshold=threshold)
        found.append(peaks[:, [1, 0]] if len(peaks) else np.empty((0, 2)))
    return found


def score(found: list[np.ndarray], fields) -> dict[str, float]:
    true = hits = total = 0
    errors, kinds = [], []
    for points, field in zip(found, fields):
        rows, cols = match_frame(points, field.xy, TOLERANCE_PX)
        errors.extend(np.hypot(*(points[rows] - field.xy[cols]).T))
        kinds.extend(field.kind[cols])
        true, hits, total = true + len(field.xy), hits + len(rows), total + len(points)
    kinds, errors = np.array(kinds), np.array(errors)
    singles = errors[kinds == "single"]
    recall, precision = hits / true, hits / max(total, 1)
    touching = np.sum(kinds == "touching") / sum(np.sum(f.kind == "touching") for f in fields)
    rings = np.sum(kinds == "ring") / sum(np.sum(f.kind == "ring") for f in fields)
    return {
        "recall": recall,
        "precision": precision,
        "f1": 2 * recall * precision / max(recall + precision, 1e-12),
        "rms": float(np.sqrt(np.mean(errors**2))) if errors.size else float("nan"),
        "single_rms": float(np.sqrt(np.mean(singles**2))) if singles.size else float("nan"),
        "touching": touching,
        "rings": rings,
    }


def cramer_rao_rms(spec: SpotFieldSpec) -> float:
    """The least 2-D RMS error of an unbiased position estimate of one spot of ``spec``, pixels:
    sqrt(2) times Mortensen's per-axis bound for maximum likelihood, with N photons in the spot
    and b photons a pixel of background (read noise counted as background)."""
    floor = spec.background + spec.read_noise**2
    amplitude = (spec.snr**2 + np.sqrt(spec.snr**4 + 4 * spec.snr**2 * floor)) / 2
    photons = 2 * np.pi * spec.sigma**2 * amplitude
    width = spec.sigma**2 + 1 / 12
    tau = 2 * np.pi * width * floor / photons
    return float(np.sqrt(2 * width / photons * (1 + 4 * tau + np.sqrt(2 * tau / (1 + 4 * tau)))))


def best(run, values, fields) -> float:
    """The parameter value of ``values`` with the best F1 on ``fields``."""
    return max(values, key=lambda value: score(run(value), fields)["f1"])


def rate(run) -> float:
    start = time.process_time()
    count = run()
    return count / (time.process_time() - start)


def main() -> None:
    cv2.setNumThreads(1)
    trackpy.quiet()
    frames = int(sys.argv[1]) if len(sys.argv) > 1 else 4
    print(f"Gaussian spots, sigma 1.5 px, 200 per 512x512 frame (20 touching, 10 rings), {frames} reporting frames per SNR; match within {TOLERANCE_PX:g} px")
    print(f"{'SNR':>4} {'detector':<22} {'recall':>7} {'precision':>9} {'RMS px':>7} {'singles':>7} {'touching':>8} {'rings':>6} {'frames/s':>9}")
    for snr in SNRS:
        spec = SpotFieldSpec(snr=snr)
        tuning = [make_spot_field(SpotFieldSpec(snr=snr, random_seed=seed)) for seed in TUNING_SEEDS]
        fields = [make_spot_field(SpotFieldSpec(snr=snr, random_seed=REPORTING_SEED + k)) for k in range(frames)]
        images = [f.image for f in fields]
        diameter = 2 * int(round(3 * spec.sigma)) + 1
        minmass = best(lambda m: trackpy_points([f.image for f in tuning], diameter, m), [0, 50, 100, 200, 400, 800, 1600], tuning)
        threshold = best(lambda t: blob_log_points([f.image for f in tuning], t), [0.01, 0.02, 0.04, 0.06, 0.08, 0.12], tuning)
        runs = {
            "seedtrack": lambda: seedtrack_points(images),
            f"trackpy (minmass {minmass:g})": lambda: trackpy_points(images, diameter, minmass),
            f"blob_log (thr {threshold:g})": lambda: blob_log_points(images, threshold),
        }
        print(f"{snr:>4g} Cramer-Rao bound, single spots: RMS {cramer_rao_rms(spec):.3f} px (2-D)")
        for name, run in runs.items():
            found = run()
            result = score(found, fields)
            fps = rate(lambda: len(run()))
            print(
                f"{snr:>4g} {name:<22} {result['recall']:>7.4f} {result['precision']:>9.4f} {result['rms']:>7.3f} {result['single_rms']:>7.3f} "
                f"{result['touching']:>8.3f} {result['rings']:>6.3f} {fps:>9.1f}"
            )


if __name__ == "__main__":
    main()
