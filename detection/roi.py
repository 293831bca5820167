"""Regions of interest: the dish found as the large bright disc, or a circle, as a mask.

Masks are uint8 arrays, 255 inside and 0 outside, the layout OpenCV takes as a mask.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

# The dish is looked for on a copy shrunk to about this many pixels across (speed only).
_SEARCH_WIDTH = 320
# A bright region counts as a dish when it fills its fitted circle this well ...
_MIN_ROUNDNESS = 0.9
# ... covers at least this fraction of the frame ...
_MIN_FRAME_FRACTION = 0.1
# ... and its circle lies inside the frame but for this fraction of the radius.
_MAX_OVERHANG = 0.05
# The region of interest stops this far inside the dish's edge, pixels, plus a fraction of the
# radius: the wall, its shadow and the blurred edge are not seeds.
_EDGE_MARGIN_PX = 3.0
_EDGE_MARGIN_FRACTION = 0.01


@dataclass(frozen=True)
class Circle:
    """A circle in pixels: centre (x, y), x to the right and y down, and radius."""

    x: float
    y: float
    r: float


def find_dish(gray: np.ndarray) -> Circle | None:
    """The dish, if the frame clearly shows one: a large, round, bright region inside the frame.

    Parameters
    ----------
    gray : ndarray of uint8, shape (H, W)

    Returns
    -------
    Circle or None
        The dish's edge, pixels; None when there is no clear disc (then the whole frame is
        the region of interest).
    """
    height, width = gray.shape
    scale = min(1.0, _SEARCH_WIDTH / width)
    small = cv2.resize(gray, (max(1, round(width * scale)), max(1, round(height * scale))), interpolation=cv2.INTER_AREA)
    _, bright = cv2.threshold(small, 0, 255, cv2.THRESH_BINARY + cv2.THRESH_OTSU)
    contours, _ = cv2.findContours(bright, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    if not contours:
        return None
    outline = max(contours, key=cv2.contourArea)
    area = cv2.contourArea(outline)
    moments = cv2.moments(outline)
    if area <= 0 or moments["m00"] <= 0:
        return None
    x, y = moments["m10"] / moments["m00"], moments["m01"] / moments["m00"]
    r = float(np.sqrt(area / np.pi))
    _, enclosing = cv2.minEnclosingCircle(outline)
    h, w = small.shape
    overhang = max(r - x, r - y, x + r - (w - 1), y + r - (h - 1))
    if area / (np.pi * enclosing**2) < _MIN_ROUNDNESS or area < _MIN_FRAME_FRACTION * w * h or overhang > _MAX_OVERHANG * r:
        return None
    # Contour points run along pixel centres of the region's border, half a pixel inside
    # its edge.
    return Circle(x / scale + (1 / scale - 1) / 2, y / scale + (1 / scale - 1) / 2, (r + 0.5) / scale)


def circle_mask(size: tuple[int, int], circle: Circle, margin: float = 0.0) -> np.ndarray:
    """Mask of the pixels whose centres lie within ``circle.r - margin`` of its centre.

    Parameters
    ----------
    size : tuple of int
        (width, height) of the frame, pixels.
    circle : Circle
    margin : float
        How far inside the circle the mask stops, pixels.

    Returns
    -------
    ndarray of uint8, shape (height, width)
        255 inside, 0 outside.
    """
    width, height = size
    y, x = np.ogrid[0:height, 0:width]
    inside = (x - circle.x) ** 2 + (y - circle.y) ** 2 <= max(circle.r - margin, 0) ** 2
    return np.where(inside, np.uint8(255), np.uint8(0))


def dish_mask(gray: np.ndarray) -> tuple[np.ndarray | None, Circle | None]:
    """The automatic region of interest: the dish found in ``gray`` less its edge, or None.

    Returns
    -------
    mask : ndarray of uint8, shape (H, W), or None
        None when no dish is found: look everywhere.
    dish : Circle or None
        The dish found.
    """
    dish = find_dish(gray)
    if dish is None:
        return None, None
    margin = _EDGE_MARGIN_PX + _EDGE_MARGIN_FRACTION * dish.r
    return circle_mask((gray.shape[1], gray.shape[0]), dish, margin), dish
