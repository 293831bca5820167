"""napari's Tracks layer data as a NumPy file (``.npy``): one row per point, columns
``track_id, t, y, x`` (napari's ID, T, Y, X order; frames 0-based, pixels), float64.

Open in napari with ``viewer.add_tracks(numpy.load("tracks.npy"))``. Interpolated points are
written as points (napari's layer has no such flag) and read back as measured.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..atomic import atomic_path
from ..errors import DataError, check_file
from .rows import Rows


def read(path) -> Rows:
    """Rows of a napari tracks array: (N, 4) numbers, track_id, t, y, x."""
    path = check_file(Path(path))
    try:
        data = np.load(path, allow_pickle=False)
    except (ValueError, OSError) as error:
        raise DataError(path, f"not a NumPy array file: {error}") from None
    if data.ndim != 2 or data.shape[1] != 4 or not np.issubdtype(data.dtype, np.number):
        raise DataError(path, f"napari tracks are an (N, 4) array of numbers (track_id, t, y, x); found shape {data.shape}, {data.dtype}")
    whole = data[:, :2] == np.round(data[:, :2])
    if not whole.all():
        raise DataError(path, f"line {int(np.flatnonzero(~whole.all(axis=1))[0]) + 1}: track_id and t must be whole numbers")
    return Rows(data[:, 0].astype(np.int64), data[:, 1].astype(np.int64), data[:, 3].astype(float), data[:, 2].astype(float), np.arange(1, data.shape[0] + 1))


def write(path, rows: dict[str, np.ndarray]) -> None:
    """Write tracks as napari's (N, 4) array, sorted by track then frame, atomically."""
    order = np.lexsort((rows["frame"], rows["track_id"]))
    data = np.column_stack((rows["track_id"][order], rows["frame"][order], rows["y"][order], rows["x"][order])).astype(float)
    with atomic_path(path) as temporary, open(temporary, "wb") as handle:
        np.save(handle, data, allow_pickle=False)
