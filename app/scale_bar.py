"""A scale bar in the bottom-right corner of drawn frames, when the clip is calibrated."""

from __future__ import annotations

import math
from typing import Iterable, Iterator

import cv2
import numpy as np

from seedtrack.data.calibration import Calibration

# About this share of the frame's width, rounded to 1, 2 or 5 times a power of ten.
_SHARE = 0.2
_MARGIN, _THICKNESS = 12, 4
# OpenCV's Hershey fonts draw ASCII only.
_ASCII = {"µm": "um", "μm": "um", "micron": "um", "microns": "um", "micrometer": "um"}


def bar_length(pixel_size: float, pixels_per_input_pixel: float, width: int) -> tuple[float, int]:
    """The bar's length in the space unit (a round number) and in drawn pixels.

    Example
    -------
    >>> bar_length(0.5, 1.0, 640)
    (50.0, 100)
    """
    wanted = _SHARE * width / pixels_per_input_pixel * pixel_size
    magnitude = 10 ** math.floor(math.log10(wanted))
    length = max(m * magnitude for m in (1, 2, 5) if m * magnitude <= wanted)
    return float(length), round(length / pixel_size * pixels_per_input_pixel)


def draw_scale_bar(image: np.ndarray, units: Calibration, pixels_per_input_pixel: float) -> np.ndarray:
    """``image`` (BGR, uint8) with a white bar, outlined in black, and its length above it."""
    height, width = image.shape[:2]
    length, pixels = bar_length(units.pixel_size, pixels_per_input_pixel, width)
    right, bottom = width - _MARGIN, height - _MARGIN
    left = right - pixels
    out = image.copy()
    cv2.rectangle(out, (left - 1, bottom - _THICKNESS - 1), (right + 1, bottom + 1), (0, 0, 0), -1)
    cv2.rectangle(out, (left, bottom - _THICKNESS), (right, bottom), (255, 255, 255), -1)
    label = f"{length:g} {_ASCII.get(units.space_unit, units.space_unit)}"
    scale = 0.5
    (text_width, _), _ = cv2.getTextSize(label, cv2.FONT_HERSHEY_SIMPLEX, scale, 1)
    origin = (right - text_width, bottom - _THICKNESS - 6)
    cv2.putText(out, label, origin, cv2.FONT_HERSHEY_SIMPLEX, scale, (0, 0, 0), 3, cv2.LINE_AA)
    cv2.putText(out, label, origin, cv2.FONT_HERSHEY_SIMPLEX, scale, (255, 255, 255), 1, cv2.LINE_AA)
    return out


def with_scale_bar(frames: Iterable[tuple[int, np.ndarray]], units: Calibration, pixels_per_input_pixel: float) -> Iterator[tuple[int, np.ndarray]]:
    """The frames with a scale bar if ``units`` has a length unit, else unchanged."""
    for index, image in frames:
        yield index, draw_scale_bar(image, units, pixels_per_input_pixel) if units.space_unit != "pixel" else image
