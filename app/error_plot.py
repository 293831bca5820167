"""Line charts drawn with OpenCV, so no plotting library is needed: tracking errors per frame
(``seedtrack evaluate``) and experiment curves with 95% intervals (``seedtrack experiment``)."""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np

from seedtrack.data.atomic import atomic_path
from seedtrack.data.errors import DataError

from .drawing import PALETTE_BGR

_WIDTH, _HEIGHT = 960, 420
_LEFT, _RIGHT, _TOP, _BOTTOM = 70, 20, 50, 60
_FONT = cv2.FONT_HERSHEY_SIMPLEX
_LEGEND_ROW = 20


def _nice_ticks(low: float, high: float, count: int = 5) -> np.ndarray:
    """Round tick values from ``low`` to at least ``high``, about ``count`` of them."""
    span = max(high - low, 1e-12)
    raw = span / count
    magnitude = 10 ** math.floor(math.log10(raw))
    step = next(m * magnitude for m in (1, 2, 2.5, 5, 10) if m * magnitude >= raw)
    return np.arange(math.floor(low / step), math.ceil(high / step - 1e-9) + 1) * step


def _label(value: float) -> str:
    return f"{value:g}" if abs(value) >= 1e-3 or value == 0 else f"{value:.1e}"


def draw_line_plot(
    x: np.ndarray,
    series: dict[str, np.ndarray],
    title: str,
    x_label: str,
    y_label: str = "",
    intervals: dict[str, np.ndarray] | None = None,
    integer_y: bool = False,
) -> np.ndarray:
    """Draw one line per series on white, with axes, ticks, optional error bars and a legend.

    Parameters
    ----------
    x : ndarray of float, shape (n,)
        Abscissa shared by all series (increasing).
    series : dict of str to ndarray, each shape (n,)
        Legend label to values; NaN values are left out of the line.
    title, x_label, y_label : str
    intervals : dict of str to ndarray, optional
        Half-width of an error bar per value (e.g. a 95% interval), for the series named.
    integer_y : bool
        Use whole-number ticks on the y axis (counts).

    Returns
    -------
    ndarray of uint8, shape (420 + 20 per legend row of four beyond the first, 960, 3) BGR
    """
    intervals = intervals or {}
    x = np.asarray(x, dtype=float)
    tops = [np.nanmax(v + np.nan_to_num(intervals.get(k, 0.0))) for k, v in series.items() if np.isfinite(v).any()]
    top = max(tops, default=1.0)
    if integer_y:
        top = max(1, int(math.ceil(top)))
        y_ticks = np.arange(0, top + 1, -(-top // 5))
    else:
        y_ticks = _nice_ticks(0.0, top if top > 0 else 1.0)
        top = float(y_ticks[-1])
    x_low, x_high = (float(x.min()), float(x.max())) if x.size else (0.0, 1.0)
    x_span = x_high - x_low or 1.0

    # The legend sits between the title and the plot, four entries to a row.
    legend_rows = -(-len(series) // 4)
    height = _HEIGHT + _LEGEND_ROW * (legend_rows - 1)
    canvas = np.full((height, _WIDTH, 3), 255, np.uint8)
    x0, x1, y0, y1 = _LEFT, _WIDTH - _RIGHT, height - _BOTTOM, _TOP + _LEGEND_ROW * legend_rows

    def to_pixel(xs, ys):
        px = x0 + (np.asarray(xs, float) - x_low) / x_span * (x1 - x0)
        py = y0 - np.asarray(ys, float) / top * (y0 - y1)
        return np.stack([px, py], axis=-1)

    black, grey = (0, 0, 0), (160, 160, 160)
    for tick in y_ticks:
        (_, py), = to_pixel([x_low], [tick])
        cv2.line(canvas, (x0, int(py)), (x1, int(py)), (230, 230, 230), 1)
        cv2.putText(canvas, _label(tick), (x0 - 55, int(py) + 5), _FONT, 0.45, black, 1, cv2.LINE_AA)
    x_ticks = x if x.size <= 12 else np.unique(np.linspace(x_low, x_high, 9).round(6))
    for tick in x_ticks:
        (px, _), = to_pixel([tick], [0])
        cv2.line(canvas, (int(px), y0), (int(px), y0 + 5), grey, 1)
        cv2.putText(canvas, _label(tick), (int(px) - 10, y0 + 22), _FONT, 0.45, black, 1, cv2.LINE_AA)
    cv2.rectangle(canvas, (x0, y1), (x1, y0), grey, 1)
    cv2.putText(canvas, x_label, ((x0 + x1) // 2 - 4 * len(x_label), height - 12), _FONT, 0.5, black, 1, cv2.LINE_AA)
    cv2.putText(canvas, title + (f"  ({y_label})" if y_label else ""), (x0, 30), _FONT, 0.6, black, 1, cv2.LINE_AA)

    for index, (label, values) in enumerate(series.items()):
        colour = tuple(int(c) for c in PALETTE_BGR[(index + 4) % len(PALETTE_BGR)])
        # Past the palette, lines are thin so that a repeated colour still reads differently.
        thickness = 2 if index < len(PALETTE_BGR) else 1
        values = np.asarray(values, float)
        finite = np.isfinite(values)
        points = np.round(to_pixel(x[finite], values[finite])).astype(np.int32)
        if len(points) > 1:
            cv2.polylines(canvas, [points], False, colour, thickness, cv2.LINE_AA)
        for px, py in points:
            cv2.circle(canvas, (int(px), int(py)), 3, colour, -1, cv2.LINE_AA)
        if label in intervals:
            half = np.asarray(intervals[label], float)[finite]
            for (px, _), value, h in zip(points, values[finite], half):
                (_, low), = to_pixel([0], [max(value - h, 0.0)])
                (_, high), = to_pixel([0], [min(value + h, top)])
                cv2.line(canvas, (int(px), int(low)), (int(px), int(high)), colour, 1, cv2.LINE_AA)
                for end in (low, high):
                    cv2.line(canvas, (int(px) - 4, int(end)), (int(px) + 4, int(end)), colour, 1, cv2.LINE_AA)
        row, column = divmod(index, 4)
        legend_x, legend_y = x0 + 10 + column * 215, _TOP + 5 + row * _LEGEND_ROW
        cv2.line(canvas, (legend_x, legend_y), (legend_x + 25, legend_y), colour, 3 if thickness == 2 else 1)
        cv2.putText(canvas, label, (legend_x + 30, legend_y + 5), _FONT, 0.45, black, 1, cv2.LINE_AA)
    return canvas


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
    ndarray of uint8, shape (height, 960, 3) BGR
    """
    return draw_line_plot(frames, series, title, "frame", integer_y=True)


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
