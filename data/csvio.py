"""CSV tables: a header row, then one row per record; columns are 1-D numpy arrays.

The file formats are a contract with users and other tools: ``frame`` is a 0-based frame
index, ``x`` runs to the right and ``y`` down, in pixels, with pixel centres at integer
coordinates.
"""

from __future__ import annotations

import csv
import os
from pathlib import Path
from typing import Iterator

import numpy as np

from .atomic import atomic_path
from .errors import DataError

DETECTION_COLUMNS = ("frame", "x", "y", "area")
TRACK_COLUMNS = ("track_id", "frame", "x", "y", "interpolated")

# Enough digits that a position survives a round trip to well below a thousandth of a pixel,
# few enough that files stay readable; fixed so that the same input gives the same bytes.
_FLOAT_FORMAT = "{:.4f}"
_ROWS_PER_BLOCK = 10_000


def _format_column(values: np.ndarray) -> list[str]:
    if values.dtype.kind in "OUS":
        return [str(v) for v in values]
    if np.issubdtype(values.dtype, np.integer) or values.dtype == bool:
        return [str(int(v)) for v in values]
    return ["" if np.isnan(v) else _FLOAT_FORMAT.format(v) for v in values.astype(float)]


def write_table(path: str | os.PathLike, columns: dict[str, np.ndarray]) -> None:
    """Write columns of equal length as CSV with a header, atomically.

    Parameters
    ----------
    path : path-like
        Output file; replaced only once the whole table is written.
    columns : dict of str to ndarray
        Column name to 1-D array; integer and boolean columns are written as integers, float
        columns with four decimals, text (object or string) columns as they are.
    """
    names = list(columns)
    lengths = {len(columns[name]) for name in names}
    if len(lengths) > 1:
        raise ValueError(f"columns differ in length: {sorted(lengths)}")
    arrays = [np.asarray(columns[name]) for name in names]
    rows = lengths.pop() if lengths else 0
    with atomic_path(path) as temporary:
        with open(temporary, "w", newline="", encoding="utf-8") as handle:
            writer = csv.writer(handle, lineterminator="\n")
            writer.writerow(names)
            # Formatted a block at a time: as text all at once, a long clip's detections took
            # 50 MB (120,000 rows), more than anything else in `run`.
            for start in range(0, rows, _ROWS_PER_BLOCK):
                block = [_format_column(array[start : start + _ROWS_PER_BLOCK]) for array in arrays]
                writer.writerows(zip(*block))


def text_lines(path: Path) -> Iterator[tuple[int, str]]:
    """``(line number from 1, line)`` of a UTF-8 text file (a byte-order mark is skipped; line
    endings are kept as written, as the csv module wants them).

    Raises
    ------
    DataError
        If the file is not UTF-8 text.
    """
    with open(path, newline="", encoding="utf-8-sig") as handle:
        try:
            yield from enumerate(handle, start=1)
        except UnicodeDecodeError as error:
            raise DataError.not_utf8(path, error) from None


def read_table(
    path: str | os.PathLike,
    required: tuple[str, ...] = (),
    integer: tuple[str, ...] = ("frame", "track_id", "interpolated"),
    others_as_text: bool = False,
) -> dict[str, np.ndarray]:
    """Read a CSV table with a header row into numeric columns.

    Parameters
    ----------
    path : path-like
        The CSV file.
    required : tuple of str
        Columns that must be present.
    integer : tuple of str
        Columns parsed as integers where present; every other column is parsed as float when
        all its values are numbers, and kept as text otherwise.
    others_as_text : bool
        Keep every column that is neither required nor integer as text, exactly as written,
        so that it can be copied to another file unchanged.

    Returns
    -------
    dict of str to ndarray
        One array per column, in file order.

    Raises
    ------
    DataError
        If the file is missing, empty, repeats a column name, lacks a required column, or holds text, NaN or
        infinity in a required column.
    """
    path = Path(path)
    if not path.is_file():
        raise DataError(path, "no such file")
    rows = list(csv.reader(line for _, line in text_lines(path)))
    if not rows:
        raise DataError(path, "the file is empty (expected a header row)")
    header = [name.strip() for name in rows[0]]
    repeated = sorted({name for name in header if name and header.count(name) > 1})
    if repeated:
        raise DataError(path, f"line 1: column(s) {', '.join(repeated)} appear more than once in the header")
    missing = [name for name in required if name not in header]
    if missing:
        raise DataError(path, f"missing column(s) {', '.join(missing)}; found {', '.join(header)}")
    body = rows[1:]
    # Editors and hand-written files often end with empty lines; they hold no row.
    while body and not any(field.strip() for field in body[-1]):
        body.pop()
    for line_number, row in enumerate(body, start=2):
        if len(row) != len(header):
            raise DataError(path, f"line {line_number} has {len(row)} fields, the header has {len(header)}")
    table: dict[str, np.ndarray] = {}
    for position, name in enumerate(header):
        texts = [row[position].strip() for row in body]
        if others_as_text and name not in required and name not in integer:
            table[name] = np.array(texts, dtype=object)
            continue
        table[name] = _parse_column(path, name, texts, name in required, name in integer)
    return table


def _parse_column(path: Path, name: str, texts: list[str], required: bool, integer: bool) -> np.ndarray:
    try:
        values = np.array([float(text) for text in texts], dtype=float)
    except ValueError:
        if required or integer:
            bad = next(i for i, text in enumerate(texts) if not _is_number(text))
            raise DataError(path, f"line {bad + 2}: column {name} holds {texts[bad]!r}, not a number") from None
        return np.array(texts, dtype=object)
    if required and not np.all(np.isfinite(values)):
        bad = int(np.flatnonzero(~np.isfinite(values))[0])
        raise DataError(path, f"line {bad + 2}: column {name} holds {texts[bad]!r}, not a finite number")
    if integer:
        if not np.all(values == np.round(values)):
            bad = int(np.flatnonzero(values != np.round(values))[0])
            raise DataError(path, f"line {bad + 2}: column {name} holds {texts[bad]!r}, not a whole number")
        return values.astype(np.int64)
    return values


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True
