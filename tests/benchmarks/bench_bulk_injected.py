"""Faint beads of known position put into real bead footage: recall and error, beside trackpy.

Run as ``python tests/benchmarks/bench_bulk_injected.py [SEED]`` (default 1000; seed 0 was looked
at while the detector was changed). Real footage has no truth, so truth is added to it: on every
6th frame of ``bulk-water-240-479.mp4`` (40 frames, 1 um beads dark on light, compressed),
dark Gaussian spots are added at known sub-pixel positions on a grid 24 px apart, jittered by
up to 4 px (about 440 a frame), and the frame rounded back to 8 bits. Their size and depth are
those of the clip's own beads: the mean profile of trackpy's confident tracks there (trackpy
signal under 3: depth 2.8 grey levels, sigma 2.8 px; 3 to 5: 5.5 and 3.0; 5 to 10: 12 and 2.5,
taken here at 8 and 1.8, an in-focus faint bead). The real scene around them is what makes it
hard: the beads, their out-of-focus rings and the compression.

- seedtrack: as ``seedtrack detect`` runs by default (:class:`seedtrack.detection.clip.ClipDetector`,
  its decisions on the first frame), nothing given.
- trackpy: ``locate(diameter=11, minmass=20, invert=True)``, as its tutorial runs it on this
  clip (and ``separation=3``, without its 12 px exclusion zone about each feature).

A spot is found when a detection lies within 2 px of it. *clear*: spots with no feature of
trackpy (separation 3) on the untouched frame within 8 px (spots laid on a bead are no test of
anything); RMS: the per-axis error over the clear spots that every column found.
"""

from __future__ import annotations

import sys
import warnings

import numpy as np
import trackpy
from scipy.spatial import cKDTree

from bench_bulk_water import CLIP
from seedtrack.data.frames import open_frames
from seedtrack.detection.blobs import to_gray
from seedtrack.detection.clip import ClipDetector

EVERY = 6
SPACING_PX = 24
JITTER_PX = 4.0
TOLERANCE_PX = 2.0
CLEAR_PX = 8.0
# (depth in grey levels, sigma px) of the beads put in.
BEADS = ((2.8, 2.8), (5.5, 3.0), (8.0, 1.8))


def inject(frame: np.ndarray, depth: float, sigma: float, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """The frame with dark Gaussian spots added on a jittered grid, and their centres (x, y)."""
    height, width = frame.shape
    gy, gx = np.mgrid[16 : height - 16 : SPACING_PX, 16 : width - 16 : SPACING_PX]
    xy = np.column_stack((gx.ravel(), gy.ravel())) + rng.uniform(-JITTER_PX, JITTER_PX, (gx.size, 2))
    rows, columns = np.mgrid[0:height, 0:width]
    spots = np.zeros((height, width))
    for x, y in xy:
        box = slice(int(y) - 8, int(y) + 9), slice(int(x) - 8, int(x) + 9)
        spots[box] += np.exp(-((columns[box] - x) ** 2 + (rows[box] - y) ** 2) / (2 * sigma**2))
    return np.clip(np.round(frame - depth * spots), 0, 255).astype(np.uint8), xy


def seedtrack_points(frames: list[np.ndarray]) -> list[np.ndarray]:
    detector = ClipDetector()
    return [np.column_stack((t["x"], t["y"])) for t in (detector.detect(f) for f in frames)]


def trackpy_points(frames: list[np.ndarray], **options) -> list[np.ndarray]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return [trackpy.locate(f, 11, minmass=20, invert=True, **options)[["x", "y"]].to_numpy() for f in frames]


def nearest(points: np.ndarray, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance from each true centre to the nearest point, and that point's index."""
    if len(points) == 0:
        return np.full(len(xy), np.inf), np.zeros(len(xy), int)
    return cKDTree(points).query(xy)


def main() -> None:
    seed = int(sys.argv[1]) if len(sys.argv) > 1 else 1000
    with open_frames(CLIP) as source:
        frames = [to_gray(image) for index, image in source if index % EVERY == 0]
    # Objects of the untouched frames, found alike whichever version of seedtrack runs.
    untouched = trackpy_points(frames, separation=3)
    print(f"{CLIP.name}: {len(frames)} frames, seed {seed}; found within {TOLERANCE_PX:g} px (all / clear), per-axis RMS px over clear spots found by every column")
    print("| depth, sigma | spots (clear) | seedtrack | trackpy | trackpy, separation 3 | RMS seedtrack / trackpy / separation 3 |")
    print("| --- | --- | --- | --- | --- | --- |")
    for depth, sigma in BEADS:
        rng = np.random.default_rng(seed)
        injected, truth = zip(*(inject(f, depth, sigma, rng) for f in frames))
        clear = np.concatenate([nearest(u, xy)[0] > CLEAR_PX for u, xy in zip(untouched, truth)])
        columns = [seedtrack_points(list(injected)), trackpy_points(list(injected)), trackpy_points(list(injected), separation=3)]
        found, errors = [], []
        for points in columns:
            hits = [nearest(p, xy) for p, xy in zip(points, truth)]
            distance = np.concatenate([d for d, _ in hits])
            offset = np.vstack([p[np.minimum(i, len(p) - 1)] - xy if len(p) else np.full_like(xy, np.inf) for (_, i), p, xy in zip(hits, points, truth)])
            found.append(distance <= TOLERANCE_PX)
            errors.append(offset)
        every = clear & np.all(found, axis=0)
        cells = [f"{f.mean():.3f} / {f[clear].mean():.3f}" for f in found]
        rms = " / ".join(f"{np.sqrt(np.mean(e[every] ** 2)):.3f}" for e in errors)
        print(f"| {depth:g}, {sigma:g} | {clear.size} ({clear.sum()}) | {' | '.join(cells)} | {rms} ({every.sum()} spots) |")


if __name__ == "__main__":
    main()
