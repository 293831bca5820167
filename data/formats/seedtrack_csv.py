"""Our ``tracks.csv``: columns ``track_id,frame,x,y,interpolated`` (0-based frames, pixels)."""

from __future__ import annotations

from functools import partial

import numpy as np

from ..csvio import TRACK_COLUMNS, data_lines, read_table, write_table
from .rows import Rows

REQUIRED = ("track_id", "frame", "x", "y")


def read(path) -> Rows:
    """Rows of a ``tracks.csv``; ``interpolated`` is optional and other columns are ignored."""
    table = read_table(path, required=REQUIRED)
    lines = partial(data_lines, path)  # read again only for an error message
    return Rows(table["track_id"], table["frame"], table["x"], table["y"], lines, table.get("interpolated"))


def write(path, rows: dict[str, np.ndarray]) -> None:
    """Write the columns of :meth:`Tracks.to_rows`, then any further columns of ``rows``, as
    ``tracks.csv``, atomically."""
    write_table(path, {**{name: rows[name] for name in TRACK_COLUMNS}, **rows})
