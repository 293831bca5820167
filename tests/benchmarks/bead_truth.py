"""Hand-marked beads of the bulk-water clip: the marking pages, and the truth written from the marks.

Run as ``python tests/benchmarks/bead_truth.py pages OUT_DIR`` to render the pages that were looked
at, or ``python tests/benchmarks/bead_truth.py write`` to write ``tests/data/bulk_water_beads/truth.csv``
from the marks in ``marks.json`` beside it (see the README there for how they were made).

A page shows one crop of 100 x 100 px of one frame at 4x: the raw crop on the left (grey levels
stretched from the frame's 0.2th to 99.8th percentile, as for any look at a low-contrast frame) and
the same crop on the right with every local minimum of the frame smoothed by a 1.5 px Gaussian that
lies 0.7 grey levels below its 21 px surroundings, numbered. These numbers are only handles for
writing marks down: a person decides from the left picture which are beads, and adds by
coordinates any bead that has no number.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import cv2
import numpy as np

from seedtrack.data.frames import open_frames
from seedtrack.detection.blobs import to_gray

HERE = Path(__file__).resolve().parent
TRUTH_DIR = HERE.parent / "data" / "bulk_water_beads"
CLIP = next(
    (folder / "shared" / "data" / "bulk-water-240-479.mp4" for folder in HERE.parents if (folder / "shared" / "data").is_dir()),
    Path("bulk-water-240-479.mp4"),
)
# Top-left corners (x, y) of the crops, pixels, chosen away from the parts of frame 0 looked at
# while the detector's rule was made; each crop is SIDE pixels square.
CROPS = {"A": (20, 300), "B": (480, 30), "C": (400, 300)}
SIDE = 100
# Ten frames a second apart (0-based indices in the clip).
FRAMES = tuple(range(12, 240, 24))
ZOOM = 4


def grey_frames(clip: Path = CLIP) -> list[np.ndarray]:
    with open_frames(clip) as source:
        return [to_gray(image) for _, image in source]


def handles(frame: np.ndarray, crop: str) -> list[tuple[int, int]]:
    """The numbered local minima of a crop, in the order the pages number them (row by row)."""
    x0, y0 = CROPS[crop]
    dark = cv2.GaussianBlur(-frame.astype(np.float32), (0, 0), 1.5)
    peak = (dark == cv2.dilate(dark, np.ones((5, 5), np.uint8))) & (dark - cv2.blur(dark, (21, 21)) > 0.7)
    rows, columns = np.nonzero(peak)
    inside = (columns >= x0) & (columns < x0 + SIDE) & (rows >= y0) & (rows < y0 + SIDE)
    return [(int(x), int(y)) for x, y in zip(columns[inside], rows[inside])]


def page(frame: np.ndarray, crop: str) -> np.ndarray:
    """The marking page of one crop of one frame (BGR)."""
    x0, y0 = CROPS[crop]
    low, high = np.percentile(frame, [0.2, 99.8])
    part = np.clip((frame[y0 : y0 + SIDE, x0 : x0 + SIDE].astype(float) - low) / (high - low) * 255, 0, 255).astype(np.uint8)
    raw = cv2.cvtColor(cv2.resize(part, None, fx=ZOOM, fy=ZOOM, interpolation=cv2.INTER_CUBIC), cv2.COLOR_GRAY2BGR)
    numbered = raw.copy()
    for number, (x, y) in enumerate(handles(frame, crop)):
        at = (int((x - x0 + 0.5) * ZOOM), int((y - y0 + 0.5) * ZOOM))
        cv2.circle(numbered, at, 3, (0, 0, 255), -1)
        cv2.putText(numbered, str(number), (at[0] + 4, at[1] - 3), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (200, 0, 0), 1, cv2.LINE_AA)
    return np.hstack([raw, np.full((SIDE * ZOOM, 6, 3), 255, np.uint8), numbered])


def centre(frame: np.ndarray, x: float, y: float) -> tuple[float, float]:
    """A mark moved onto the darkest point near it: the vertex of a parabola through the smoothed
    frame's minimum pixel and its neighbours, each way (at most half a pixel from that pixel)."""
    dark = cv2.GaussianBlur(-frame.astype(np.float32), (0, 0), 1.5)
    column, row = int(round(x)), int(round(y))
    around = dark[row - 2 : row + 3, column - 2 : column + 3]
    dy, dx = np.unravel_index(int(np.argmax(around)), around.shape)
    row, column = row + dy - 2, column + dx - 2
    w = dark[row - 1 : row + 2, column - 1 : column + 2]
    shift_x = (w[1, 2] - w[1, 0]) / (2 * (2 * w[1, 1] - w[1, 0] - w[1, 2]) + 1e-9)
    shift_y = (w[2, 1] - w[0, 1]) / (2 * (2 * w[1, 1] - w[0, 1] - w[2, 1]) + 1e-9)
    return column + float(np.clip(shift_x, -0.5, 0.5)), row + float(np.clip(shift_y, -0.5, 0.5))


def write_truth(frames: list[np.ndarray]) -> Path:
    marks = json.loads((TRUTH_DIR / "marks.json").read_text())
    lines = ["frame,crop,x,y"]
    for crop in CROPS:
        for index in FRAMES:
            key = f"{crop}{index:03d}"
            frame = frames[index]
            numbered = handles(frame, crop)
            points = [numbered[n] for n in marks["numbers"][key]] + [tuple(p) for p in marks["added"].get(key, [])]
            for x, y in sorted(centre(frame, x, y) for x, y in points):
                lines.append(f"{index},{crop},{x:.2f},{y:.2f}")
    out = TRUTH_DIR / "truth.csv"
    out.write_text("\n".join(lines) + "\n")
    return out


def main() -> None:
    if len(sys.argv) < 2 or sys.argv[1] not in ("pages", "write") or (sys.argv[1] == "pages" and len(sys.argv) != 3):
        sys.exit("usage: bead_truth.py pages OUT_DIR | bead_truth.py write")
    frames = grey_frames()
    if sys.argv[1] == "write":
        print(write_truth(frames))
        return
    out = Path(sys.argv[2])
    out.mkdir(parents=True, exist_ok=True)
    for crop in CROPS:
        for index in FRAMES:
            cv2.imwrite(str(out / f"{crop}{index:03d}.png"), page(frames[index], crop))


if __name__ == "__main__":
    main()
