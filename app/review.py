"""Review sheets: frames enlarged with every track's id written large, to write corrections from."""

from __future__ import annotations

import cv2
import numpy as np

from seedtrack.tracking.tracks import Tracks

from .drawing import SHIFT, draw_text, to_fixed, track_colour

# Pages are enlarged until they are at least this wide, so ids of small clips stay readable.
_MIN_PAGE_WIDTH = 1280
_MAX_ZOOM = 4


def review_zoom(width: int) -> int:
    """Whole-number enlargement for a frame ``width`` pixels wide (1 to 4)."""
    return int(min(_MAX_ZOOM, max(1, -(-_MIN_PAGE_WIDTH // max(width, 1)))))


def draw_review_page(frame: np.ndarray, tracks: Tracks, column: int, frame_index: int, trail: int = 3) -> np.ndarray:
    """One review page: the frame enlarged, each track's last steps, its position and its id.

    Ids are drawn in the track's colour on a black halo so that they read on any background;
    an interpolated (unmeasured) position is a hollow circle.

    Parameters
    ----------
    frame : ndarray of uint8, shape (H, W, 3) BGR
    tracks : Tracks
    column : int
        Column of ``tracks`` for this frame.
    frame_index : int
        0-based frame index, printed in the corner.
    trail : int
        Past frames drawn as a line behind each position.

    Returns
    -------
    ndarray of uint8, shape (zoom H, zoom W, 3)
    """
    zoom = review_zoom(frame.shape[1])
    page = cv2.resize(frame, None, fx=zoom, fy=zoom, interpolation=cv2.INTER_NEAREST)
    # A pixel centre at integer x sits at zoom * x + (zoom - 1) / 2 on the enlarged page.
    offset = (zoom - 1) / 2
    present = np.flatnonzero(tracks.present[:, column])
    start = max(0, column - trail)
    for row in present:
        history = tracks.xy[row, start : column + 1] * zoom + offset
        history = history[~np.isnan(history[:, 0])]
        if len(history) > 1:
            cv2.polylines(page, [to_fixed(history)], False, track_colour(tracks.track_ids[row]), 2, cv2.LINE_AA, SHIFT)
    for row in present:
        colour = track_colour(tracks.track_ids[row])
        x, y = tracks.xy[row, column] * zoom + offset
        hollow = tracks.interpolated[row, column]
        cv2.circle(page, tuple(to_fixed(np.array([x, y]))), 4 << SHIFT, (0, 0, 0), 4, cv2.LINE_AA, SHIFT)
        cv2.circle(page, tuple(to_fixed(np.array([x, y]))), 4 << SHIFT, colour, 2 if hollow else -1, cv2.LINE_AA, SHIFT)
        origin = (int(round(x + 7)), int(round(y - 7)))
        text = str(tracks.track_ids[row])
        draw_text(page, text, origin, colour, 0.7, 2)
    label = f"frame {frame_index}"
    draw_text(page, label, (12, 36), (255, 255, 255), 1.0, 2)
    return page
