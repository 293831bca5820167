"""Track files: read and write track sets, whatever tool wrote them.

Every command that takes a tracks or truth file reads it through :func:`read_tracks`, so that a
format added here is accepted everywhere. Formats (see each module in :mod:`seedtrack.data.formats`):

========== ============================================= =====================================
name       what                                          chosen by default for
========== ============================================= =====================================
csv        our ``tracks.csv`` (track_id,frame,x,y,...)   ``.csv`` with a ``track_id`` column
trackpy    trackpy's table (frame,particle,x,y)          ``.csv`` with a ``particle`` column
mot        MOTChallenge text (1-based frames, boxes)     ``.txt``
trackmate  TrackMate XML (spots, edges, tracks)          ``.xml`` with root ``<TrackMate>``
isbi       ISBI 2012 particle-tracking challenge XML     ``.xml`` with root ``<root>``
========== ============================================= =====================================
"""

from __future__ import annotations

import csv
import os
from pathlib import Path

import numpy as np

from seedtrack.tracking.tracks import Tracks

from .csvio import text_lines
from .errors import DataError
from .formats import isbi, mot, seedtrack_csv, trackmate, trackpy
from .formats.rows import rows_to_tracks
from .formats.xmltree import root_tag

FORMATS = {"csv": seedtrack_csv, "trackpy": trackpy, "mot": mot, "trackmate": trackmate, "isbi": isbi}
_WRITE_DEFAULTS = {".csv": "csv", ".txt": "mot", ".xml": "trackmate"}


def read_tracks(path: str | os.PathLike, format: str | None = None) -> Tracks:
    """Read a track set from any supported format.

    Parameters
    ----------
    path : path-like
    format : str, optional
        One of ``csv``, ``trackpy``, ``mot``, ``trackmate``, ``isbi``; by default chosen from the
        extension and, for ``.csv`` and ``.xml``, the header or root element.

    Returns
    -------
    Tracks
        Frames are 0-based clip indices: column ``c`` of the result is frame
        ``first_frame + c``; positions in pixels.

    Raises
    ------
    DataError
        If the file is missing, of an unknown format or malformed (naming the line), or a track
        has two points in one frame.
    """
    path = Path(path)
    name = _check_format(format) if format is not None else _sniff(path)
    return rows_to_tracks(path, FORMATS[name].read(path))


def write_tracks(
    path: str | os.PathLike,
    tracks: Tracks,
    frame_indices: np.ndarray | None = None,
    format: str | None = None,
) -> None:
    """Write a track set, atomically, in the format given or implied by the extension.

    Parameters
    ----------
    path : path-like
        ``.csv`` writes our ``tracks.csv``, ``.txt`` MOTChallenge, ``.xml`` TrackMate, unless
        ``format`` says otherwise.
    tracks : Tracks
    frame_indices : ndarray of int, optional
        0-based clip frame index of each track-set column, when frames were skipped; by default
        column ``c`` is frame ``tracks.first_frame + c``.
    format : str, optional
        One of :data:`FORMATS`.

    Raises
    ------
    DataError
        If the format is unknown or the file cannot be written.
    """
    path = Path(path)
    if format is None:
        format = _WRITE_DEFAULTS.get(path.suffix.lower())
        if format is None:
            raise DataError(path, f"cannot tell the track format from the extension {path.suffix!r}; {_known()}")
    rows = tracks.to_rows()
    if frame_indices is not None:
        rows["frame"] = np.asarray(frame_indices)[rows["frame"] - tracks.first_frame]
    FORMATS[_check_format(format)].write(path, rows)


def _check_format(name: str) -> str:
    if name not in FORMATS:
        raise DataError(name, f"unknown track format; {_known()}")
    return name


def _known() -> str:
    return f"use .csv, .txt (MOTChallenge) or .xml (TrackMate, ISBI), or give a format: {', '.join(FORMATS)}"


def _sniff(path: Path) -> str:
    if not path.is_file():
        raise DataError(path, "no such file")
    suffix = path.suffix.lower()
    if suffix == ".csv":
        lines = text_lines(path)
        header = {name.strip() for name in next(csv.reader(line for _, line in lines), [])}
        lines.close()
        if {"track_id", "frame", "x", "y"} <= header:
            return "csv"
        if {"particle", "frame", "x", "y"} <= header:
            return "trackpy"
        raise DataError(path, f"line 1: a track CSV needs columns track_id,frame,x,y (ours) or frame,particle,x,y (trackpy); found {','.join(sorted(header)) or 'nothing'}")
    if suffix == ".txt":
        return "mot"
    if suffix == ".xml":
        tag, line = root_tag(path)
        if tag == "TrackMate":
            return "trackmate"
        if tag == "root":
            return "isbi"
        raise DataError(path, f"line {line}: XML root <{tag}> is neither TrackMate (<TrackMate>) nor ISBI (<root>)")
    raise DataError(path, f"cannot tell the track format from the extension {path.suffix!r}; {_known()}")
