"""MOTChallenge text: ``frame,id,bb_left,bb_top,bb_width,bb_height,conf,x,y,z``, one box a line.

Conversions: MOTChallenge frames count from 1, ours from 0, so ``frame = mot_frame - 1`` on
reading and ``mot_frame = frame + 1`` on writing. A point is the centre of its box,
``(bb_left + bb_width / 2, bb_top + bb_height / 2)``, in the file's pixel coordinates; the point
variant is a box of zero size, whose centre is its corner. Files with 6 or more fields a line
are accepted (MOT15 detections, MOT16/17 ground truth with class and visibility columns); fields
after the box are ignored, so every row is read, whatever its confidence or class. Fields are
separated by commas or white space. The writer writes point boxes: ``bb_width = bb_height = 0``,
``conf = 1`` and ``x = y = z = -1`` (no world coordinates).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..atomic import atomic_path
from ..csvio import text_lines
from ..errors import DataError, check_file
from ..numbers import check_range
from .rows import Rows

_SEPARATOR = re.compile(r"[,\s]+")
_FIELDS = 6


def read(path) -> Rows:
    """Rows of a MOTChallenge file (blank lines and lines starting with ``#`` are skipped)."""
    path = Path(path)
    check_file(path)
    values, lines = [], []
    for number, text in text_lines(path):
        text = text.strip()
        if not text or text.startswith("#"):
            continue
        fields = _SEPARATOR.split(text.strip(", \t"))
        if len(fields) < _FIELDS:
            raise DataError(path, f"line {number}: {len(fields)} fields; MOTChallenge needs at least frame,id,bb_left,bb_top,bb_width,bb_height")
        try:
            numbers = [float(field) for field in fields[:_FIELDS]]
        except ValueError:
            raise DataError(path, f"line {number}: a field of frame,id,bb_left,bb_top,bb_width,bb_height is not a number") from None
        values.append(numbers)
        lines.append(number)
    table = np.array(values, dtype=float).reshape(-1, _FIELDS)
    line = np.array(lines, dtype=np.int64)
    whole = (table[:, :2] == np.round(table[:, :2])) | ~np.isfinite(table[:, :2])
    if not whole.all():
        raise DataError(path, f"line {line[np.flatnonzero(~whole.all(axis=1))[0]]}: frame and id must be whole numbers")
    early = np.flatnonzero(table[:, 0] < 1)
    if early.size:
        raise DataError(path, f"line {line[early[0]]}: frame {table[early[0], 0]:g}; MOTChallenge frames count from 1")
    # Checked as floats, before they become integers: the 0-based frame, the id and the box.
    for name, column in (("frame", table[:, 0] - 1), ("track_id", table[:, 1]), ("x", table[:, 2]), ("y", table[:, 3]), ("x", table[:, 4]), ("y", table[:, 5])):
        check_range(path, name, column, line)
    frame = table[:, 0].astype(np.int64)
    x = table[:, 2] + table[:, 4] / 2
    y = table[:, 3] + table[:, 5] / 2
    return Rows(table[:, 1].astype(np.int64), frame - 1, x, y, line)


def write(path, rows: dict[str, np.ndarray]) -> None:
    """Write tracks as MOTChallenge point boxes (1-based frames), sorted by frame then id, atomically."""
    order = np.lexsort((rows["track_id"], rows["frame"]))
    with atomic_path(path) as temporary:
        with open(temporary, "w") as handle:
            for i in order:
                handle.write(f"{rows['frame'][i] + 1},{rows['track_id'][i]},{rows['x'][i]:.4f},{rows['y'][i]:.4f},0,0,1,-1,-1,-1\n")
