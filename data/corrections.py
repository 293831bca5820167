"""Corrections files: a plain-text list of edits that turns tracker output into ground truth.

One edit a line; ``#`` starts a comment; blank lines are ignored. Track ids and frames are
whole numbers (0-based frames), positions in pixels:

==========================  =================================================================
``join A B FRAME``          track B's points from FRAME on become track A's (A must have none
                            there); B keeps its earlier points, if any
``swap A B FRAME``          tracks A and B exchange their points from FRAME on
``split A FRAME [NEW]``     track A's points from FRAME on become track NEW (default: the
                            largest id in use + 1); NEW must not exist
``delete A [FRAME]``        delete track A, or only its point in FRAME
``move A FRAME X Y``        track A's point in FRAME moves to (X, Y), as a measured point
``add A FRAME X Y``         track A (new or existing) gets a measured point at (X, Y) in FRAME
==========================  =================================================================

Edits apply in file order, each to the result of the ones before. Every problem is reported as
``FILE:LINE: problem``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from seedtrack.tracking.tracks import Tracks

from .csvio import text_lines
from .errors import DataError, check_file
from .numbers import check_range

# verb -> (argument kinds, number of optional trailing arguments)
_GRAMMAR = {
    "join": (("track", "track", "frame"), 0),
    "swap": (("track", "track", "frame"), 0),
    "split": (("track", "frame", "track"), 1),
    "delete": (("track", "frame"), 1),
    "move": (("track", "frame", "x", "y"), 0),
    "add": (("track", "frame", "x", "y"), 0),
}
_USAGE = {
    "join": "join A B FRAME",
    "swap": "swap A B FRAME",
    "split": "split A FRAME [NEW_ID]",
    "delete": "delete A [FRAME]",
    "move": "move A FRAME X Y",
    "add": "add A FRAME X Y",
}


@dataclass(frozen=True)
class Edit:
    """One parsed line: the verb, its arguments (ints, then floats for X Y) and its line number."""

    verb: str
    arguments: tuple
    line: int


def read_corrections(path) -> list[Edit]:
    """Parse a corrections file.

    Raises
    ------
    DataError
        ``FILE:LINE: problem`` for the first line that is not a valid edit.
    """
    path = Path(path)
    check_file(path)
    edits = []
    for number, text in text_lines(path):
        words = text.split("#", 1)[0].split()
        if words:
            edits.append(_parse(f"{path}:{number}", words, number))
    return edits


def _parse(where: str, words: list[str], number: int) -> Edit:
    verb, values = words[0].lower(), words[1:]
    if verb not in _GRAMMAR:
        raise DataError(where, f"unknown edit {words[0]!r}; expected one of {', '.join(_GRAMMAR)}")
    kinds, optional = _GRAMMAR[verb]
    if not len(kinds) - optional <= len(values) <= len(kinds):
        raise DataError(where, f"{verb} takes {len(kinds) - optional if optional else len(kinds)}{'-' + str(len(kinds)) if optional else ''} values: {_USAGE[verb]}")
    parsed = []
    for kind, word in zip(kinds, values):
        if kind in ("x", "y"):
            try:
                value = float(word)
            except ValueError:
                value = math.nan
            if not math.isfinite(value):
                raise DataError(where, f"{kind.upper()} must be a finite number of pixels, got {word!r}")
        else:
            try:
                value = int(word)
            except ValueError:
                raise DataError(where, f"{'a track id' if kind == 'track' else 'a frame'} must be a whole number, got {word!r}") from None
            if kind == "frame" and value < 0:
                raise DataError(where, f"frame must be >= 0 (frames count from 0), got {value}")
        check_range(where, {"track": "track_id"}.get(kind, kind), np.array([float(value)]), np.array([number]))
        parsed.append(value)
    return Edit(verb, tuple(parsed), number)


def apply_corrections(tracks: Tracks, edits: list[Edit], path) -> Tracks:
    """Apply edits in order.

    Parameters
    ----------
    tracks : Tracks
    edits : list of Edit
        From :func:`read_corrections`.
    path : path-like
        The corrections file, for error messages.

    Raises
    ------
    DataError
        ``FILE:LINE: problem`` for the first edit that names a missing track or point, or
        would put two points of one track in one frame.
    """
    points = points_of(tracks)
    for edit in edits:
        apply_edit(points, edit, f"{path}:{edit.line}")
    return tracks_of(points)


def points_of(tracks: Tracks) -> dict[int, dict[int, tuple[float, float, int]]]:
    """The tracks as ``{track id: {frame: (x, y, interpolated)}}``, the form edits apply to.

    Example
    -------
    >>> points_of(Tracks.from_rows([4, 4], [2, 3], [1.0, 2.0], [5.0, 6.0]))
    {4: {2: (1.0, 5.0, 0), 3: (2.0, 6.0, 0)}}
    """
    rows = tracks.to_rows()
    points: dict[int, dict[int, tuple[float, float, int]]] = {}
    for track_id, frame, x, y, interpolated in zip(*(rows[name].tolist() for name in ("track_id", "frame", "x", "y", "interpolated"))):
        points.setdefault(track_id, {})[frame] = (x, y, interpolated)
    return points


def tracks_of(points: dict[int, dict[int, tuple[float, float, int]]]) -> Tracks:
    """The :class:`Tracks` that :func:`points_of` form holds (tracks without points left out).

    Example
    -------
    >>> tracks_of({4: {3: (2.0, 6.0, 0), 2: (1.0, 5.0, 0)}}).to_rows()["frame"]
    array([2, 3])
    """
    flat = [(t, f, *p) for t in sorted(points) for f, p in sorted(points[t].items())]
    table = np.array(flat, dtype=float).reshape(-1, 5)
    return Tracks.from_rows(table[:, 0].astype(np.int64), table[:, 1].astype(np.int64), table[:, 2], table[:, 3], table[:, 4].astype(np.int64))


def apply_edit(points: dict, edit: Edit, where: str) -> None:
    """Apply one edit in place to ``points`` (the :func:`points_of` form), changing only the tracks it names.

    Every check is made before anything changes, so a refused edit leaves ``points`` as it was.

    Raises
    ------
    DataError
        ``WHERE: problem`` when the edit names a missing track or point, or would put two
        points of one track in one frame.

    Example
    -------
    >>> points = {1: {0: (0.0, 0.0, 0)}}
    >>> apply_edit(points, Edit("add", (1, 1, 3.0, 4.0), 1), "edit")
    >>> points[1][1]
    (3.0, 4.0, 0)
    """
    def track(track_id: int) -> dict:
        if track_id not in points:
            raise DataError(where, f"track {track_id} does not exist")
        return points[track_id]

    def tail(track_id: int, frame: int) -> dict:
        return {f: p for f, p in track(track_id).items() if f >= frame}

    def keep_head(track_id: int, frame: int) -> None:
        head = {f: p for f, p in points[track_id].items() if f < frame}
        if head:
            points[track_id] = head
        else:
            del points[track_id]

    verb, args = edit.verb, edit.arguments
    if verb in ("join", "swap"):
        a, b, frame = args
        if a == b:
            raise DataError(where, f"{verb} needs two different tracks, got {a} twice")
        tail_a, tail_b = tail(a, frame), tail(b, frame)
        if not tail_b:
            raise DataError(where, f"track {b} has no points from frame {frame} on")
        if verb == "join" and tail_a:
            raise DataError(where, f"track {a} already has points from frame {frame} on (frame {min(tail_a)}); split it first or use swap")
        keep_head(b, frame)
        points[a].update(tail_b)
        points[a] = {f: p for f, p in points[a].items() if f < frame or f in tail_b}
        if verb == "swap" and tail_a:
            points.setdefault(b, {}).update(tail_a)
    elif verb == "split":
        a, frame = args[:2]
        moved = tail(a, frame)
        if not moved:
            raise DataError(where, f"track {a} has no points from frame {frame} on")
        new = args[2] if len(args) == 3 else max(points) + 1
        if new in points:
            raise DataError(where, f"track {new} already exists; choose a new id")
        keep_head(a, frame)
        points[new] = moved
    elif verb == "delete":
        if len(args) == 1:
            track(args[0])
            del points[args[0]]
        else:
            a, frame = args
            if frame not in track(a):
                raise DataError(where, f"track {a} has no point in frame {frame}")
            del points[a][frame]
            if not points[a]:
                del points[a]
    elif verb == "move":
        a, frame, x, y = args
        if frame not in track(a):
            raise DataError(where, f"track {a} has no point in frame {frame}; use add")
        points[a][frame] = (x, y, 0)
    else:  # add
        a, frame, x, y = args
        if frame in points.get(a, {}):
            raise DataError(where, f"track {a} already has a point in frame {frame}; use move")
        points.setdefault(a, {})[frame] = (x, y, 0)
