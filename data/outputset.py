"""A command's files in one folder as one set: all of one run, or all of the run before.

Files are written under temporary names beside their own (``.seedtrack-PID-NAME``), then a
journal naming them all (``.seedtrack-commit.json``) is renamed into place: the one step after
which the new set counts. The files are then renamed over the old ones and the manifest
(``manifest.json``: the command, the inputs' sizes and SHA-256, the files' sizes and SHA-256,
the version) is written last. Killed before the journal is in place, the folder holds the old set
untouched (and hidden temporaries, removed by the next set written there); killed after, the
journal says what is left to rename, and the next reader or writer of the folder finishes it
(:func:`finish_interrupted`), so that no reader ever takes a mix of two runs for one.

Readers call :func:`check_member` on a file they read: a file of a set whose manifest is missing,
or lists other bytes, is warned of in one line.
"""

from __future__ import annotations

import contextlib
import glob
import hashlib
import json
import os
from pathlib import Path
from typing import Iterable, Iterator

from .atomic import atomic_path, check_target, output_folder
from .errors import DataError, warn

MANIFEST = "manifest.json"
JOURNAL = ".seedtrack-commit.json"
_TEMPORARY = ".seedtrack-"
# The names `seedtrack run` writes: a folder holding them without a manifest is a set whose
# manifest is missing (an older seedtrack, a copy that left it out, a run killed half-way).
RUN_FILES = ("detections.csv", "tracks.csv", "overlay.mp4")
_CHUNK = 1 << 20


def file_digest(path: str | os.PathLike) -> dict:
    """Size (bytes) and SHA-256 (hex) of a file.

    Example
    -------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "a.txt"; _ = path.write_bytes(b"abc")
    >>> file_digest(path)["sha256"][:12], file_digest(path)["size"]
    ('ba7816bf8f01', 3)
    """
    digest = hashlib.sha256()
    size = 0
    with open(path, "rb") as stream:
        while chunk := stream.read(_CHUNK):
            digest.update(chunk)
            size += len(chunk)
    return {"size": size, "sha256": digest.hexdigest()}


def input_digest(path: str | os.PathLike) -> dict:
    """:func:`file_digest` of an input, or for a folder or glob pattern of frames, their total size
    and the SHA-256 of their names and digests in name order."""
    path = Path(path)
    if path.is_file():
        return {"path": str(path), **file_digest(path)}
    members = sorted(Path(name) for name in (glob.glob(str(path / "*")) if path.is_dir() else glob.glob(str(path))) if Path(name).is_file())
    digest = hashlib.sha256()
    size = 0
    for member in members:
        one = file_digest(member)
        size += one["size"]
        digest.update(f"{member.name}\0{one['sha256']}\n".encode("utf-8", "surrogateescape"))
    return {"path": str(path), "size": size, "sha256": digest.hexdigest(), "files": len(members)}


class OutputSet:
    """The files of one command being written into ``folder``; see :func:`output_set`.

    Attributes
    ----------
    folder : Path
    names : list of str
        The files asked for with :meth:`path`, in that order.
    """

    def __init__(self, folder: Path, command: str, inputs: Iterable[str | os.PathLike], version: str) -> None:
        self.folder = folder
        self.command = command
        self.inputs = [Path(path) for path in inputs]
        self.version = version
        self.names: list[str] = []
        self.committed = False

    def path(self, name: str) -> Path:
        """Where to write the file ``name`` of the set: a temporary name in the folder, with the
        same extension, renamed to ``folder/name`` when the set is complete.

        Raises
        ------
        DataError
            If ``folder/name`` is a folder, a pipe or a device (found now, not at the end).
        """
        if name not in self.names:
            check_target(self.folder / name)
            self.names.append(name)
        return self.folder / self._temporary(name)

    def name_of(self, path: str | os.PathLike) -> str | None:
        """The name in the set of a temporary file :meth:`path` gave, or None."""
        return next((name for name in self.names if Path(path) == self.path(name)), None)

    def _temporary(self, name: str) -> str:
        return f"{_TEMPORARY}{os.getpid()}-{name}"

    def manifest(self) -> dict:
        """The manifest of the files written so far (under their temporary names)."""
        return {
            "command": self.command,
            "seedtrack": self.version,
            "inputs": [input_digest(path) for path in self.inputs],
            "files": [{"name": name, **file_digest(self.path(name))} for name in self.names],
        }

    def commit(self) -> None:
        """Put the set in place of the folder's earlier one (see the module's description)."""
        missing = [name for name in self.names if not self.path(name).is_file()]
        if missing:
            raise DataError(self.folder / missing[0], "was not written")
        for name in self.names:
            _sync(self.path(name))
        journal = {**self.manifest(), "pending": {name: self._temporary(name) for name in self.names}}
        _write_json(self.folder / JOURNAL, journal)
        # From here on the journal needs the temporaries, and whoever reads the folder next
        # finishes what this process does not.
        self.committed = True
        _finish(self.folder, journal)

    def discard(self) -> None:
        """Remove the temporaries written so far; the folder's earlier set stays as it was."""
        if self.committed:
            return
        for name in self.names:
            self.path(name).unlink(missing_ok=True)


@contextlib.contextmanager
def output_set(folder: str | os.PathLike, command: str, inputs: Iterable[str | os.PathLike]) -> Iterator[OutputSet]:
    """Write a set of files into ``folder`` (created if missing), in place of the set there.

    Write each file to ``files.path(name)``; leaving the block normally puts them all in place and
    writes ``manifest.json`` last; an exception (or Ctrl-C) leaves the earlier set as it was.

    Parameters
    ----------
    folder : path-like
    command : str
        The command, as the manifest names it (``"seedtrack run"``).
    inputs : iterable of path-like
        The files (or frame folders, glob patterns) the set is made from, hashed into the manifest.

    Example
    -------
    >>> import tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp())
    >>> with output_set(out, "seedtrack demo", []) as files:
    ...     _ = files.path("a.txt").write_text("one")
    >>> sorted(path.name for path in out.iterdir())
    ['a.txt', 'manifest.json']
    """
    from importlib.metadata import PackageNotFoundError, version

    try:
        ours = version("seedtrack")
    except PackageNotFoundError:  # run from a checkout that is not installed
        ours = "unknown"
    with output_folder(folder) as made:
        finish_interrupted(made)
        _remove_stale_temporaries(made)
        files = OutputSet(made, command, inputs, ours)
        try:
            yield files
            files.commit()
        except DataError as error:
            files.discard()
            # The user named the folder, not the temporary: the message names the file of the set.
            name = files.name_of(error.path)
            if name is None:
                raise
            raise DataError(made / name, error.problem) from None
        except BaseException:
            files.discard()
            raise


def finish_interrupted(folder: str | os.PathLike) -> bool:
    """Finish putting in place a set whose writer was stopped after its journal was written.

    Returns
    -------
    bool
        Whether there was such a set.

    Raises
    ------
    DataError
        If the journal is unreadable or the folder cannot be written.
    """
    folder = Path(folder)
    path = folder / JOURNAL
    if not path.is_file():
        return False
    try:
        journal = json.loads(path.read_text(encoding="utf-8"))
        pending = journal["pending"]
    except (OSError, ValueError, KeyError, TypeError) as error:
        raise DataError(path, f"unreadable journal of an interrupted run ({error}); remove it and run again") from None
    try:
        _finish(folder, journal)
    except OSError as error:
        raise DataError(folder, f"cannot finish an interrupted run's files here ({error.strerror})") from None
    return bool(pending)


def _finish(folder: Path, journal: dict) -> None:
    # Every step may be done already (a second finisher, or one stopped half-way): each is
    # skipped then, so that finishing twice is finishing once.
    for name, temporary in journal["pending"].items():
        if (folder / temporary).exists():
            os.replace(folder / temporary, folder / name)
    manifest = {key: value for key, value in journal.items() if key != "pending"}
    _write_json(folder / MANIFEST, manifest)
    (folder / JOURNAL).unlink(missing_ok=True)
    _sync(folder)


def _write_json(path: Path, value: dict) -> None:
    with atomic_path(path) as temporary:
        with open(temporary, "w", encoding="utf-8") as out:
            json.dump(value, out, indent=1)
            out.write("\n")
            out.flush()
            os.fsync(out.fileno())


def _sync(path: Path) -> None:
    # Renames are only as durable as the data they point to: without this a power cut could
    # leave a committed name pointing at an empty file.
    handle = os.open(path, os.O_RDONLY)
    try:
        os.fsync(handle)
    finally:
        os.close(handle)


def _remove_stale_temporaries(folder: Path) -> None:
    # Temporaries of a writer killed before its journal: no set names them, and their process
    # is gone (a running writer's are left alone).
    for path in folder.glob(f"{_TEMPORARY}*-*"):
        pid = path.name[len(_TEMPORARY) :].split("-", 1)[0]
        if pid.isdigit() and not _alive(int(pid)):
            path.unlink(missing_ok=True)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def check_member(path: str | os.PathLike) -> None:
    """Warn (one line) if ``path`` is a file of a set that is not whole: its folder's manifest
    is missing (where the folder holds a run's files) or lists other bytes for it or another
    member. A set left half in place by a killed writer is finished first (:func:`finish_interrupted`).

    Example
    -------
    >>> import tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp())
    >>> with output_set(out, "seedtrack demo", []) as files:
    ...     _ = files.path("tracks.csv").write_text("track_id,frame,x,y\\n")
    >>> check_member(out / "tracks.csv")  # whole: nothing to say
    """
    path = Path(path)
    folder = path.parent
    if not path.is_file():
        return
    if (folder / JOURNAL).is_file():
        try:
            finish_interrupted(folder)
            warn(folder, "finished putting in place the files of a run that was stopped part-way")
        except DataError as error:
            warn(folder, f"holds a run stopped part-way, its files a mix of two runs ({error.problem})")
            return
    manifest_path = folder / MANIFEST
    if not manifest_path.is_file():
        if path.name in RUN_FILES and all((folder / name).is_file() for name in RUN_FILES):
            warn(path, f"no {MANIFEST} beside it: not known to be of one run with the other files in {folder}")
        return
    try:
        listed = {entry["name"]: entry for entry in json.loads(manifest_path.read_text(encoding="utf-8"))["files"]}
    except (OSError, ValueError, KeyError, TypeError):
        warn(manifest_path, "unreadable manifest; the files beside it are not known to be of one run")
        return
    if path.name not in listed:
        return
    entry = listed[path.name]
    if file_digest(path) != {"size": entry.get("size"), "sha256": entry.get("sha256")}:
        warn(path, f"is not the file {MANIFEST} lists (another run's, or changed since)")
        return
    # The other members: their sizes, so that a reader of one large set does not hash it all.
    for name, entry in listed.items():
        other = folder / name
        if not other.is_file() or other.stat().st_size != entry.get("size"):
            warn(path, f"{name} beside it is not the file {MANIFEST} lists: the folder mixes two runs")
            return
