"""Outputs never replace an input: every command that writes names its inputs and outputs here
before any work, and an output that would land on an input is refused in one line."""

from __future__ import annotations

import glob
import os
from pathlib import Path
from typing import Iterable

from seedtrack.data.errors import DataError

PathLike = str | os.PathLike


def refuse_replacing_inputs(inputs: Iterable[PathLike | None], outputs: Iterable[PathLike | None]) -> None:
    """Refuse an output that is one of the inputs, before anything is written.

    An output is refused when it is the same file as an input (by ``os.path.samefile``: hard and
    symbolic links and ``./`` spellings included, or the same resolved path), when it is a folder of
    frames given as input, or when it would add a file to such a folder (the next read of the folder
    would take it for a frame). Glob patterns among the inputs count with the files they match.

    Parameters
    ----------
    inputs : iterable of path-like or None
        Files (clips, tables, frame folders, glob patterns) the command reads; None is skipped.
    outputs : iterable of path-like or None
        Files or folders the command writes; None is skipped.

    Raises
    ------
    DataError
        Naming the output and the input it would replace.

    Example
    -------
    >>> import tempfile, pathlib
    >>> clip = pathlib.Path(tempfile.mkdtemp()) / "clip.mp4"; _ = clip.write_bytes(b"")
    >>> refuse_replacing_inputs([clip], [clip.with_name("overlay.mp4")])
    >>> refuse_replacing_inputs([clip], [clip.parent / "." / "clip.mp4"])
    Traceback (most recent call last):
    ...
    seedtrack.data.errors.DataError: ...clip.mp4: is an input of this command; writing it would replace the input: give another output name
    """
    named = [Path(path) for path in _expanded(inputs)]
    for output in outputs:
        if output is None:
            continue
        output = Path(output)
        for source in named:
            if _same(output, source):
                alias = "" if str(source) == str(output) else f" ({source})"
                raise DataError(output, f"is an input of this command{alias}; writing it would replace the input: give another output name")
            if source.is_dir() and _same(output.parent, source):
                raise DataError(output, f"lies in {source}, a folder of frames read as input; writing it would add a frame: give another output folder")


def _expanded(inputs: Iterable[PathLike | None]) -> Iterable[PathLike]:
    for path in inputs:
        if path is None:
            continue
        text = os.fspath(path)
        if not os.path.exists(text) and glob.has_magic(text):
            yield from glob.glob(text)
        else:
            yield path


def _same(a: Path, b: Path) -> bool:
    try:
        if os.path.samefile(a, b):
            return True
    except (OSError, ValueError):  # either missing (the output, before its first run) or unreadable
        pass
    return os.path.realpath(a) == os.path.realpath(b)
