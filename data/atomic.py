"""Write files so that a reader never sees half of one: write beside the target, then rename;
and leave no empty folder behind when work fails before its first file."""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path
from typing import Iterator

from .errors import DataError


def check_target(path: str | os.PathLike) -> Path:
    """Refuse now a file :func:`atomic_path` would refuse at the end of long work.

    Returns
    -------
    Path
        The folder the file goes in.

    Raises
    ------
    DataError
        If the target's folder does not exist or is a file, or the target is a folder, a pipe
        or a device.
    """
    target = Path(path)
    folder = target.parent if str(target.parent) else Path(".")
    if not folder.is_dir():
        raise DataError(target, f"{folder} is not a folder" if folder.exists() else f"folder {folder} does not exist")
    if target.is_dir():
        raise DataError(target, "is a folder; give a file name")
    if target.exists() and not target.is_file():
        # Renamed over, a pipe or a device (/dev/null, as root) would be replaced by a file.
        raise DataError(target, "is not a regular file (a pipe or a device); give a file name")
    return folder


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path in the target's folder; rename it onto ``path`` on success.

    On any exception the temporary file is removed and ``path`` is left as it was.

    Raises
    ------
    DataError
        If the target's folder does not exist or cannot be written, the target is a folder, or
        writing fails (a full disk: ENOSPC, a quota...), naming the target and the cause.
    """
    target = Path(path)
    folder = check_target(target)
    try:
        handle, temporary = tempfile.mkstemp(prefix=f".{target.name}.", suffix=target.suffix, dir=folder)
    except OSError as error:
        raise DataError(target, f"cannot write here ({error.strerror})") from None
    os.close(handle)
    # mkstemp creates owner-only files; give the result the mode any new file would get.
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(temporary, 0o666 & ~umask)
    temporary_path = Path(temporary)
    try:
        yield temporary_path
        os.replace(temporary_path, target)
    except OSError as error:
        temporary_path.unlink(missing_ok=True)
        # A failed write names the temporary file, or no file at all; the user knows the target.
        if error.filename not in (None, str(temporary_path), temporary_path):
            raise
        raise DataError(target, f"could not be written ({error.strerror or error})") from None
    except BaseException:
        temporary_path.unlink(missing_ok=True)
        raise


@contextlib.contextmanager
def output_folder(folder: str | os.PathLike) -> Iterator[Path]:
    """Create ``folder`` and its missing parents for the work in the ``with`` block.

    If the block fails or is interrupted, the folders created here that are still empty are
    removed again, so that a bad input or Ctrl-C before the first file leaves nothing behind.

    Raises
    ------
    DataError
        If the folder cannot be created or a file of that name exists.
    """
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise DataError(folder, "exists and is not a folder")
    # x/.. names no folder of its own to remove: x is the one made.
    missing = [path for path in (folder, *folder.parents) if not path.exists() and path.name not in ("", ".", "..")]
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise DataError(folder, f"cannot create output folder ({error.strerror})") from None
    try:
        yield folder
    except BaseException:
        for created in missing:  # deepest first
            if any(created.iterdir()):
                break
            created.rmdir()
        raise
