"""CSV tables: a header row, then one row per record; columns are 1-D numpy arrays.

The file formats are a contract with users and other tools: ``frame`` is a 0-based frame
index, ``x`` runs to the right and ``y`` down, in pixels, with pixel centres at integer
coordinates.
"""

from __future__ import annotations

import csv
import itertools
import os
import re
import warnings
from functools import partial
from pathlib import Path
from typing import Callable, Iterator

import numpy as np

from .atomic import atomic_path
from .errors import DataError, check_file, warn
from .formats import CSV_FORMATS, EXTENSIONS, described
from .formats.trackmate import check_pixels
from .numbers import check_range
from .outputset import check_member

DETECTION_COLUMNS = ("frame", "x", "y", "area")
TRACK_COLUMNS = ("track_id", "frame", "x", "y", "interpolated")

# Enough digits that a position survives a round trip to well below a thousandth of a pixel,
# few enough that files stay readable; fixed so that the same input gives the same bytes.
_FLOAT_FORMAT = "%.4f"
# Written NaNs, which are numbers (refused where a finite one is needed), not text.
NAN_WORDS = ("nan", "+nan", "-nan", "")
# Rows formatted at a time when writing.
_WRITE_ROWS = 65536


def write_table(path: str | os.PathLike, columns: dict[str, np.ndarray], float_format: str = _FLOAT_FORMAT) -> None:
    """Write columns of equal length as CSV with a header, atomically.

    Parameters
    ----------
    path : path-like
        Output file; replaced only once the whole table is written.
    columns : dict of str to ndarray
        Column name to 1-D array; integer and boolean columns are written as integers, float
        columns with four decimals (NaN as an empty field), text (object or string) columns as
        they are.
    float_format : str
        printf-style format of float columns, for tables in units where four decimals are too
        few (``"%.8g"``: significant digits).

    Example
    -------
    >>> import tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "points.csv"
    >>> write_table(out, {"frame": np.array([0, 1]), "x": np.array([1.5, 2.25]), "y": np.array([3.0, np.nan])})
    >>> out.read_text()
    'frame,x,y\\n0,1.5000,3.0000\\n1,2.2500,\\n'
    """
    lengths = {len(values) for values in columns.values()}
    if len(lengths) > 1:
        raise ValueError(f"columns differ in length: {sorted(lengths)}")
    check_table_name(path)
    columns = {name: np.asarray(values) for name, values in columns.items()}
    rows = lengths.pop() if lengths else 0
    # Imported when a table is written or read, not with this module: `seedtrack run` loads it
    # beside detection (see seedtrack.pipeline.run_pipeline).
    import pandas as pd

    with atomic_path(path) as temporary, open(temporary, "w", encoding="utf-8", newline="") as out:
        # A block of rows at a time: a table of all of them is a copy of every column, on a
        # million rows 40 MB of the peak of seedtrack track. Each row's text does not depend on
        # the others, so the bytes are the same.
        for start in range(0, max(rows, 1), _WRITE_ROWS):
            block = pd.DataFrame({name: _for_writing(values[start : start + _WRITE_ROWS]) for name, values in columns.items()})
            block.to_csv(out, header=start == 0, index=False, float_format=float_format, na_rep="", lineterminator="\n")


def check_table_name(path: str | os.PathLike) -> Path:
    """Refuse a CSV table named with an extension that :data:`~seedtrack.data.formats.EXTENSIONS`
    gives to another format (``points.txt`` would be MOTChallenge text to every other command).

    Raises
    ------
    DataError
        Naming the extension and what it means.
    """
    path = Path(path)
    names = EXTENSIONS.get(path.suffix.lower())
    if names is not None and not set(names) & set(CSV_FORMATS):
        raise DataError(path, f"{path.suffix} names {' or '.join(names)} files, not a CSV table; name it .csv (extensions: {described()})")
    return path


def _for_writing(values: np.ndarray) -> np.ndarray:
    if values.dtype == bool:
        return values.astype(np.int64)
    if values.dtype.kind in "OUS" or np.issubdtype(values.dtype, np.integer):
        return values
    return values.astype(float)


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
    label_rows: int = 0,
) -> dict[str, np.ndarray]:
    """Read a CSV table with a header row into numeric columns (through pandas' C parser).

    Parameters
    ----------
    path : path-like
        The CSV file (UTF-8; blank lines hold no row).
    required : tuple of str
        Columns that must be present; their values must be finite numbers.
    integer : tuple of str
        Columns parsed as integers where present; every other column is parsed as float when
        all its values are numbers, and kept as text otherwise.
    others_as_text : bool
        Keep every column that is neither required nor integer as text, exactly as written,
        so that it can be copied to another file unchanged.
    label_rows : int
        Lines after the header that hold no data (TrackMate's names, short names and units).

    Returns
    -------
    dict of str to ndarray
        One array per column, in file order, without a first column of no name (the row index
        pandas writes by default). Columns with a range in
        :data:`seedtrack.data.numbers.RANGES` (frame, x, y, ...) have been checked against it.

    Raises
    ------
    DataError
        If the file is missing, empty, repeats a column name, lacks a required column, has a
        row with more fields than the header, or holds text, NaN, infinity or a value out of
        range in a required or integer column (naming the line).

    Example
    -------
    >>> import tempfile, pathlib
    >>> points = pathlib.Path(tempfile.mkdtemp()) / "points.csv"
    >>> _ = points.write_text("frame,x,y\\n0,1.5,2\\n1,2.5,2\\n")
    >>> read_table(points, required=("frame", "x", "y"))["x"]
    array([1.5, 2.5])
    """
    path = check_table_name(path)
    check_file(path)
    header = _header(path)
    repeated = sorted({name for name in header if name and header.count(name) > 1})
    if repeated:
        raise DataError(path, f"line 1: column(s) {', '.join(repeated)} appear more than once in the header")
    missing = [name for name in required if name not in header]
    if missing:
        # Excel in many languages saves "CSV" with semicolons, the comma being the decimal mark;
        # spreadsheets and ImageJ's Results export tabs (.tsv, .xls saved as text).
        separator = ""
        if len(header) == 1:
            for mark, name in ((";", "semicolons"), ("\t", "tabs")):
                if mark in header[0]:
                    separator = f"; its fields are separated by {name}: save it with commas"
                    header = header[0].split(mark)
                    break
        raise DataError(path, f"missing column(s) {', '.join(missing)}; found {', '.join(header)}{separator}")
    text = [name for name in header if others_as_text and name not in required and name not in integer]
    import pandas as pd

    try:
        with warnings.catch_warnings():
            # pandas drops the fields of a row longer than the header, with a warning only.
            warnings.simplefilter("error", pd.errors.ParserWarning)
            frame = pd.read_csv(
                path,
                header=0,
                names=header,
                skiprows=range(1, 1 + label_rows),
                index_col=False,
                encoding="utf-8-sig",
                dtype={name: str for name in text},
                keep_default_na=False,
                na_values={name: [""] for name in header if name not in text},
                skipinitialspace=True,
            )
    except UnicodeDecodeError as error:
        raise DataError.not_utf8(path, error) from None
    except pd.errors.ParserError as error:
        raise DataError(path, _parser_problem(error, len(header))) from None
    except pd.errors.ParserWarning:
        raise DataError(path, f"a row has more fields than the header's {len(header)}; its last fields would be lost") from None
    table: dict[str, np.ndarray] = {}
    for position, name in enumerate(header):
        if position == 0 and not name:
            # pandas' to_csv writes the row index first, under an empty name (trackpy's and
            # laptrack's tables saved as their users save them): no column of the table.
            continue
        values = frame[name]
        if name in text:
            table[name] = values.to_numpy(dtype=object)
            continue
        table[name] = _numeric_column(path, name, values, name in required, name in integer, partial(data_lines, path, label_rows=label_rows))
    return table


def _header(path: Path) -> list[str]:
    lines = text_lines(path)
    first = next((line for _, line in lines if line.strip()), None)
    lines.close()
    if first is None:
        raise DataError(path, "the file is empty (expected a header row)")
    return [name.strip() for name in next(csv.reader([first]))]


def _parser_problem(error: Exception, fields: int) -> str:
    # pandas says "Expected 3 fields in line 5, saw 4"; the line is the file's.
    found = re.search(r"Expected (\d+) fields in line (\d+), saw (\d+)", str(error))
    if found:
        return f"line {found.group(2)} has {found.group(3)} fields, the header has {fields}"
    return f"not a readable CSV table ({' '.join(str(error).split())})"


def _numeric_column(path: Path, name: str, values: "pd.Series", required: bool, integer: bool, lines: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    import pandas as pd

    numbers = pd.to_numeric(values, errors="coerce").to_numpy(dtype=float)
    unparsed = _text(values)
    if unparsed.any() and not (required or integer):
        return values.astype(object).where(values.notna(), "").to_numpy(dtype=object)
    if (required or integer) and not np.all(np.isfinite(numbers)):
        bad = int(np.flatnonzero(~np.isfinite(numbers))[0])
        written = _as_written(values, bad)
        problem = "is empty" if not written.strip() else f"holds {written!r}, " + ("not a number" if unparsed[bad] else "not a finite number")
        raise DataError(path, f"line {lines(bad)}: column {name} {problem}")
    if integer:
        whole = numbers == np.round(numbers)
        if not whole.all():
            bad = int(np.flatnonzero(~whole)[0])
            raise DataError(path, f"line {lines(bad)}: column {name} holds {_as_written(values, bad)!r}, not a whole number")
    check_range(path, name, numbers, lines)
    return numbers.astype(np.int64) if integer else numbers


def _text(values: "pd.Series") -> np.ndarray:
    """Where a field holds text that is no number: an empty field (NaN) and "nan", "inf" as
    written are numbers here, so that a numeric column with blanks stays numeric."""
    if values.dtype.kind in "iuf":
        return np.zeros(len(values), bool)
    import pandas as pd

    written = values.astype(object).where(values.notna(), "").astype(str).str.strip()
    return (pd.to_numeric(written.where(written != "", "nan"), errors="coerce").isna() & ~written.str.lower().isin(NAN_WORDS)).to_numpy()


def _as_written(values: "pd.Series", row: int) -> str:
    value = values.iloc[row]
    return "" if value is None or (isinstance(value, float) and np.isnan(value)) else str(value)


def data_lines(path: Path, rows: np.ndarray | None = None, label_rows: int = 0) -> np.ndarray:
    """The 1-based line of each data row of a CSV file (or of the rows given by position): every
    line after the header (and its ``label_rows``) that is not blank, as pandas reads it. For
    error messages only: it reads the file again."""
    lines = np.array([number for number, line in text_lines(path) if line.strip()][1 + label_rows :], dtype=np.int64)
    return lines if rows is None else lines[rows]


def read_points(path: str | os.PathLike, others_as_text: bool = False) -> dict[str, np.ndarray]:
    """Read a table of measured points (columns frame, x, y and any others), each point once.

    A TrackMate spot table (its CSV export, or the spots table saved from its window: columns
    ``FRAME``, ``POSITION_X``, ``POSITION_Y`` and others, maybe with TrackMate's three rows of
    names, short names and units under the header) is read as ``frame``, ``x``, ``y``, its other
    columns kept; positions in another unit than pixels are refused.

    A row that repeats an earlier row's frame, x and y is the same measurement twice (a file
    joined with itself, a detection written twice): it is dropped, with a warning naming the
    first such line, so that no tracker sees two objects in one place.

    Parameters
    ----------
    path : path-like
    others_as_text : bool
        As in :func:`read_table`.

    Returns
    -------
    dict of str to ndarray
        The columns, in file order, without the repeated rows.

    Raises
    ------
    DataError
        As :func:`read_table`, for a missing column or a value that is not a number in range.

    Example
    -------
    >>> import tempfile, pathlib, warnings
    >>> points = pathlib.Path(tempfile.mkdtemp()) / "points.csv"
    >>> _ = points.write_text("frame,x,y\\n0,1,2\\n0,1,2\\n1,2,2\\n")
    >>> with warnings.catch_warnings(record=True):
    ...     read_points(points)["x"]
    array([1., 2.])
    """
    path = Path(path)
    # First: a set left half in place by a killed run is finished before its file is read.
    check_member(path)
    names, label_rows = _point_columns(path)
    table = read_table(path, required=tuple(names), integer=tuple(names)[:1], others_as_text=others_as_text, label_rows=label_rows)
    if label_rows or tuple(names) != ("frame", "x", "y"):
        table = {names.get(name, name): values for name, values in table.items()}
        for name in ("frame", "x", "y"):
            check_range(path, name, table[name], partial(data_lines, path, label_rows=label_rows))
    frame, x, y = table["frame"], table["x"], table["y"]
    order = np.lexsort((np.arange(frame.size), y, x, frame))
    same = (np.diff(frame[order]) == 0) & (np.diff(x[order]) == 0) & (np.diff(y[order]) == 0)
    if not same.any():
        return table
    # Equal rows sit together in that order, earliest first: it is kept, the others repeat it.
    starts = np.concatenate(([True], ~same))
    earliest = order[starts][np.cumsum(starts) - 1]
    repeats = order[~starts]
    first = int(np.argmin(repeats))
    earlier, first = int(earliest[~starts][first]), int(repeats[first])
    lines = data_lines(path, np.array([earlier, first]), label_rows)
    warn(path, f"{repeats.size} row(s) repeat an earlier row's frame, x and y (first line {lines[1]}, as line {lines[0]}); each point is read once")
    keep = np.ones(frame.size, bool)
    keep[repeats] = False
    return {name: values[keep] for name, values in table.items()}


# TrackMate's spot features that are our point columns: both count frames from 0, and TrackMate's
# pixel coordinates put pixel centres at integers, as ours do.
TRACKMATE_POINT_COLUMNS = {"FRAME": "frame", "POSITION_X": "x", "POSITION_Y": "y"}


def _point_columns(path: Path) -> tuple[dict[str, str], int]:
    """The columns of ``path`` that are frame, x and y (file name to ours), and how many rows
    under the header hold no data."""
    check_table_name(path)
    check_file(path)
    header = _header(path)
    if {"frame", "x", "y"} <= set(header) or not set(TRACKMATE_POINT_COLUMNS) <= set(header):
        return {"frame": "frame", "x": "x", "y": "y"}, 0
    lines = text_lines(path)
    rows = [line for _, line in itertools.islice((item for item in lines if item[1].strip()), 1, 4)]
    lines.close()
    frame_at, x_at = header.index("FRAME"), header.index("POSITION_X")
    fields = [next(csv.reader([line])) for line in rows]
    # TrackMate 7 writes under the keys the features' names, short names and units; only those
    # three rows are skipped, so that a data row is never taken for one.
    label_rows = 3 if len(fields) == 3 and len(fields[0]) > frame_at and fields[0][frame_at].strip() == "Frame" else 0
    if label_rows and len(fields[2]) > x_at:
        check_pixels(path, 4, fields[2][x_at].strip().strip("()"))
    return dict(TRACKMATE_POINT_COLUMNS), label_rows
