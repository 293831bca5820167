"""The one check of numbers read from a file: finite and within the range the program handles.

Every reader (CSV tables, MOTChallenge, TrackMate and ISBI XML, corrections) checks the columns
it reads through :func:`check_range`, so a coordinate of 1e300 is a one-line error naming the
file and line, not an overflow deep inside a tracker or a drawing call.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from .errors import DataError

# Far beyond any frame a camera makes (a 16k frame, a microscope mosaic) and far inside the
# range where squared distances, smoothness costs and fixed-point drawing stay exact.
MAX_COORDINATE_PX = 1e6
# Eleven hours at 25 frames/s. Frame indices index arrays over the frames a track set spans, so
# a larger one is a typo that would cost memory in proportion to it.
MAX_FRAME = 1_000_000
# Track ids are written as integers and must survive a round trip through a float column.
MAX_ID = 2**53

# Column name -> (smallest, largest, what it is), for every column a reader may hold.
RANGES = {
    "frame": (0, MAX_FRAME, "a 0-based frame index"),
    "x": (-MAX_COORDINATE_PX, MAX_COORDINATE_PX, "a position in pixels"),
    "y": (-MAX_COORDINATE_PX, MAX_COORDINATE_PX, "a position in pixels"),
    "track_id": (-MAX_ID, MAX_ID, "a track id"),
    "particle": (-MAX_ID, MAX_ID, "a track id"),
    "interpolated": (0, 1, "0 (measured) or 1 (interpolated)"),
}


def check_range(path, name: str, values: np.ndarray, lines: Callable[[np.ndarray], np.ndarray] | np.ndarray) -> None:
    """Refuse values of column ``name`` that are not finite or fall outside :data:`RANGES`.

    Parameters
    ----------
    path : path-like
        The file, for the message.
    name : str
        Column name; a column without a range is only checked to be finite where numeric.
    values : ndarray of float or int
    lines : ndarray of int, or callable
        1-based file line of each value, or a function from row positions to their lines
        (called only when a value is bad, so that a reader need not track lines).

    Raises
    ------
    DataError
        Naming the first bad value's line, the column and the allowed range.

    Example
    -------
    >>> try:
    ...     check_range("points.csv", "x", np.array([1.0, 1e300]), np.array([2, 3]))
    ... except DataError as error:
    ...     print(error)
    points.csv: line 3: x = 1e+300 is out of range (a position in pixels: -1e+06 to 1e+06)
    """
    if name not in RANGES:
        return
    low, high, meaning = RANGES[name]
    values = np.asarray(values)
    bad = ~np.isfinite(values) | (values < low) | (values > high) if values.dtype.kind == "f" else (values < low) | (values > high)
    if not bad.any():
        return
    row = int(np.flatnonzero(bad)[0])
    line = (lines(np.array([row])) if callable(lines) else np.asarray(lines)[[row]])[0]
    raise DataError(path, f"line {line}: {name} = {values[row]:g} is out of range ({meaning}: {low:g} to {high:g})")
