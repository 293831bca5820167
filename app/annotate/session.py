"""One annotation session: the tracks being corrected, the edits made so far, and their files.

The edits are the session's state: the corrected tracks are always ``apply_corrections(start,
edits)``, so ``seedtrack correct START DIR/corrections.txt`` rebuilds ``DIR/tracks.csv`` exactly.
Every edit rewrites both files atomically (temporary file, then rename), so a server stopped at
any moment leaves whole files.
"""

from __future__ import annotations

import os
import shlex
import threading
from pathlib import Path

import numpy as np

from seedtrack.data.atomic import atomic_path
from seedtrack.data.corrections import Edit, apply_corrections, read_corrections
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


class EditRefused(ValueError):
    """An edit that does not apply to the tracks as they are (the message says why)."""


class ReassignUnconfirmed(EditRefused):
    """A click that would take another track's point, made without saying so: the message says
    what it would do (a dense field puts a neighbour's point within reach of a small move)."""


class Session:
    """The tracks being corrected and the list of edits, saved to ``folder`` after each change.

    Parameters
    ----------
    start : Tracks
        The tracks before any edit (empty for a manual session).
    folder : Path
        Output folder: ``corrections.txt`` and ``tracks.csv`` are written here.
    start_path : Path or None
        The tracks file ``start`` came from, named in ``corrections.txt``; None writes an empty
        ``start.csv`` into ``folder`` instead.

    Example
    -------
    >>> import tempfile; from pathlib import Path
    >>> session = Session(Tracks.from_rows([], [], [], []), Path(tempfile.mkdtemp()), None)
    >>> session.click(None, 0, 10.0, 20.0)
    1
    >>> session.tracks.to_rows()["x"].tolist()
    [10.0]
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
        self.edits: list[Edit] = []
        self._redo: list[Edit] = []
        saved = folder / CORRECTIONS
        if saved.exists():
            # Resume: the edits of an earlier session on this folder are the starting point.
            self.edits = read_corrections(saved)
            self.tracks = apply_corrections(start, self.edits, saved)
        else:
            self.tracks = start
        self._index()
        self._save()

    @property
    def can_redo(self) -> bool:
        """Whether an edit taken back can be made again."""
        return bool(self._redo)

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
            if holder is not None:
                later = self._frames.get(selected, np.empty(0, np.int64))
                verb = "join" if not (later >= frame).any() else "swap"
                if not reassign:
                    what = f"join track {holder} to track {selected}" if verb == "join" else f"swap tracks {selected} and {holder}"
                    raise ReassignUnconfirmed(f"this is track {holder}'s point: the click would {what} from frame {frame} on")
                self._apply(Edit(verb, (selected, holder, frame), 0))
            else:
                verb = "move" if frame in self._frame_sets.get(selected, ()) else "add"
                self._apply(Edit(verb, (selected, frame, x, y), 0))
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
            self.tracks = apply_corrections(self.start, self.edits, self.folder / CORRECTIONS)
            self._index()
            self._save()
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
            written = []
            for name, file in EXPORTS.items():
                write_tracks(self.folder / file, self.tracks, format=name)
                written.append(self.folder / file)
            return written

    # --- internals ----------------------------------------------------------------------------

    def _apply(self, edit: Edit, keep_redo: bool = False) -> None:
        line = Edit(edit.verb, edit.arguments, len(self.edits) + 1)
        try:
            tracks = apply_corrections(self.tracks, [line], "edit")
        except DataError as error:
            raise EditRefused(str(error).removeprefix("edit:1: ")) from None
        self.edits.append(line)
        if not keep_redo:
            self._redo.clear()
        self.tracks = tracks
        self._index()
        self._save()

    def _index(self) -> None:
        rows = self.tracks.to_rows()
        self._rows = rows
        order = np.argsort(rows["track_id"], kind="stable")
        ids, starts = np.unique(rows["track_id"][order], return_index=True)
        groups = np.split(rows["frame"][order], starts[1:]) if ids.size else []
        self._frames = dict(zip(ids.tolist(), groups))
        self._frame_sets = {track: set(frames.tolist()) for track, frames in self._frames.items()}

    def _holder(self, frame: int, x: float, y: float) -> int | None:
        rows = self._rows
        here = np.flatnonzero(rows["frame"] == frame)
        if here.size == 0:
            return None
        distance = np.hypot(rows["x"][here] - x, rows["y"][here] - y)
        nearest = int(np.argmin(distance))
        return int(rows["track_id"][here[nearest]]) if distance[nearest] <= SAME_POINT else None

    def _new_id(self) -> int:
        used = [int(self.start.track_ids.max()) if self.start.n_tracks else 0]
        used += [max(self._frames) if self._frames else 0]
        used += [edit.arguments[0] for edit in self.edits if edit.verb == "add"]
        used += [edit.arguments[2] for edit in self.edits if edit.verb == "split"]
        # Never reuse an id, even of a deleted track, so that an id in the file means one track.
        return max(used) + 1

    def _save(self) -> None:
        with atomic_path(self.folder / CORRECTIONS) as temporary:
            temporary.write_text(corrections_text(self.edits, self.start_path, self.folder), encoding="utf-8")
        write_tracks(self.folder / TRACKS, self.tracks)


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
    lines += [" ".join(_word(value) for value in (edit.verb, *edit.arguments)) for edit in edits]
    return "\n".join(lines) + "\n"


def _word(value) -> str:
    # str() of a float is its shortest exact form, so `correct` reads back the very same number.
    return str(value)
