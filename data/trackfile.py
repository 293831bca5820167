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
geff       GEFF graph (a zarr folder), via ``geff``      ``.geff``
napari     napari Tracks layer array (ID, T, Y, X)       ``.npy``
========== ============================================= =====================================

The extensions come from the one table :data:`seedtrack.data.formats.EXTENSIONS`, which writers
follow too (``.csv`` writes ``csv``, ``.txt`` ``mot``, ``.xml`` ``trackmate``).
"""

from __future__ import annotations

import csv
import os
from pathlib import Path

import numpy as np

from seedtrack.tracking.tracks import Tracks

from .calibration import Calibration
from .csvio import text_lines
from .errors import DataError, check_file
from .formats import EXTENSIONS, described, geff, isbi, mot, napari, seedtrack_csv, trackmate, trackpy
from .formats.rows import rows_to_tracks
from .formats.xmltree import root_tag
from .outputset import check_member

FORMATS = {"csv": seedtrack_csv, "trackpy": trackpy, "mot": mot, "trackmate": trackmate, "isbi": isbi, "geff": geff, "napari": napari}


def read_tracks(path: str | os.PathLike, format: str | None = None) -> Tracks:
    """Read a track set from any supported format.

    Parameters
    ----------
    path : path-like
    format : str, optional
        One of :data:`FORMATS`; by default chosen from the extension and, for ``.csv`` and
        ``.xml``, the header or root element.

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
    # First: a set left half in place by a killed run is finished before its file is read.
    check_member(path)
    name = _check_format(format) if format is not None else _sniff(path)
    return rows_to_tracks(path, FORMATS[name].read(path))


def read_calibration(path: str | os.PathLike, format: str | None = None) -> Calibration:
    """The units a track file's positions and times are in, for the formats that say
    (TrackMate XML, GEFF); pixels and frames for the others.

    Example
    -------
    >>> import tempfile, pathlib
    >>> from seedtrack.tracking.tracks import Tracks
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "t.xml"
    >>> write_tracks(out, Tracks.from_rows([0, 0], [0, 1], [1.0, 2.0], [1.0, 1.0]), units=Calibration(0.5, "micron", 2.0, "sec"))
    >>> read_calibration(out)
    Calibration(pixel_size=0.5, space_unit='micron', frame_interval=2.0, time_unit='sec')
    """
    path = Path(path)
    name = _check_format(format) if format is not None else _sniff(path)
    reader = getattr(FORMATS[name], "calibration", None)
    return reader(path) if reader is not None else Calibration()


def write_tracks(
    path: str | os.PathLike,
    tracks: Tracks,
    frame_indices: np.ndarray | None = None,
    format: str | None = None,
    units: Calibration | None = None,
) -> None:
    """Write a track set, atomically, in the format given or implied by the extension.

    Parameters
    ----------
    path : path-like
        ``.csv`` writes our ``tracks.csv``, ``.txt`` MOTChallenge, ``.xml`` TrackMate, ``.geff``
        GEFF, ``.npy`` napari's tracks array, unless ``format`` says otherwise.
    tracks : Tracks
    frame_indices : ndarray of int, optional
        0-based clip frame index of each track-set column, when frames were skipped; by default
        column ``c`` is frame ``tracks.first_frame + c``.
    format : str, optional
        One of :data:`FORMATS`.
    units : Calibration, optional
        Physical units, for the formats that hold them (TrackMate XML, GEFF); the others stay
        in pixels and frames.

    Raises
    ------
    DataError
        If the format is unknown or the file cannot be written.
    """
    rows = tracks.to_rows()
    if frame_indices is not None:
        rows["frame"] = np.asarray(frame_indices)[rows["frame"] - tracks.first_frame]
    write_rows(path, rows, format, units)


def output_format(path: str | os.PathLike, format: str | None = None) -> str:
    """The format :func:`write_tracks` writes ``path`` in: ``format``, or the first the
    extension's row of :data:`~seedtrack.data.formats.EXTENSIONS` names.

    Raises
    ------
    DataError
        If the format is unknown or the extension names none.

    Example
    -------
    >>> output_format("result.txt")
    'mot'
    """
    if format is not None:
        return _check_format(format)
    names = EXTENSIONS.get(Path(path).suffix.lower())
    if names is None:
        raise DataError(path, f"cannot tell the track format from the extension {Path(path).suffix!r}; {_known()}")
    return names[0]


def write_rows(path: str | os.PathLike, rows: dict[str, np.ndarray], format: str | None = None, units: Calibration | None = None) -> None:
    """Write flat track rows (the columns of :meth:`Tracks.to_rows`; our CSV also keeps any
    further columns, after those) atomically, in the format :func:`output_format` picks, in
    ``units`` where the format holds units.

    Raises
    ------
    DataError
        If the format is unknown or the file cannot be written.
    """
    module = FORMATS[output_format(path, format)]
    if getattr(module, "calibration", None) is not None:
        module.write(Path(path), rows, units)
    else:
        module.write(Path(path), rows)


def _check_format(name: str) -> str:
    if name not in FORMATS:
        raise DataError(name, f"unknown track format; {_known()}")
    return name


def _known() -> str:
    return f"use {described()}, or give a format: {', '.join(FORMATS)}"


def _sniff(path: Path) -> str:
    if path.suffix.lower() == ".geff":
        return "geff"  # a folder, which the reader checks
    check_file(path)
    names = EXTENSIONS.get(path.suffix.lower())
    if names is None:
        raise DataError(path, f"cannot tell the track format from the extension {path.suffix!r}; {_known()}")
    if len(names) == 1:
        return names[0]
    if "csv" in names:
        lines = text_lines(path)
        header = {name.strip() for name in next(csv.reader(line for _, line in lines if line.strip()), [])}
        lines.close()
        if {"track_id", "frame", "x", "y"} <= header:
            return "csv"
        if {"particle", "frame", "x", "y"} <= header:
            return "trackpy"
        raise DataError(path, f"line 1: a track CSV needs columns track_id,frame,x,y (ours) or frame,particle,x,y (trackpy); found {','.join(sorted(header)) or 'nothing'}")
    tag, line = root_tag(path)
    if tag == "TrackMate":
        return "trackmate"
    if tag == "root":
        return "isbi"
    raise DataError(path, f"line {line}: XML root <{tag}> is neither TrackMate (<TrackMate>) nor ISBI (<root>)")
