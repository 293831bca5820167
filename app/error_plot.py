"""A line chart of tracking errors per frame, drawn with OpenCV so no plotting library is needed."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from data.atomic import atomic_path
from data.errors import DataError

from .overlay import PALETTE_BGR

_WIDTH, _HEIGHT = 960, 420
_LEFT, _RIGHT, _TOP, _BOTTOM = 70, 20, 50, 60
_FONT = cv2.FONT_HERSHEY_SIMPLEX


def draw_error_plot(frames: np.ndarray, series: dict[str, np.ndarray], title: str) -> np.ndarray:
    """Draw counts per frame as coloured lines on white, with axes, ticks and a legend.

    Parameters
    ----------
    frames : ndarray of int
        0-based frame index of each value.
    series : dict of str to ndarray
        Legend label to one count per frame.
    title : str

    Returns
    -------
    ndarray of uint8, shape (420, 960, 3) BGR
    """
    canvas = np.full((_HEIGHT, _WIDTH, 3), 255, np.uint8)
    x0, x1, y0, y1 = _LEFT, _WIDTH - _RIGHT, _HEIGHT - _BOTTOM, _TOP
    top = max(1, int(max((values.max() for values in series.values() if values.size), default=1)))
    span = max(1, int(frames[-1] - frames[0])) if frames.size else 1

    def to_pixel(frame, value):
        x = x0 + (np.asarray(frame) - (frames[0] if frames.size else 0)) / span * (x1 - x0)
        y = y0 - np.asarray(value) / top * (y0 - y1)
        return np.stack([x, y], axis=-1)

    grey = (160, 160, 160)
    for tick in range(0, top + 1, -(-top // 5)):
        (_, y), = to_pixel([frames[0] if frames.size else 0], [tick])
        cv2.line(canvas, (x0, int(y)), (x1, int(y)), (230, 230, 230), 1)
        cv2.putText(canvas, str(tick), (x0 - 45, int(y) + 5), _FONT, 0.45, (0, 0, 0), 1, cv2.LINE_AA)
    if frames.size:
        for tick in np.unique(np.linspace(frames[0], frames[-1], min(span, 8) + 1).round().astype(int)):
            (x, _), = to_pixel([tick], [0])
            cv2.line(canvas, (int(x), y0), (int(x), y0 + 5), grey, 1)
            cv2.putText(canvas, str(tick), (int(x) - 10, y0 + 22), _FONT, 0.45, (0, 0, 0), 1, cv2.LINE_AA)
    cv2.rectangle(canvas, (x0, y1), (x1, y0), grey, 1)
    cv2.putText(canvas, "frame", ((x0 + x1) // 2 - 20, _HEIGHT - 12), _FONT, 0.5, (0, 0, 0), 1, cv2.LINE_AA)
    cv2.putText(canvas, title, (x0, 30), _FONT, 0.6, (0, 0, 0), 1, cv2.LINE_AA)
    legend_x = x0 + 10
    for index, (label, values) in enumerate(series.items()):
        colour = tuple(int(c) for c in PALETTE_BGR[(index + 4) % len(PALETTE_BGR)])
        if values.size:
            points = np.round(to_pixel(frames, values)).astype(np.int32)
            cv2.polylines(canvas, [points], False, colour, 2, cv2.LINE_AA)
        cv2.line(canvas, (legend_x, y1 + 15), (legend_x + 25, y1 + 15), colour, 3)
        cv2.putText(canvas, label, (legend_x + 30, y1 + 20), _FONT, 0.45, (0, 0, 0), 1, cv2.LINE_AA)
        legend_x += 45 + 9 * len(label)
    return canvas


def write_png(path: Path, image: np.ndarray) -> None:
    """Write an image as PNG, atomically.

    Raises
    ------
    DataError
        If it cannot be encoded or written.
    """
    ok, encoded = cv2.imencode(".png", image)
    if not ok:
        raise DataError(path, "could not encode the image as PNG")
    with atomic_path(path) as temporary:
        temporary.write_bytes(encoded.tobytes())
