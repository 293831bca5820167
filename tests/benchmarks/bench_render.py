"""Frames per second of the overlay renderer on one core: 200 tracks over 1920x1080 frames.

Run as ``python tests/benchmarks/bench_render.py [--write-docs]`` (``--write-docs`` also writes the
table into docs/cli.md, stamped: ``render-speed``); prints the median of several repeats for
drawing alone (what issue #5 asks: at least 30 frames/s) and, for reference, for drawing plus
H.264 encoding with the writer the ``render`` command uses.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from seedtrack.drawing import FalseDetections, TrackLayer, View, annotate, track_legend
from seedtrack.data.video import write_video
from seedtrack.tracking.tracks import Tracks
from tables import write_table

WIDTH, HEIGHT, TRACKS, FRAMES, TRAIL = 1920, 1080, 200, 40, 10


def scene(rng: np.random.Generator) -> tuple[list[np.ndarray], Tracks]:
    """Light noisy frames and 200 tracks wandering a few pixels per frame, 10% of positions interpolated."""
    # Camera-like frames: mild sensor noise softened by the optics (pure noise would make the
    # encoder figure meaninglessly slow).
    frames = [cv2.GaussianBlur(np.clip(rng.normal(190, 4, (HEIGHT, WIDTH, 3)), 0, 255).astype(np.uint8), (0, 0), 1.0) for _ in range(FRAMES)]
    start = rng.uniform([50, 50], [WIDTH - 50, HEIGHT - 50], (TRACKS, 2))
    steps = rng.normal(0, 6, (TRACKS, FRAMES, 2)) + rng.normal(0, 6, (TRACKS, 1, 2))
    xy = start[:, None] + np.cumsum(steps, axis=1)
    measurement = np.where(rng.random((TRACKS, FRAMES)) < 0.1, -1, 0)
    return frames, Tracks.from_dense(xy=xy, measurement=measurement)


def frames_per_second(render, count: int, repeats: int = 5) -> float:
    """Median frames/s of ``render()`` (which handles ``count`` frames) over ``repeats`` runs.

    Time is this process's CPU time: the renderer and encoder run on one thread, and CPU time does
    not count what other programs on a shared machine take.
    """
    rates = []
    for _ in range(repeats):
        start = time.process_time()
        render()
        rates.append(count / (time.process_time() - start))
    return statistics.median(rates)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write-docs", action="store_true", help="write the table into docs/cli.md, stamped")
    args = parser.parse_args()
    cv2.setNumThreads(1)  # one core, as the issue asks
    rng = np.random.default_rng(0)
    frames, tracks = scene(rng)
    view = View.of((WIDTH, HEIGHT))
    layer = TrackLayer(tracks, view, trail=TRAIL)
    points = tracks.xy + rng.normal(0, 30, tracks.xy.shape)
    frame = np.repeat(np.arange(FRAMES), TRACKS // 10)
    false = FalseDetections(frame, points[: TRACKS // 10, :, 0].T.ravel(), points[: TRACKS // 10, :, 1].T.ravel(), tracks, view)
    options = dict(false_detections=false, legend=track_legend(True))

    def draw() -> None:
        for index, image in enumerate(frames):
            annotate(image, index, view, [layer], **options)

    drawn = frames_per_second(draw, FRAMES)
    print(f"render {WIDTH}x{HEIGHT}, {TRACKS} tracks, trail {TRAIL}: {drawn:.1f} frames/s median (goal 30)")
    with tempfile.TemporaryDirectory() as folder:
        out = Path(folder) / "clip.mp4"

        def encode() -> None:
            write_video(out, (annotate(image, index, view, [layer], **options) for index, image in enumerate(frames)), 25.0)

        encoded = frames_per_second(encode, FRAMES, repeats=3)
    print(f"render + H.264 encode (one x264 thread): {encoded:.1f} frames/s median")
    if args.write_docs:
        scene_name = f"{WIDTH}x{HEIGHT}, {TRACKS} tracks, trail {TRAIL}, {FRAMES} frames"
        rows = [[scene_name, "drawing", f"{drawn:.1f}", "30"], [scene_name, "drawing + H.264 (one x264 thread)", f"{encoded:.1f}", "-"]]
        write_table("cli.md", "render-speed", ["scene", "work", "frames/s (CPU, one core, median)", "goal"], rows)


if __name__ == "__main__":
    main()
