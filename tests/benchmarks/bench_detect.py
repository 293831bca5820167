"""Frames per second of the detectors on one core, and of decoding with and without detection.

Run as ``python tests/benchmarks/bench_detect.py``; prints medians of several repeats, in CPU
seconds of this process (a busy shared machine inflates wall-clock time):

- the blob detector with the default options as ``seedtrack detect`` applies them (polarity
  decided once per clip) and with the polarity decided again on every frame, on 80 dark discs;
- the spot detector (settings fitted once per clip) on 300 Gaussian spots at signal-to-noise 4
  and on trackpy's bulk-water clip;
- decoding the bulk-water clip alone, and decoding plus the detector the clip gets by default
  (decoding threads as the reader sets them, detection on one core).

Goals from issues #4 and #16: at least 200 frames/s at 640x512 and 30 frames/s at 1920x1080 for
the detector alone; decoding plus detection at least 0.8 times decoding alone.
"""

from __future__ import annotations

import statistics
import time
from pathlib import Path

import cv2
import numpy as np

from seedtrack.data.frames import open_frames
from seedtrack.data.spotfield import SpotFieldSpec, make_spot_field
from seedtrack.detection.blobs import BlobOptions, detect_blobs, to_gray
from seedtrack.detection.choice import choose_detector
from seedtrack.detection.spots import detect_spots, fit_spot_settings

CLIP = next(
    (folder / "shared" / "data" / "bulk-water-240-479.mp4" for folder in Path(__file__).resolve().parents if (folder / "shared" / "data").is_dir()),
    Path("bulk-water-240-479.mp4"),
)


def scene(width: int, height: int, n_seeds: int, rng: np.random.Generator) -> np.ndarray:
    """A light field with ``n_seeds`` dark discs of radius 4 px and a little noise."""
    frame = np.full((height, width), 200, np.uint8)
    for x, y in zip(rng.uniform(10, width - 10, n_seeds), rng.uniform(10, height - 10, n_seeds)):
        cv2.circle(frame, (int(x), int(y)), 4, 60, -1)
    noise = rng.normal(0, 4, frame.shape)
    return np.clip(frame + noise, 0, 255).astype(np.uint8)


def frames_per_second(frames: list[np.ndarray], detect, clock=time.process_time, repeats: int = 5) -> float:
    """Median frames/s of ``detect(frame)`` over ``repeats`` passes through ``frames``."""
    rates = []
    for _ in range(repeats):
        start = clock()
        for frame in frames:
            detect(frame)
        rates.append(len(frames) / (clock() - start))
    return statistics.median(rates)


def decoding_rate(clip: Path, detect=None, repeats: int = 3) -> float:
    """Median frames per CPU second of reading ``clip`` as grey frames, detecting if asked."""
    rates = []
    for _ in range(repeats):
        start, count = time.process_time(), 0
        with open_frames(clip) as source:
            for _, image in source:
                gray = to_gray(image)
                if detect is not None:
                    detect(gray)
                count += 1
        rates.append(count / (time.process_time() - start))
    return statistics.median(rates)


def main() -> None:
    cv2.setNumThreads(1)  # one core, as the issues ask
    rng = np.random.default_rng(0)
    for width, height, goal in ((640, 512, 200), (1920, 1080, 30)):
        frames = [scene(width, height, 80, rng) for _ in range(20)]
        once = frames_per_second(frames, lambda f: detect_blobs(f, BlobOptions(polarity="dark")))
        every = frames_per_second(frames, lambda f: detect_blobs(f, BlobOptions()))
        print(f"blob detector {width}x{height}: {once:.0f} frames/s (median), {every:.0f} deciding polarity per frame (goal {goal})")
        spots = [make_spot_field(SpotFieldSpec(width=width, height=height, spots=300 * width * height // (640 * 512), snr=4.0, random_seed=k)).image for k in range(10)]
        settings = fit_spot_settings(spots[0], "light")
        rate = frames_per_second(spots, lambda f: detect_spots(f, settings))
        print(f"spot detector {width}x{height}, 300 spots per 640x512 at SNR 4 (diameter {settings.diameter}): {rate:.0f} frames/s (goal {goal})")
    if not CLIP.exists():
        return
    with open_frames(CLIP, end=40) as source:
        frames = [to_gray(image) for _, image in source]
    choice = choose_detector(frames[0], "dark")
    if choice.spots is not None:
        settings = choice.spots
        rate = frames_per_second(frames, lambda f: detect_spots(f, settings), repeats=3)
        detect = lambda f: detect_spots(f, settings)
    else:
        rate = frames_per_second(frames, lambda f: detect_blobs(f, BlobOptions(polarity="dark")), repeats=3)
        detect = lambda f: detect_blobs(f, BlobOptions(polarity="dark"))
    print(f"{CLIP.name} ({frames[0].shape[1]}x{frames[0].shape[0]}): {choice.name} detector alone {rate:.0f} frames/s; {choice.reason}")
    alone, both = decoding_rate(CLIP), decoding_rate(CLIP, detect)
    print(f"  decoding alone {alone:.0f} frames/s, decoding + detection {both:.0f} frames/s: {both / alone:.2f} x (goal 0.8)")


if __name__ == "__main__":
    main()
