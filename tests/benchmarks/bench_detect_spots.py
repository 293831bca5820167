"""Recall, precision and position error of the spot detector beside trackpy.locate and blob_log.

Run as ``python tests/benchmarks/bench_detect_spots.py [FRAMES] [--write-docs]`` (``--write-docs``
also writes both tables into docs/detection.md, stamped: ``detect-spots``, ``detect-spots-settings``). Frames of Gaussian spots
(:mod:`seedtrack.data.spotfield`: Poisson and read noise, 200 spots on 512 x 512 of which 20 in
touching pairs and 10 out of focus rings) at signal-to-noise ratios 2 to 10, as in the ISBI
particle tracking challenge; a found point is matched one to one to a true centre within 2 px.

- seedtrack: ``fit_spot_settings`` on the first frame (diameter and least mass measured), then
  ``detect_spots``, nothing given.
- trackpy.locate: diameter 2 round(3 sigma) + 1 (its documentation: odd, a little larger than
  the spot) and its ``minmass``, and skimage's blob_log: sigma 1..3 and its ``threshold``, each
  swept on tuning frames (random seeds 0..) and the best F1 taken, then reported on other frames
  (seeds 1000..), as its users would tune it. seedtrack is not tuned on these frames.

A second table, for small spots and settings other than the default: the same generator at
sigma 1.0 (backgrounds 10 and 50 photons), 2.2 and 3.0, and a second generator never looked at
while the detector was made (:func:`erf_field`): pixel-integrated Gaussian spots (erf), sigma
0.9-1.1 px, 150 per 400 x 400 frame on 30 photons, read noise 2 electrons, gain 2.2 grey levels
an electron, offset 400, 16-bit. Recall and precision of seedtrack and trackpy (diameter
2 round(3 sigma) + 1, its minmass the best F1 on the tuning frames among the masses of its
candidates there, 40 quantiles: what trackpy finds at minmass 0 and keeps above each); and
trackpy's recall at seedtrack's precision, which compares the two detectors' masses at one
operating point.

Frames per second are CPU seconds on one core (trackpy with numba if installed). RMS is the 2-D
distance to the true centre over all matched spots, and over single spots alone (the detectors
match different touching spots, so that column compares like with like); beside it, per level,
the Cramer-Rao bound of any unbiased estimator on a single spot of this generator (Mortensen et
al., Nature Methods 7, 377, 2010, maximum likelihood with a known Gaussian PSF and background).
"""

from __future__ import annotations

import argparse
import time

import cv2
import numpy as np
import trackpy
from scipy.special import erf
from skimage.feature import blob_log

from seedtrack.data.spotfield import SpotField, SpotFieldSpec, make_spot_field
from seedtrack.detection.spots import detect_spots, fit_spot_settings
from seedtrack.tracking.metrics import match_frame
from tables import write_table

TOLERANCE_PX = 2.0
SNRS = (2.0, 3.0, 4.0, 6.0, 10.0)
TUNING_SEEDS = range(0, 2)
REPORTING_SEED = 1000
# (generator, sigma px, background photons, SNRs) of the second table.
SETTINGS = (
    ("spotfield", 1.0, 50.0, (2.0, 3.0, 4.0)),
    ("spotfield", 1.0, 10.0, (2.0, 2.5, 3.0)),
    ("spotfield", 2.2, 50.0, (2.0, 3.0)),
    ("spotfield", 3.0, 10.0, (2.0, 3.0)),
    ("erf 16-bit", 1.0, 30.0, (2.0, 2.5, 3.0, 4.0)),
)


def erf_field(snr: float, seed: int, size: int = 400, spots: int = 150) -> SpotField:
    """Pixel-integrated Gaussian spots (each pixel gets the PSF's integral over it), sigma
    0.9-1.1 px, at least 8 px apart; Poisson noise on 30 photons, read noise 2 electrons, gain
    2.2 grey levels an electron, offset 400, rounded to 16 bits. SNR as in spotfield: the
    brightest pixel's expected signal over the noise there, for a spot centred on a pixel."""
    rng = np.random.default_rng(seed)
    background, read, gain, offset = 30.0, 2.0, 2.2, 400.0
    xy: list[np.ndarray] = []
    while len(xy) < spots:
        point = rng.uniform(6, size - 7, 2)
        if not xy or np.min(np.hypot(*(np.array(xy) - point).T)) >= 8:
            xy.append(point)
    centres = np.array(xy)
    sigmas = rng.uniform(0.9, 1.1, spots)
    edges = np.arange(size + 1) - 0.5
    photons = np.full((size, size), background)
    for (x, y), sigma in zip(centres, sigmas):
        # The peak pixel's share of the light, for a spot centred on it, fixes its photons.
        share = erf(0.5 / (np.sqrt(2) * sigma)) ** 2
        peak = (snr**2 + np.sqrt(snr**4 + 4 * snr**2 * (background + read**2))) / 2
        across = np.diff(erf((edges - x) / (np.sqrt(2) * sigma))) / 2
        down = np.diff(erf((edges - y) / (np.sqrt(2) * sigma))) / 2
        photons += peak / share * np.outer(down, across)
    electrons = rng.poisson(photons) + rng.normal(0, read, photons.shape)
    image = np.clip(np.round(offset + gain * electrons), 0, 65535).astype(np.uint16)
    return SpotField(image, centres, np.array(["single"] * spots))


def trackpy_diameter(sigma: float) -> int:
    """trackpy's diameter for spots of ``sigma`` px, as its documentation asks: odd, a little
    larger than the spot."""
    return 2 * int(round(3 * sigma)) + 1


def make_fields(generator: str, sigma: float, background: float, snr: float, seeds) -> list:
    if generator == "spotfield":
        return [make_spot_field(SpotFieldSpec(sigma=sigma, background=background, snr=snr, random_seed=seed)) for seed in seeds]
    return [erf_field(snr, seed) for seed in seeds]


def trackpy_candidates(diameter: int, fields) -> list:
    """What trackpy.locate finds on each frame at minmass 0: filtering by mass after is its minmass."""
    return [trackpy.locate(f.image.astype(np.float64), diameter, minmass=0) for f in fields]


def heavier(found: list, level: float) -> list[np.ndarray]:
    return [t.loc[t["mass"] >= level, ["x", "y"]].to_numpy() for t in found]


def mass_levels(found: list, top: float, count: int) -> np.ndarray:
    """``count`` quantiles, from 0 to ``top``, of the masses of trackpy's candidates ``found``."""
    return np.quantile(np.concatenate([t["mass"].to_numpy() for t in found]), np.linspace(0, top, count))


def best_minmass(diameter: int, fields) -> float:
    """trackpy's minmass of best F1 on ``fields``, among 40 quantiles of its candidates' masses."""
    found = trackpy_candidates(diameter, fields)
    return float(max(mass_levels(found, 0.975, 40), key=lambda level: score(heavier(found, level), fields)["f1"]))


def recall_at_precision(diameter: int, fields, precision: float) -> float:
    """trackpy's recall on ``fields`` at its lowest minmass whose precision there is at least
    ``precision`` (set on the frames it is scored on: a comparison of the two masses at one
    precision, not a tuned setting)."""
    found = trackpy_candidates(diameter, fields)
    for level in mass_levels(found, 0.999, 300):
        result = score(heavier(found, level), fields)
        if result["precision"] >= precision:
            return result["recall"]
    return 0.0


SPOT_HEADER = ["SNR", "detector", "recall", "precision", "RMS px", "singles px (bound)", "touching found", "rings found", "frames/s"]
SETTINGS_HEADER = ["generator", "sigma", "bg", "SNR", "seedtrack recall / precision", "trackpy recall / precision", "trackpy minmass", "F1 ours / trackpy", "trackpy at our precision"]


def small_spots_table(frames: int) -> list[list[str]]:
    print(f"\nOther settings: {frames} reporting frames each (seeds {REPORTING_SEED}..), trackpy tuned on seeds {TUNING_SEEDS.start}-{TUNING_SEEDS.stop - 1}")
    rows = []
    print(f"{'generator':<11} {'sigma':>5} {'bg':>4} {'SNR':>4} {'seedtrack recall':>16} {'precision':>9} {'trackpy recall':>14} {'precision':>9} {'minmass':>8} {'F1 ours':>7} {'trackpy':>7} {'trackpy recall at our precision':>31}")
    for generator, sigma, background, snrs in SETTINGS:
        for snr in snrs:
            tuning = make_fields(generator, sigma, background, snr, TUNING_SEEDS)
            fields = make_fields(generator, sigma, background, snr, range(REPORTING_SEED, REPORTING_SEED + frames))
            images = [f.image for f in fields]
            diameter = trackpy_diameter(sigma)
            minmass = best_minmass(diameter, tuning)
            ours = score(seedtrack_points(images), fields)
            theirs = score(trackpy_points([image.astype(np.float64) for image in images], diameter, minmass), fields)
            at_ours = recall_at_precision(diameter, fields, ours["precision"])
            print(
                f"{generator:<11} {sigma:>5g} {background:>4g} {snr:>4g} {ours['recall']:>16.3f} {ours['precision']:>9.3f} "
                f"{theirs['recall']:>14.3f} {theirs['precision']:>9.3f} {minmass:>8.3g} {ours['f1']:>7.3f} {theirs['f1']:>7.3f} "
                f"{at_ours:>31.3f}"
            )
            rows.append([generator, f"{sigma:g}", f"{background:g}", f"{snr:g}", f"{ours['recall']:.3f} / {ours['precision']:.3f}",
                         f"{theirs['recall']:.3f} / {theirs['precision']:.3f}", f"{minmass:.3g}", f"{ours['f1']:.2f} / {theirs['f1']:.2f}", f"{at_ours:.3f}"])
    return rows


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
    touching = np.sum(kinds == "touching") / max(sum(np.sum(f.kind == "touching") for f in fields), 1)
    rings = np.sum(kinds == "ring") / max(sum(np.sum(f.kind == "ring") for f in fields), 1)
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
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("frames", nargs="?", type=int, default=4, help="reporting frames per setting (default 4)")
    parser.add_argument("--write-docs", action="store_true", help="write both tables into docs/detection.md, stamped")
    args = parser.parse_args()
    frames, rows = args.frames, []
    print(f"Gaussian spots, sigma 1.5 px, 200 per 512x512 frame (20 touching, 10 rings), {frames} reporting frames per SNR; match within {TOLERANCE_PX:g} px")
    print(f"{'SNR':>4} {'detector':<22} {'recall':>7} {'precision':>9} {'RMS px':>7} {'singles':>7} {'touching':>8} {'rings':>6} {'frames/s':>9}")
    for snr in SNRS:
        spec = SpotFieldSpec(snr=snr)
        tuning = [make_spot_field(SpotFieldSpec(snr=snr, random_seed=seed)) for seed in TUNING_SEEDS]
        fields = [make_spot_field(SpotFieldSpec(snr=snr, random_seed=REPORTING_SEED + k)) for k in range(frames)]
        images = [f.image for f in fields]
        diameter = trackpy_diameter(spec.sigma)
        minmass = best(lambda m: trackpy_points([f.image for f in tuning], diameter, m), [0, 50, 100, 200, 400, 800, 1600], tuning)
        threshold = best(lambda t: blob_log_points([f.image for f in tuning], t), [0.01, 0.02, 0.04, 0.06, 0.08, 0.12], tuning)
        runs = {
            "seedtrack": lambda: seedtrack_points(images),
            f"trackpy (minmass {minmass:g})": lambda: trackpy_points(images, diameter, minmass),
            f"blob_log (thr {threshold:g})": lambda: blob_log_points(images, threshold),
        }
        bound = cramer_rao_rms(spec)
        print(f"{snr:>4g} Cramer-Rao bound, single spots: RMS {bound:.3f} px (2-D)")
        for name, run in runs.items():
            found = run()
            result = score(found, fields)
            fps = rate(lambda: len(run()))
            print(
                f"{snr:>4g} {name:<22} {result['recall']:>7.4f} {result['precision']:>9.4f} {result['rms']:>7.3f} {result['single_rms']:>7.3f} "
                f"{result['touching']:>8.3f} {result['rings']:>6.3f} {fps:>9.1f}"
            )
            rows.append([f"{snr:g}", name, f"{result['recall']:.3f}", f"{result['precision']:.3f}", f"{result['rms']:.3f}",
                         f"{result['single_rms']:.3f} ({bound:.3f})", f"{result['touching']:.2f}", f"{result['rings']:.2f}", f"{fps:.0f}"])
    settings_rows = small_spots_table(frames)
    if args.write_docs:
        write_table("detection.md", "detect-spots", SPOT_HEADER, rows)
        write_table("detection.md", "detect-spots-settings", SETTINGS_HEADER, settings_rows)


if __name__ == "__main__":
    main()
