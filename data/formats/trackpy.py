"""trackpy's linked feature table as CSV: columns ``frame``, ``particle``, ``x``, ``y``.

trackpy uses the same conventions as we do (0-based frames, x right, y down, pixels), so no
conversion is needed. Other columns (``mass``, ``size``, a pandas index...) are ignored; trackpy
has no notion of an interpolated point, so every row reads as measured.
"""

from __future__ import annotations

from functools import partial

import numpy as np

from ..csvio import data_lines, read_table, write_table
from .rows import Rows

REQUIRED = ("frame", "particle", "x", "y")


def read(path) -> Rows:
    """Rows of a trackpy table (``particle`` is the track id)."""
    table = read_table(path, required=REQUIRED, integer=("frame", "particle"))
    lines = partial(data_lines, path)  # read again only for an error message
    return Rows(table["particle"], table["frame"], table["x"], table["y"], lines)


def write(path, rows: dict[str, np.ndarray]) -> None:
    """Write tracks as a trackpy table (``frame,particle,x,y``), atomically."""
    write_table(path, {"frame": rows["frame"], "particle": rows["track_id"], "x": rows["x"], "y": rows["y"]})
