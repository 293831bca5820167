"""Flat track rows as every format reader returns them, and the checks they all share."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from seedtrack.tracking.tracks import Tracks

from ..errors import DataError
from ..numbers import check_range


@dataclass(frozen=True)
class Rows:
    """One row per (track, frame) point.

    Attributes
    ----------
    track_id, frame : ndarray of int
        Track identifier and 0-based frame index.
    x, y : ndarray of float
        Position, pixels (x right, y down).
    line : ndarray of int, or callable
        Line of the file the row comes from (1-based), for error messages; or a function from
        row positions to their lines, called only when a row is bad.
    interpolated : ndarray of int or None
        1 where the position was filled in rather than measured; None if the format cannot say.
    """

    track_id: np.ndarray
    frame: np.ndarray
    x: np.ndarray
    y: np.ndarray
    line: np.ndarray | Callable[[np.ndarray], np.ndarray]
    interpolated: np.ndarray | None = None


def rows_to_tracks(path, rows: Rows) -> Tracks:
    """Check rows and build the track set.

    Raises
    ------
    DataError
        Naming the line of the first row with a frame, id or position out of range (see
        :mod:`seedtrack.data.numbers`), or a second row for a (track, frame) pair already given.
    """
    track_id = np.asarray(rows.track_id, dtype=np.int64)
    frame = np.asarray(rows.frame, dtype=np.int64)
    x, y = np.asarray(rows.x, dtype=float), np.asarray(rows.y, dtype=float)
    line = rows.line if callable(rows.line) else np.asarray(rows.line, dtype=np.int64)
    for name, values in (("frame", frame), ("track_id", track_id), ("x", x), ("y", y)):
        check_range(path, name, values, line)
    order = np.lexsort((np.arange(frame.size), frame, track_id))
    repeated = np.flatnonzero((np.diff(track_id[order]) == 0) & (np.diff(frame[order]) == 0))
    if repeated.size:
        first, second = order[repeated], order[repeated + 1]
        worst = int(np.argmin(second))
        a, b = first[worst], second[worst]
        at = line(np.array([a, b])) if callable(line) else line[[a, b]]
        raise DataError(path, f"line {at[1]}: track {track_id[b]} has a second point in frame {frame[b]} (first at line {at[0]})")
    interpolated = rows.interpolated
    if interpolated is not None:
        check_range(path, "interpolated", np.asarray(interpolated), line)
    return Tracks.from_rows(track_id, frame, x, y, interpolated)
