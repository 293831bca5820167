"""Review sheets: frames enlarged with every track's id written large, to write corrections from."""

from __future__ import annotations

import cv2
import numpy as np

from seedtrack.tracking.tracks import Tracks

from .drawing import SHIFT, Occupancy, Style, draw_heads, draw_text, draw_texts, place_labels, ring_radius, to_fixed, track_colour

# Marks and ids at a fixed size, pixels of the page: the page is enlarged to suit them.
_STYLE = Style(line=2, radius=4.0, font=0.6, text=2, marker=9)
# Pages are enlarged until they are at least this wide, so ids of small clips stay readable.
_MIN_PAGE_WIDTH = 1280
_MAX_ZOOM = 4


def review_zoom(width: int) -> int:
    """Whole-number enlargement for a frame ``width`` pixels wide (1 to 4)."""
    return int(min(_MAX_ZOOM, max(1, -(-_MIN_PAGE_WIDTH // max(width, 1)))))


def draw_review_page(frame: np.ndarray, tracks: Tracks, column: int, frame_index: int, trail: int = 3) -> np.ndarray:
    """One review page: the frame enlarged, each track's last steps, its position and its id.

    Ids are drawn in the track's colour on a black halo so that they read on any background, each
    where it covers no other id or head (ids that find no such place are left out); a position is
    a ring (dashed if interpolated), so that the object inside stays visible.

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
    heads = tracks.xy[present, column] * zoom + offset
    ids = tracks.track_ids[present]
    colours = [track_colour(track_id) for track_id in ids]
    draw_heads(page, heads, np.arange(len(present)), colours, tracks.interpolated[present, column], _STYLE)
    # Every id that fits without covering another id or a head; the rest are left out rather
    # than written over each other (the annotate page shows every id, zoomed in).
    taken = Occupancy(page.shape[:2])
    taken.add_points(heads, ring_radius(_STYLE))
    chosen, origins = place_labels(taken, [str(i) for i in ids], heads, ring_radius(_STYLE) + 1, _STYLE.font, _STYLE.text)
    draw_texts(page, [str(ids[i]) for i in chosen], origins, [colours[i] for i in chosen], _STYLE.font, _STYLE.text)
    label = f"frame {frame_index}"
    draw_text(page, label, (12, 36), (255, 255, 255), 1.0, 2)
    return page
