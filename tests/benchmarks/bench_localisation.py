"""The detectors' localisation error estimate (``ep``) against the truth of generated frames.

Run as ``python tests/benchmarks/bench_localisation.py [frames] [--write-docs]`` (``--write-docs``
writes the table into ``docs/detection.md``). Gaussian spots of known
sub-pixel centres (``seedtrack.data.spotfield``: sigma 1.5 px, Poisson noise on 10 photons a
pixel plus read noise 1) at several signal-to-noise ratios, and generated dishes of seeds (the
blob detector), each detected with the default choices as ``detect`` makes them; and the spots
at SNR 4 rounded to 8 bits, then JPEG-compressed (quality 90 and 75), whose noise compression
takes off. Per setting:
the detections matched to the truth within 2 px (single spots: touching pairs and rings left
out), the root mean square of their ``ep`` (the estimate) beside the root mean square of their
true error per axis (the measurement), and for spots the Cramer-Rao bound per axis. Reporting
seeds 2000.. for spots and 100.. for dishes; the estimate was built looking at spot seeds 0-1,
single generated spots, and seeds 1000-1003 (where the JPEG rows showed the pixel noise's
shortfall under compression, and the noise at the spots' scale was taken instead).
"""

from __future__ import annotations

import argparse

import cv2
import numpy as np

from seedtrack.data.dish import DishSpec, make_dish_scene
from seedtrack.data.spotfield import SpotFieldSpec, make_spot_field
from seedtrack.detection.clip import ClipDetector
from seedtrack.tracking.metrics import match_frame
from tables import write_table

SNRS = (2, 2.5, 3, 4, 6, 10)
TOLERANCE_PX = 2.0


def cramer_rao_axis(spec: SpotFieldSpec) -> float:
    """Mortensen's per-axis bound (Nature Methods 7, 377, 2010) for one spot of ``spec``, pixels."""
    floor = spec.background + spec.read_noise**2
    amplitude = (spec.snr**2 + np.sqrt(spec.snr**4 + 4 * spec.snr**2 * floor)) / 2
    photons = 2 * np.pi * spec.sigma**2 * amplitude
    width = spec.sigma**2 + 1 / 12
    tau = 2 * np.pi * width * floor / photons
    return float(np.sqrt(width / photons * (1 + 4 * tau + np.sqrt(2 * tau / (1 + 4 * tau)))))


def matched(found: dict[str, np.ndarray], truth: np.ndarray, wanted: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(estimates, true errors per axis) of the detections matched to the ``wanted`` truths."""
    points = np.column_stack((found["x"], found["y"]))
    rows, cols = match_frame(points, truth, TOLERANCE_PX)
    keep = wanted[cols]
    return found["ep"][rows[keep]], (points[rows[keep]] - truth[cols[keep]]).ravel()


def rms(values: list[np.ndarray]) -> float:
    return float(np.sqrt(np.mean(np.square(np.concatenate(values)))))


HEADER = ["setting", "detections matched", "ep (RMS), px", "true RMS error per axis, px", "ratio", "Cramer-Rao bound, px"]


def row(name: str, estimates: list[np.ndarray], errors: list[np.ndarray], bound: str = "") -> list[str]:
    """One row of the table, printed as it is made."""
    shown, true = rms(estimates), rms(errors)
    cells = [name, str(sum(e.size for e in estimates)), f"{shown:.3f}", f"{true:.3f}", f"{shown / true:.2f}", bound]
    print(f"{cells[0]:<30} {cells[1]:>7} {cells[2]:>9} {cells[3]:>9} {cells[4]:>6} {cells[5]:>6}")
    return cells


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("frames", nargs="?", type=int, default=4, help="frames per setting (default 4)")
    parser.add_argument("--write-docs", action="store_true", help="write the table into docs/detection.md, stamped")
    args = parser.parse_args()
    frames, rows = args.frames, []
    print(f"Gaussian spots, sigma 1.5 px, 200 per 512x512 frame, {frames} frames per SNR (seeds 2000..); single spots matched within {TOLERANCE_PX:g} px")
    print(f"{'setting':<30} {'matched':>7} {'ep (RMS)':>9} {'true RMS':>9} {'ratio':>6} {'bound':>6}")
    for snr in SNRS:
        estimates, errors = [], []
        for k in range(frames):
            spec = SpotFieldSpec(snr=snr, random_seed=2000 + k)
            field = make_spot_field(spec)
            estimate, error = matched(ClipDetector(roi="none").detect(field.image), field.xy, field.kind == "single")
            estimates.append(estimate)
            errors.append(error)
        rows.append(row(f"spots, SNR {snr:g}", estimates, errors, f"{cramer_rao_axis(spec):.3f}"))
    for quality in (None, 90, 75):
        estimates, errors = [], []
        for k in range(frames):
            field = make_spot_field(SpotFieldSpec(snr=4, random_seed=2000 + k))
            image = np.clip(np.round(field.image), 0, 255).astype(np.uint8)
            if quality is not None:
                image = cv2.imdecode(cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, quality])[1], cv2.IMREAD_GRAYSCALE)
            estimate, error = matched(ClipDetector(roi="none").detect(image), field.xy, field.kind == "single")
            estimates.append(estimate)
            errors.append(error)
        rows.append(row("spots, SNR 4, 8-bit" + (f", JPEG {quality}" if quality else ""), estimates, errors))
    for name, options in (("dish, 80 seeds", {}), ("dense dish, 200 seeds", dict(seeds=200, width=320, height=240, rim_speed=10.0, separation=7.0))):
        estimates, errors = [], []
        for seed in (100, 101):
            scene = make_dish_scene(DishSpec(frames=2 * frames, random_seed=seed, **options))
            detector = ClipDetector()
            for k, image in enumerate(scene.frames()):
                shown = np.flatnonzero(scene.visible[:, k])
                estimate, error = matched(detector.detect(image), scene.truth.xy[shown, k], np.ones(shown.size, bool))
                estimates.append(estimate)
                errors.append(error)
        rows.append(row(name + " (blobs)", estimates, errors))
    if args.write_docs:
        write_table("detection.md", "localisation-error", HEADER, rows)


if __name__ == "__main__":
    main()
