"""Draw tracks over video frames: a fading trail and the id of every track head."""

from __future__ import annotations

from typing import Iterator

import cv2
import numpy as np

from tracking.tracks import Tracks

# Okabe-Ito: distinguishable with the common colour-vision deficiencies (BGR order).
PALETTE_BGR = np.array(
    [
        (0, 159, 230),  # orange
        (233, 180, 86),  # sky blue
        (115, 158, 0),  # bluish green
        (66, 228, 240),  # yellow
        (178, 114, 0),  # blue
        (0, 94, 213),  # vermillion
        (167, 121, 204),  # reddish purple
    ],
    dtype=np.uint8,
)

# Sub-pixel drawing: OpenCV takes integer coordinates scaled by 2**SHIFT.
SHIFT = 4


def track_colour(track_id: int) -> tuple[int, int, int]:
    """The BGR colour of a track id; the same id gets the same colour on every run."""
    return tuple(int(c) for c in PALETTE_BGR[int(track_id) % len(PALETTE_BGR)])


def _fixed(points: np.ndarray) -> np.ndarray:
    return np.round(points * (1 << SHIFT)).astype(np.int32)


def draw_tracks(frame: np.ndarray, tracks: Tracks, column: int, trail: int = 10) -> np.ndarray:
    """Draw each track's last ``trail`` positions and its id onto a copy of ``frame``.

    Parameters
    ----------
    frame : ndarray of uint8, shape (H, W, 3) BGR
    tracks : Tracks
    column : int
        Column of ``tracks`` (frame position within the track set) to draw.
    trail : int
        Number of past frames whose positions form the trail.

    Returns
    -------
    ndarray of uint8, shape (H, W, 3)
    """
    canvas = frame.copy()
    scale = max(frame.shape[:2]) / 640.0
    radius = max(2.0, 3.0 * scale)
    font_scale = 0.35 * scale
    start = max(0, column - trail)
    for row in np.flatnonzero(tracks.present[:, column]):
        colour = track_colour(tracks.track_ids[row])
        history = tracks.xy[row, start : column + 1]
        history = history[~np.isnan(history[:, 0])]
        if len(history) > 1:
            cv2.polylines(canvas, [_fixed(history)], False, colour, 1, cv2.LINE_AA, SHIFT)
        head = _fixed(tracks.xy[row, column])
        hollow = tracks.interpolated[row, column]
        cv2.circle(canvas, tuple(head), int(radius * (1 << SHIFT)), colour, 1 if hollow else -1, cv2.LINE_AA, SHIFT)
        x, y = tracks.xy[row, column]
        cv2.putText(
            canvas,
            str(tracks.track_ids[row]),
            (int(round(x + radius + 1)), int(round(y - radius - 1))),
            cv2.FONT_HERSHEY_SIMPLEX,
            font_scale,
            colour,
            1,
            cv2.LINE_AA,
        )
    return canvas


def overlay_frames(frames: Iterator[tuple[int, np.ndarray]], tracks: Tracks, column_of_frame: dict[int, int], trail: int = 10) -> Iterator[np.ndarray]:
    """Yield each frame with the tracks drawn over it.

    Parameters
    ----------
    frames : iterator of (frame_index, image)
        0-based frame index and BGR image, as a frame source yields them.
    tracks : Tracks
    column_of_frame : dict of int to int
        Track-set column of each frame index; frames not in it are passed through undrawn.
    trail : int
        Past frames per trail.
    """
    for index, image in frames:
        column = column_of_frame.get(index)
        yield image if column is None else draw_tracks(image, tracks, column, trail)
