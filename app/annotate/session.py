"""One annotation session: the tracks being corrected, the edits made so far, and their files.

The edits are the session's state: the corrected tracks are always ``apply_corrections(start,
edits)``, so ``seedtrack correct START DIR/corrections.txt`` rebuilds ``DIR/tracks.csv`` exactly.
An edit changes only the tracks it names, and is appended to ``corrections.txt`` and flushed to
disk (fsync) before it is answered; an undo cuts the file's last line off. ``tracks.csv``, whose
rewrite grows with all the points, is written a moment after the last edit and when the session
closes. A server killed at any moment (even ``kill -9``) loses nothing: the next session on the
folder replays ``corrections.txt`` to the same tracks and writes ``tracks.csv`` again.
"""

from __future__ import annotations

import os
import shlex
import threading
from pathlib import Path

from seedtrack.data.atomic import atomic_path
from seedtrack.data.corrections import Edit, apply_edit, points_of, read_corrections, tracks_of
from seedtrack.data.errors import DataError
from seedtrack.data.trackfile import FORMATS, write_tracks
from seedtrack.tracking.tracks import Tracks

CORRECTIONS = "corrections.txt"
TRACKS = "tracks.csv"
# Without TRACKS the session starts from no tracks, written here so that `correct` has an input.
EMPTY_START = "start.csv"
# Every track format the project writes, and the file each export goes to; but GEFF, which needs
# an optional package and is a folder (never replaced): `seedtrack correct --out x.geff` writes it.
EXPORTS = {"csv": "tracks.csv", "trackpy": "tracks.trackpy.csv", "mot": "tracks.mot.txt", "trackmate": "tracks.trackmate.xml", "isbi": "tracks.isbi.xml", "napari": "tracks.napari.npy"}
assert set(EXPORTS) == set(FORMATS) - {"geff"}
# Every file a session may write into its folder.
SESSION_FILES = (CORRECTIONS, TRACKS, EMPTY_START, *EXPORTS.values())
# A click within this distance of a track's point (pixels) means that point.
SAME_POINT = 0.5
# tracks.csv is written this long (seconds) after the last change: a burst of clicks costs one write.
SAVE_DELAY = 2.0


class EditRefused(ValueError):
    """An edit that does not apply to the tracks as they are (the message says why)."""


class ReassignUnconfirmed(EditRefused):
    """A click that would take another track's point, made without saying so: the message says
    what it would do (a dense field puts a neighbour's point within reach of a small move)."""


class Session:
    """The tracks being corrected and the list of edits, saved to ``folder`` as they change.

    Parameters
    ----------
    start : Tracks
        The tracks before any edit (empty for a manual session).
    folder : Path
        Output folder: ``corrections.txt`` and ``tracks.csv`` are written here.
    start_path : Path or None
        The tracks file ``start`` came from, named in ``corrections.txt``; None writes an empty
        ``start.csv`` into ``folder`` instead.

    Attributes
    ----------
    version : int
        Changes made so far (edits, undos, redos): what :meth:`changed_since` counts in.

    Example
    -------
    >>> import tempfile; from pathlib import Path
    >>> session = Session(Tracks.from_rows([], [], [], []), Path(tempfile.mkdtemp()), None)
    >>> session.click(None, 0, 10.0, 20.0)
    1
    >>> session.tracks.to_rows()["x"].tolist()
    [10.0]
    >>> session.close()
    """

    def __init__(self, start: Tracks, folder: Path, start_path: Path | None) -> None:
        self.start = start
        self.folder = folder
        if start_path is None:
            start_path = folder / EMPTY_START
            if not start_path.exists():
                write_tracks(start_path, start)
        self.start_path = start_path
        # Held while the session changes, and by whoever reads the tracks or stops the server.
        self.lock = threading.Lock()
        # {track id: {frame: (x, y, interpolated)}}. An edit replaces the inner dicts of the tracks
        # it names instead of changing them, so a shallow copy of the outer dict is a snapshot.
        self.points = points_of(start)
        self.by_frame: dict[int, set[int]] = {}
        for track, frames in self.points.items():
            for frame in frames:
                self.by_frame.setdefault(frame, set()).add(track)
        self.edits: list[Edit] = []
        # What each edit replaced: {track id: its points before, None for no track}.
        self._before: list[dict[int, dict | None]] = []
        self._redo: list[Edit] = []
        self.version = 0
        # The tracks each change touched: the change to version v is self._touched[v - 1].
        self._touched: list[frozenset[int]] = []
        self._top = max(self.points, default=0)
        self._tracks_cache: tuple[int, Tracks] | None = None
        saved = folder / CORRECTIONS
        if saved.exists():
            # Resume: the edits of an earlier session on this folder are the starting point.
            _drop_torn_line(saved)
            for edit in read_corrections(saved):
                self._do(edit, f"{saved}:{edit.line}")
        with atomic_path(saved) as temporary:
            temporary.write_text(corrections_text(self.edits, self.start_path, self.folder), encoding="utf-8")
        text = corrections_text([], self.start_path, self.folder).encode()
        # Where each edit's line starts in the file: an undo cuts the file there.
        self._line_starts = [len(text)]
        for edit in self.edits:
            self._line_starts.append(self._line_starts[-1] + len(_line(edit).encode()))
        self._log = os.open(saved, os.O_WRONLY | os.O_APPEND)
        # Lock order: _write_lock before lock; _timer_lock is taken alone (an edit takes it
        # holding lock, so it must never wait for _write_lock).
        self._write_lock = threading.Lock()
        self._timer_lock = threading.Lock()
        self._timer: threading.Timer | None = None
        self._saved_version = -1
        self._write_tracks()

    @property
    def can_redo(self) -> bool:
        """Whether an edit taken back can be made again."""
        return bool(self._redo)

    @property
    def tracks(self) -> Tracks:
        """The corrected tracks as they are now (built once per version; hold ``lock`` if others edit)."""
        return self._tracks_at(self.version, dict(self.points))

    def snapshot(self) -> tuple[int, Tracks, list[Edit], bool]:
        """The version, the tracks, the edits and :attr:`can_redo`, all of one moment.

        The lock is held only to copy the outer dict of points, not while the tracks are built.
        """
        with self.lock:
            version, points, edits, can_redo = self.version, dict(self.points), list(self.edits), self.can_redo
        return version, self._tracks_at(version, points), edits, can_redo

    def _tracks_at(self, version: int, points: dict) -> Tracks:
        cached = self._tracks_cache
        if cached is None or cached[0] != version:
            cached = (version, tracks_of(points))
            if self._tracks_cache is None or self._tracks_cache[0] < version:
                self._tracks_cache = cached
        return cached[1]

    def changed_since(self, version: int) -> set[int] | None:
        """Ids of the tracks changed after ``version`` (their points, or that they are gone); None if unknown.

        Example
        -------
        >>> import tempfile; from pathlib import Path
        >>> session = Session(Tracks.from_rows([], [], [], []), Path(tempfile.mkdtemp()), None)
        >>> session.click(None, 0, 1.0, 2.0), session.click(None, 0, 5.0, 6.0)
        (1, 2)
        >>> session.changed_since(1), session.changed_since(2), session.changed_since(3)
        ({2}, set(), None)
        >>> session.close()
        """
        if not 0 <= version <= self.version:
            return None
        return set().union(*self._touched[version:])

    # --- what a click means -------------------------------------------------------------------

    def click(self, selected: int | None, frame: int, x: float, y: float, reassign: bool = True) -> int:
        """Apply what pointing at (x, y) in ``frame`` means, with track ``selected`` (or none) chosen.

        With no track selected, a point of a track selects that track and anywhere else starts
        a new track there. With track A selected, a point of another track B joins B's points
        from ``frame`` on to A when A has none there (a link), or else swaps A's and B's points
        from ``frame`` on (a wrong link fixed); anywhere else moves A's point in ``frame`` there,
        or adds one.

        Parameters
        ----------
        selected : int or None
            Id of the selected track.
        frame : int
            0-based frame index.
        x, y : float
            Pixels.
        reassign : bool
            Whether a click on another track's point may take it (a join or swap); if not, such
            a click changes nothing.

        Returns
        -------
        int
            The track selected afterwards.

        Raises
        ------
        ReassignUnconfirmed
            If the click would join or swap and ``reassign`` is False; the message says which.
        """
        # Hundredths of a pixel are far below what a click can aim at, and keep the file readable.
        x, y = round(float(x), 2), round(float(y), 2)
        with self.lock:
            holder = self._holder(frame, x, y)
            if selected is None:
                if holder is not None:
                    return holder
                new = self._new_id()
                self._apply(Edit("add", (new, frame, x, y), 0))
                return new
            if holder == selected:
                return selected
            own = self.points.get(selected, {})
            if holder is not None:
                verb = "swap" if any(f >= frame for f in own) else "join"
                if not reassign:
                    what = f"join track {holder} to track {selected}" if verb == "join" else f"swap tracks {selected} and {holder}"
                    raise ReassignUnconfirmed(f"this is track {holder}'s point: the click would {what} from frame {frame} on")
                self._apply(Edit(verb, (selected, holder, frame), 0))
            else:
                self._apply(Edit("move" if frame in own else "add", (selected, frame, x, y), 0))
            return selected

    def split(self, track: int, frame: int) -> int:
        """Split ``track`` before ``frame``; returns the id of the new track (its points from ``frame`` on)."""
        with self.lock:
            new = self._new_id()
            self._apply(Edit("split", (track, frame, new), 0))
            return new

    def delete(self, track: int, frame: int | None = None) -> None:
        """Delete ``track``, or only its point in ``frame``."""
        with self.lock:
            self._apply(Edit("delete", (track,) if frame is None else (track, frame), 0))

    def undo(self) -> bool:
        """Take back the last edit; False if there is none."""
        with self.lock:
            if not self.edits:
                return False
            self._redo.append(self.edits.pop())
            before = self._before.pop()
            self._restore(before)
            self._log_cut()
            self._changed(before)
            return True

    def redo(self) -> bool:
        """Make again the last edit taken back; False if there is none."""
        with self.lock:
            if not self._redo:
                return False
            edit = self._redo.pop()
            self._apply(edit, keep_redo=True)
            return True

    def export(self) -> list[Path]:
        """Write the corrected tracks in every track format; returns the files written."""
        with self.lock:
            tracks = self.tracks
            written = []
            for name, file in EXPORTS.items():
                write_tracks(self.folder / file, tracks, format=name)
                written.append(self.folder / file)
            return written

    def close(self) -> None:
        """Write ``tracks.csv`` now if it lags behind the edits, and close the corrections log."""
        with self._timer_lock:
            if self._timer is not None:
                self._timer.cancel()
        self._write_tracks()
        with self.lock:
            if self._log >= 0:
                os.close(self._log)
                self._log = -1

    # --- internals ----------------------------------------------------------------------------

    def _apply(self, edit: Edit, keep_redo: bool = False) -> None:
        if self._log < 0:
            raise EditRefused("the server is stopping; the edit was not made")
        line = Edit(edit.verb, edit.arguments, len(self.edits) + 1)
        try:
            before = self._do(line, "edit")
        except DataError as error:
            raise EditRefused(error.problem) from None
        # The edit is on disk before it is answered: a crash after this loses nothing.
        try:
            data = _line(line).encode()
            while data:
                data = data[os.write(self._log, data) :]
            os.fsync(self._log)
        except OSError as error:
            self.edits.pop()
            self._restore(self._before.pop())
            os.ftruncate(self._log, self._line_starts[-1])
            raise EditRefused(f"{self.folder / CORRECTIONS}: cannot save the edit ({error.strerror}); it was not made") from None
        if not keep_redo:
            self._redo.clear()
        self._line_starts.append(self._line_starts[-1] + len(_line(line).encode()))
        self._changed(before)

    def _do(self, edit: Edit, where: str) -> dict[int, dict | None]:
        """Apply ``edit`` to the points and the frame index; returns what it replaced."""
        verb, args = edit.verb, edit.arguments
        named = {args[0]}
        if verb in ("join", "swap"):
            named.add(args[1])
        elif verb == "split" and len(args) == 3:
            named.add(args[2])
        before = {track: self.points.get(track) for track in named}
        for track, points in before.items():
            if points is not None:
                self.points[track] = dict(points)
        try:
            apply_edit(self.points, edit, where)
        except DataError:
            self._restore(before, index=False)
            raise
        self._reindex(before)
        self.edits.append(edit)
        self._before.append(before)
        self._top = max(self._top, *named)
        return before

    def _restore(self, before: dict[int, dict | None], index: bool = True) -> None:
        now = {track: self.points.get(track) for track in before}
        for track, points in before.items():
            if points is None:
                self.points.pop(track, None)
            else:
                self.points[track] = points
        if index:
            self._reindex(now)

    def _reindex(self, before: dict[int, dict | None]) -> None:
        for track, points in before.items():
            for frame in points or ():
                here = self.by_frame[frame]
                here.discard(track)
                if not here:
                    del self.by_frame[frame]
            for frame in self.points.get(track, ()):
                self.by_frame.setdefault(frame, set()).add(track)

    def _changed(self, before: dict) -> None:
        self.version += 1
        self._touched.append(frozenset(before))
        with self._timer_lock:
            if self._timer is not None:
                self._timer.cancel()
            self._timer = threading.Timer(SAVE_DELAY, self._write_tracks)
            self._timer.daemon = True
            self._timer.start()

    def _log_cut(self) -> None:
        self._line_starts.pop()
        os.ftruncate(self._log, self._line_starts[-1])
        os.fsync(self._log)

    def _write_tracks(self) -> None:
        # Writes one at a time, each of the newest snapshot, so a slow older one never lands last.
        with self._write_lock:
            with self.lock:
                if self._saved_version == self.version:
                    return
                version, snapshot = self.version, dict(self.points)
            write_tracks(self.folder / TRACKS, tracks_of(snapshot))
            self._saved_version = version

    def _holder(self, frame: int, x: float, y: float) -> int | None:
        best, nearest = None, SAME_POINT
        for track in self.by_frame.get(frame, ()):
            px, py = self.points[track][frame][:2]
            distance = ((px - x) ** 2 + (py - y) ** 2) ** 0.5
            if distance <= nearest and (best is None or distance < nearest or track < best):
                best, nearest = track, distance
        return best

    def _new_id(self) -> int:
        # Never reuse an id, even of a deleted track or of an edit taken back, so that an id in
        # the file means one track.
        return self._top + 1


def _drop_torn_line(path: Path) -> None:
    """Cut off a last line a crash left half written (it has no line end): the edit was never answered."""
    data = path.read_bytes()
    if data and not data.endswith(b"\n"):
        with open(path, "r+b") as handle:
            handle.truncate(data.rfind(b"\n") + 1)


def edit_text(edit: Edit) -> str:
    """One edit as its line of a corrections file, without the line end.

    Example
    -------
    >>> edit_text(Edit("move", (3, 5, 12.5, 7.0), 1))
    'move 3 5 12.5 7.0'
    """
    return " ".join(_word(value) for value in (edit.verb, *edit.arguments))


def _line(edit: Edit) -> str:
    return edit_text(edit) + "\n"


def corrections_text(edits: list[Edit], start_path: Path, folder: Path) -> str:
    """The edits as a corrections file, with a comment saying how to apply them: a command that
    works when run in ``folder`` (the file's own), whatever folder the session was started from.

    Example
    -------
    >>> print(corrections_text([Edit("swap", (3, 5, 12), 1)], Path("/data/run 1/tracks.csv"), Path("/data/truth")), end="")
    # seedtrack annotate: edits to /data/run 1/tracks.csv; in /data/truth, apply with
    #   seedtrack correct '../run 1/tracks.csv' corrections.txt --out tracks.csv
    swap 3 5 12
    """
    start = os.path.relpath(os.path.abspath(start_path), os.path.abspath(folder))
    lines = [
        f"# seedtrack annotate: edits to {os.path.abspath(start_path)}; in {os.path.abspath(folder)}, apply with",
        f"#   seedtrack correct {shlex.quote(start)} {CORRECTIONS} --out {TRACKS}",
    ]
    return "".join(line + "\n" for line in lines) + "".join(_line(edit) for edit in edits)


def _word(value) -> str:
    # str() of a float is its shortest exact form, so `correct` reads back the very same number.
    return str(value)
