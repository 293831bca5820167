"""Track files: read and write track sets, whatever tool wrote them.

Every command that takes a tracks or truth file reads it through :func:`read_tracks`, so that a
format added here is accepted everywhere.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from tracking.tracks import Tracks

from .csvio import TRACK_COLUMNS, read_table, write_table
from .errors import DataError


def read_tracks(path: str | os.PathLike) -> Tracks:
    """Read a track set from our ``tracks.csv`` format.

    Parameters
    ----------
    path : path-like
        CSV with columns ``track_id,frame,x,y`` and optionally ``interpolated``; other
        columns are ignored.

    Returns
    -------
    Tracks
        Frames are 0-based clip indices: column ``c`` of the result is frame
        ``first_frame + c``.

    Raises
    ------
    DataError
        If the file is missing or malformed, or a track has two rows for one frame.
    """
    table = read_table(path, required=("track_id", "frame", "x", "y"))
    if table["frame"].size and table["frame"].min() < 0:
        raise DataError(path, "column frame holds a negative frame index")
    try:
        return Tracks.from_rows(table["track_id"], table["frame"], table["x"], table["y"], table.get("interpolated"))
    except ValueError as error:
        raise DataError(path, str(error)) from None


def write_tracks(path: str | os.PathLike, tracks: Tracks, frame_indices: np.ndarray | None = None) -> None:
    """Write a track set as ``tracks.csv`` (columns ``track_id,frame,x,y,interpolated``), atomically.

    Parameters
    ----------
    path : path-like
    tracks : Tracks
    frame_indices : ndarray of int, optional
        0-based clip frame index of each track-set column, when frames were skipped; by default
        column ``c`` is frame ``tracks.first_frame + c``.
    """
    rows = tracks.to_rows()
    if frame_indices is not None:
        rows["frame"] = np.asarray(frame_indices)[rows["frame"] - tracks.first_frame]
    write_table(Path(path), {name: rows[name] for name in TRACK_COLUMNS})
