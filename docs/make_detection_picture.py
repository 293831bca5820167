"""Remake docs/pictures/bulk-water-spots.png: ``python docs/make_detection_picture.py [CLIP]``.

One 100 x 100 px crop of bulk water (frame 108, crop C of the beads marked by looking, see
tests/data/bulk_water_beads) at 3x, three times side by side: the raw crop (grey levels stretched
from the frame's 0.2th to 99.8th percentile), the spot detector's detections with default options
ringed in red, and trackpy's at its walkthrough settings (diameter 11, minmass 20, invert) ringed in
blue; a small green dot on each bead marked by looking.
"""

from __future__ import annotations

import sys
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
import trackpy
from PIL import Image

from seedtrack.data.frames import open_frames
from seedtrack.detection.blobs import to_gray
from seedtrack.detection.clip import ClipDetector, detect_frames

HERE = Path(__file__).resolve().parent
CLIP = next(
    (folder / "shared" / "data" / "bulk-water-240-479.mp4" for folder in HERE.parents if (folder / "shared" / "data").is_dir()),
    Path("bulk-water-240-479.mp4"),
)
FRAME, X0, Y0, SIDE, ZOOM = 108, 400, 300, 100, 3


def main(clip: Path) -> None:
    with open_frames(clip, end=FRAME + 1) as source:
        frames = {index: to_gray(image) for index, image in source if index in (0, FRAME)}
    found = detect_frames(sorted(frames.items()), ClipDetector())
    ours = found.frame(1)
    trackpy.quiet()
    theirs = trackpy.locate(frames[FRAME], diameter=11, minmass=20, invert=True)
    truth = pd.read_csv(HERE.parent / "tests" / "data" / "bulk_water_beads" / "truth.csv")
    marks = truth[(truth["frame"] == FRAME) & (truth["crop"] == "C")]
    frame = frames[FRAME]
    low, high = np.percentile(frame, [0.2, 99.8])
    crop = np.clip((frame[Y0 : Y0 + SIDE, X0 : X0 + SIDE].astype(float) - low) / (high - low) * 255, 0, 255).astype(np.uint8)
    raw = cv2.cvtColor(cv2.resize(crop, None, fx=ZOOM, fy=ZOOM, interpolation=cv2.INTER_CUBIC), cv2.COLOR_GRAY2BGR)

    def at(x: float, y: float) -> tuple[int, int]:
        return int(round((x - X0 + 0.5) * ZOOM - 0.5)), int(round((y - Y0 + 0.5) * ZOOM - 0.5))

    def ringed(xs, ys, colour) -> np.ndarray:
        page = raw.copy()
        for x, y in zip(marks["x"], marks["y"]):
            cv2.circle(page, at(x, y), 2, (0, 170, 0), -1, cv2.LINE_AA)
        for x, y in zip(xs, ys):
            if X0 - 3 <= x < X0 + SIDE + 3 and Y0 - 3 <= y < Y0 + SIDE + 3:
                cv2.circle(page, at(x, y), 4 * ZOOM, colour, 1, cv2.LINE_AA)
        return page

    gap = np.full((SIDE * ZOOM, 6, 3), 255, np.uint8)
    picture = np.hstack([raw, gap, ringed(ours["x"], ours["y"], (0, 0, 230)), gap, ringed(theirs["x"], theirs["y"], (230, 80, 0))])
    band = np.full((24, picture.shape[1], 3), 255, np.uint8)
    for text, left in (("raw, 3x", 4), ("seedtrack defaults", SIDE * ZOOM + 10), ("trackpy walkthrough", 2 * SIDE * ZOOM + 16)):
        cv2.putText(band, text, (left, 17), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 0, 0), 1, cv2.LINE_AA)
    # Reduced to 256 colours, as the README's pictures are, to stay small.
    rgb = Image.fromarray(cv2.cvtColor(np.vstack([band, picture]), cv2.COLOR_BGR2RGB))
    rgb.quantize(256).save(HERE / "pictures" / "bulk-water-spots.png", optimize=True)


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else CLIP)
