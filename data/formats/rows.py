"""Flat track rows as every format reader returns them, and the checks they all share."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from seedtrack.tracking.tracks import Tracks

from ..errors import DataError


@dataclass(frozen=True)
class Rows:
    """One row per (track, frame) point.

    Attributes
    ----------
    track_id, frame : ndarray of int
        Track identifier and 0-based frame index.
    x, y : ndarray of float
        Position, pixels (x right, y down).
    line : ndarray of int
        Line of the file the row comes from (1-based), for error messages.
    interpolated : ndarray of int or None
        1 where the position was filled in rather than measured; None if the format cannot say.
    """

    track_id: np.ndarray
    frame: np.ndarray
    x: np.ndarray
    y: np.ndarray
    line: np.ndarray
    interpolated: np.ndarray | None = None


def rows_to_tracks(path, rows: Rows) -> Tracks:
    """Check rows and build the track set.

    Raises
    ------
    DataError
        Naming the line of the first row with a negative frame, a position that is not a finite
        number, or a second row for a (track, frame) pair already given.
    """
    track_id = np.asarray(rows.track_id, dtype=np.int64)
    frame = np.asarray(rows.frame, dtype=np.int64)
    x, y = np.asarray(rows.x, dtype=float), np.asarray(rows.y, dtype=float)
    line = np.asarray(rows.line, dtype=np.int64)
    negative = np.flatnonzero(frame < 0)
    if negative.size:
        raise DataError(path, f"line {line[negative[0]]}: negative frame index {frame[negative[0]]}")
    bad = np.flatnonzero(~(np.isfinite(x) & np.isfinite(y)))
    if bad.size:
        raise DataError(path, f"line {line[bad[0]]}: position is not a finite number")
    order = np.lexsort((line, frame, track_id))
    repeated = np.flatnonzero((np.diff(track_id[order]) == 0) & (np.diff(frame[order]) == 0))
    if repeated.size:
        first, second = order[repeated], order[repeated + 1]
        worst = int(np.argmin(line[second]))
        a, b = first[worst], second[worst]
        raise DataError(path, f"line {line[b]}: track {track_id[b]} has a second point in frame {frame[b]} (first at line {line[a]})")
    return Tracks.from_rows(track_id, frame, x, y, rows.interpolated)
