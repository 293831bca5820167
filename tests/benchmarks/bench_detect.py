"""Frames per second of the blob detector on one core at 640x512 and 1920x1080.

Run as ``python tests/benchmarks/bench_detect.py``; prints the median of several repeats, with
the default options as ``seedtrack detect`` applies them (polarity decided once per clip) and
with the polarity decided again on every frame (``detect_blobs`` called alone).
Goal from issue #4: at least 200 frames/s at 640x512 and 30 frames/s at 1920x1080.
"""

from __future__ import annotations

import statistics
import time

import cv2
import numpy as np

from seedtrack.detection.blobs import BlobOptions, detect_blobs


def scene(width: int, height: int, n_seeds: int, rng: np.random.Generator) -> np.ndarray:
    """A light field with ``n_seeds`` dark discs of radius 4 px and a little noise."""
    frame = np.full((height, width), 200, np.uint8)
    for x, y in zip(rng.uniform(10, width - 10, n_seeds), rng.uniform(10, height - 10, n_seeds)):
        cv2.circle(frame, (int(x), int(y)), 4, 60, -1)
    noise = rng.normal(0, 4, frame.shape)
    return np.clip(frame + noise, 0, 255).astype(np.uint8)


def frames_per_second(frames: list[np.ndarray], options: BlobOptions, clock=time.process_time, repeats: int = 5) -> float:
    """Median frames/s of :func:`detect_blobs` over ``repeats`` passes through ``frames``.

    The default clock is this process's CPU time, which a busy shared machine does not inflate
    the way it inflates wall-clock time.
    """
    rates = []
    for _ in range(repeats):
        start = clock()
        for frame in frames:
            detect_blobs(frame, options)
        rates.append(len(frames) / (clock() - start))
    return statistics.median(rates)


def main() -> None:
    cv2.setNumThreads(1)  # one core, as the issue asks
    rng = np.random.default_rng(0)
    for width, height, goal in ((640, 512, 200), (1920, 1080, 30)):
        frames = [scene(width, height, 80, rng) for _ in range(20)]
        once = frames_per_second(frames, BlobOptions(polarity="dark"))
        every = frames_per_second(frames, BlobOptions())
        wall = frames_per_second(frames, BlobOptions(polarity="dark"), clock=time.perf_counter)
        print(
            f"detect {width}x{height}: {once:.0f} frames per CPU second (median), {every:.0f} deciding polarity "
            f"per frame; {wall:.0f} frames/s by the wall clock (goal {goal})"
        )


if __name__ == "__main__":
    main()
