"""Frames per second of the detectors on one core, and of decoding with and without detection.

Run as ``python tests/benchmarks/bench_detect.py [--write-docs]`` (``--write-docs`` also writes
its two tables into docs/detection.md, stamped: ``detect-speed``, ``detect-pipeline``); prints medians of several repeats, in CPU
seconds of this process (a busy shared machine inflates wall-clock time):

- the blob detector with the default options as ``seedtrack detect`` applies them (polarity
  decided once per clip) and with the polarity decided again on every frame, on 80 dark discs;
- the spot detector (settings fitted once per clip) on 300 Gaussian spots at signal-to-noise 4;
- on trackpy's bulk-water clip, a generated 300-frame 640x512 dish of 80 seeds and a 200-frame
  1280x960 dish of 200 seeds, the detector each gets by default (:class:`seedtrack.detection.clip.ClipDetector`) alone, and
  decoding alone and decoding plus that detector (decoding threads as the reader sets them,
  detection on one core), in CPU seconds;
- the same as ``seedtrack`` runs it (:func:`seedtrack.pipeline.detect_clip`: decoding in a
  thread of its own beside detection in 1 or 2 threads, ``--workers`` 1 and 2), in wall-clock seconds of the work
  alone (a fresh process each, imports not counted), on the same clips; decoding alone and
  each way of detecting are run in turn, and the ratio is taken within each turn. Wall-clock
  time is only meaningful on a quiet machine: the load average is printed beside it, and the
  ratio of the processor seconds of the whole process (all its threads), which a busy machine
  moves less.

Goals from issues #4 and #16: at least 200 frames/s at 640x512 and 30 frames/s at 1920x1080 for
the detector alone; decoding plus detection at least 0.8 times decoding alone.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from seedtrack.data.dish import DishSpec, write_dish_clip
from seedtrack.data.frames import open_frames
from seedtrack.data.spotfield import SpotFieldSpec, make_spot_field
from seedtrack.detection.blobs import BlobOptions, detect_blobs, to_gray
from seedtrack.detection.clip import ClipDetector
from seedtrack.detection.spots import detect_spots, fit_spot_settings
from tables import write_table

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


# Run in a fresh process: decode the clip (workers 0) or detect it as ``seedtrack`` does, and
# print the wall-clock seconds of that work alone.
_TIMED = """
import sys, time
from pathlib import Path
from seedtrack.data.frames import open_frames
from seedtrack.pipeline import detect_clip
if __name__ == "__main__":
    clip, workers = Path(sys.argv[1]), int(sys.argv[2])
    start, used = time.perf_counter(), time.process_time()
    if workers == 0:
        with open_frames(clip) as source:
            for _ in source:
                pass
    else:
        detect_clip(clip, workers=workers, say=None)
    print(time.perf_counter() - start, time.process_time() - used)
"""


def pipeline_seconds(clip: Path, workers: int) -> tuple[float, float]:
    """Wall-clock and processor seconds of decoding ``clip`` (``workers`` 0) or of
    ``detect_clip`` on it."""
    with tempfile.TemporaryDirectory() as folder:
        script = Path(folder) / "timed.py"
        script.write_text(_TIMED)
        done = subprocess.run([sys.executable, str(script), str(clip), str(workers)], check=True, capture_output=True, text=True)
    wall, used = done.stdout.split()[-2:]
    return float(wall), float(used)


PIPELINE_HEADER = ["clip", "decoding alone, frames/s", "workers", "decoding + detection, frames/s", "of decoding alone", "processor time, of decoding alone"]
SPEED_HEADER = ["frames", "detector", "frames/s, one core", "goal"]


def pipeline_table(clips: dict[str, Path], repeats: int = 5) -> list[list[str]]:
    """Decoding alone beside decoding plus detection as ``seedtrack`` runs it, wall clock."""
    print(f"decoding + detection as seedtrack runs it (wall clock, median of {repeats}; load average {os.getloadavg()[0]:.1f}):")
    print("| " + " | ".join(PIPELINE_HEADER) + " |")
    print("| --- " * len(PIPELINE_HEADER) + "|")
    rows = []
    for name, clip in clips.items():
        with open_frames(clip) as source:
            frames = source.frame_count
        turns = [[pipeline_seconds(clip, workers) for workers in (0, 1, 2)] for _ in range(repeats)]
        alone = statistics.median(turn[0][0] for turn in turns)
        for column, workers in ((1, 1), (2, 2)):
            both = statistics.median(turn[column][0] for turn in turns)
            ratio = statistics.median(turn[0][0] / turn[column][0] for turn in turns)
            used = statistics.median(turn[0][1] / turn[column][1] for turn in turns)
            rows.append([name, f"{frames / alone:.0f}", str(workers), f"{frames / both:.0f}", f"{ratio:.2f} x", f"{used:.2f} x"])
            print("| " + " | ".join(rows[-1]) + " |")
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write-docs", action="store_true", help="write the tables into docs/detection.md, stamped")
    args = parser.parse_args()
    cv2.setNumThreads(1)  # one core, as the issues ask
    rng = np.random.default_rng(0)
    speed: list[list[str]] = []
    pipeline: list[list[str]] = []
    for width, height, goal in ((640, 512, 200), (1920, 1080, 30)):
        frames = [scene(width, height, 80, rng) for _ in range(20)]
        once = frames_per_second(frames, lambda f: detect_blobs(f, BlobOptions(polarity="dark")))
        every = frames_per_second(frames, lambda f: detect_blobs(f, BlobOptions()))
        print(f"blob detector {width}x{height}: {once:.0f} frames/s (median), {every:.0f} deciding polarity per frame (goal {goal})")
        speed.append([f"{width}x{height}, 80 dark discs", "blob", f"{once:.0f}", str(goal)])
        spots = [make_spot_field(SpotFieldSpec(width=width, height=height, spots=300 * width * height // (640 * 512), snr=4.0, random_seed=k)).image for k in range(10)]
        settings = fit_spot_settings(spots[0], "light")
        rate = frames_per_second(spots, lambda f: detect_spots(f, settings))
        print(f"spot detector {width}x{height}, 300 spots per 640x512 at SNR 4 (diameter {settings.diameter}): {rate:.0f} frames/s (goal {goal})")
        speed.append([f"{width}x{height}, 300 spots per 640x512 at SNR 4", f"spot (diameter {settings.diameter})", f"{rate:.0f}", str(goal)])
    if CLIP.exists():
        pipeline = clip_tables(speed)
    if args.write_docs:
        write_table("detection.md", "detect-speed", SPEED_HEADER, speed)
        if pipeline:
            write_table("detection.md", "detect-pipeline", PIPELINE_HEADER, pipeline)


def clip_tables(speed: list[list[str]]) -> list[list[str]]:
    """The bulk-water clip and two generated dishes: each one's detector alone (a row added to
    ``speed``) and decoding with and without it, on one core and as ``seedtrack`` runs it."""
    with tempfile.TemporaryDirectory() as folder:
        dish, large = Path(folder) / "dish" / "clip.mp4", Path(folder) / "large" / "clip.mp4"
        write_dish_clip(DishSpec(seeds=80, frames=300, width=640, height=512, rim_speed=20.0), dish.parent)
        write_dish_clip(DishSpec(seeds=200, frames=200, width=1280, height=960, rim_speed=20.0, random_seed=1000), large.parent)
        clips = {CLIP.name: CLIP, "dish, 80 seeds, 640x512": dish, "dish, 200 seeds, 1280x960": large}
        for name, clip in clips.items():
            speed.append(one_core(name, clip))
        return pipeline_table(clips)


def one_core(name: str, clip: Path) -> list[str]:
    """The detector ``seedtrack`` picks for ``clip`` alone, and decoding with and without it,
    on one core in CPU time."""
    with open_frames(clip, end=40) as source:
        frames = [to_gray(image) for _, image in source]
    detector = ClipDetector()
    detector.detect(frames[0])
    rate = frames_per_second(frames, detector.detect, repeats=3)
    print(f"{name} ({frames[0].shape[1]}x{frames[0].shape[0]}): {detector.choice.name} detector alone {rate:.0f} frames/s; {detector.choice.reason}")
    alone, both = decoding_rate(clip), decoding_rate(clip, detector.detect)
    print(f"  one core, CPU time: decoding alone {alone:.0f} frames/s, decoding + detection {both:.0f} frames/s: {both / alone:.2f} x (goal 0.8)")
    return [f"{name} ({frames[0].shape[1]}x{frames[0].shape[0]})", detector.choice.name, f"{rate:.0f}", ""]

if __name__ == "__main__":
    main()
