"""The Python API: the commands' stages as functions over tables (pandas DataFrames).

``seedtrack.detect`` finds objects in frames, ``seedtrack.link`` links them into tracks,
``seedtrack.evaluate`` scores tracks against the truth and ``seedtrack.render`` draws them over
the clip. Each takes the options of its command, by the same names with underscores
(``--max-speed`` is ``max_speed=``) and with the same defaults, and calls the same functions as
the command, so that both give the same answer. Tables hold the columns the command's CSV files
hold: frames 0-based, positions in pixels, x to the right and y down, pixel centres at integer
coordinates.

Errors: an option or a table that makes no sense is a ``ValueError`` (an unknown option a
``TypeError``); a file that cannot be read is a :class:`seedtrack.data.errors.DataError` naming it.
"""

from __future__ import annotations

import argparse
import contextlib
import itertools
import os
import re
import warnings
from pathlib import Path
from typing import Iterable, Iterator

import numpy as np
import pandas as pd

from seedtrack.data.csvio import TRACK_COLUMNS, read_table
from seedtrack.data.errors import DataError
from seedtrack.data.frames import read_mask
from seedtrack.data.trackfile import read_tracks
from seedtrack.detection.clip import ClipDetector, Detections, detect_frames, temporal_background
from seedtrack.detection.roi import Circle
from seedtrack.tracking.evaluation import Scores
from seedtrack.tracking.tracks import Tracks

from .commands import detect as detect_command
from .commands import evaluate as evaluate_command
from .commands import render as render_command
from .commands import track as track_command
from .errors import UsageError
from .pipeline import DetectionSettings, detect_clip
from .points import POINT_COLUMNS, group_points, point_rows

__all__ = ["detect", "link", "evaluate", "render", "Scores"]

PathLike = str | os.PathLike


def detect(source: PathLike | Iterable[np.ndarray], **options) -> pd.DataFrame:
    """Find objects in every frame, as ``seedtrack detect`` does.

    Parameters
    ----------
    source : path-like or iterable of ndarray
        A video file, image folder, glob pattern or TIFF stack; or frames, each an (H, W) grey
        or (H, W, 3) BGR array of uint8, uint16 or float (a list, or a generator: frames are
        read once, except with ``background="temporal"``, which keeps them in memory). A file
        is read at its own depth (:func:`seedtrack.data.frames.open_frames`), so it gives the
        detections of its frames as arrays.
    **options
        The options of ``seedtrack detect``: ``detector`` ("blob"), ``polarity`` ("auto",
        decided on the first frame), ``background`` ("local"), ``background_size`` (40 px),
        ``threshold`` ("otsu", "adaptive" or grey levels), ``min_area`` (4 px), ``max_area``
        (1% of the frame), ``roi`` ("auto", "none", (x, y, r) in pixels, or a mask image file),
        ``split`` (True), ``start`` (0), ``end`` (None: the end), ``step`` (1), ``diameter`` and
        ``min_mass`` (the spot detector's diameter, pixels, and least mass, integrated brightness
        in grey levels times pixels; None: set from the first frame).

    Returns
    -------
    DataFrame
        One row per object: ``frame`` (0-based index in the source), ``x``, ``y`` (pixels),
        ``area`` (pixels), ``mean_intensity`` (0-255), ``eccentricity`` (0 round, towards 1
        elongated); the columns of detections.csv.

    See Also
    --------
    link : link the detections into tracks.

    Examples
    --------
    >>> import seedtrack
    >>> from seedtrack.data.dish import DishSpec, make_dish_scene
    >>> scene = make_dish_scene(DishSpec(seeds=12, frames=3, width=240, height=180))
    >>> points = seedtrack.detect(scene.frames())
    >>> points.groupby("frame").size().tolist()
    [12, 12, 12]
    >>> list(points.columns)
    ['frame', 'x', 'y', 'area', 'mean_intensity', 'eccentricity']
    """
    options = dict(options)
    if "roi" in options:
        options["roi"] = _roi_text(options["roi"])
    args = _arguments(detect_command, ["INPUT", "--out", "detections.csv"], options, "detect", exclude=("preview", "preview_frame"))
    with _python_names():
        settings = detect_command.detection_settings(args)
    if isinstance(source, (str, os.PathLike)):
        detections = detect_clip(Path(source), settings, say=None).detections
    else:
        detections = _detect_arrays(source, settings)
    return pd.DataFrame(detections.to_rows())


def link(points: pd.DataFrame, **options) -> pd.DataFrame:
    """Link points into tracks, as ``seedtrack track`` does.

    Parameters
    ----------
    points : DataFrame
        Columns ``frame`` (0-based, whole numbers), ``x``, ``y`` (pixels), any others; row order
        does not matter. Frame numbers all N apart are consecutive measurements (speeds per N
        frames), as in the command.
    **options
        The options of ``seedtrack track``: ``algorithm`` ("goa-updown"), ``max_speed`` (None,
        pixels/frame), ``motion`` ("auto", "smooth" or "random"), ``phi_max`` (0.1),
        ``max_gap`` (10 frames), ``fixed_count`` (False), ``min_length`` (0 frames),
        ``individual_model``, ``combined_model``, ``min_speed``, ``first_links``.

    Returns
    -------
    DataFrame
        Columns ``track_id``, ``frame``, ``x``, ``y``, ``interpolated`` (1 for a position filled
        in for a missed point), then the input's other columns: on a measured row the values of
        the point it holds, on an interpolated row missing (NaN). Sorted by track, then frame.
        ``attrs["motion"]`` holds the line the command prints on how the points move (GOA
        trackers).

    See Also
    --------
    detect : points from frames.
    evaluate : score the tracks.

    Examples
    --------
    Three points moving right by 3 pixels a frame, the middle one missed in frame 3:

    >>> import pandas as pd, seedtrack
    >>> rows = [(k, 10.0 + 3 * k, y, area) for k in range(6) for y, area in ((10.0, 20), (50.0, 21), (90.0, 22))]
    >>> points = pd.DataFrame([row for row in rows if row[:3] != (3, 19.0, 50.0)], columns=["frame", "x", "y", "area"])
    >>> tracks = seedtrack.link(points, max_gap=2)
    >>> tracks.groupby("track_id")["area"].first().tolist()
    [20.0, 21.0, 22.0]
    >>> tracks[tracks.interpolated == 1][["frame", "x", "y"]].values.tolist()
    [[3.0, 19.0, 50.0]]
    """
    # The units only change the file the command writes; the table stays in pixels and frames.
    units = ("pixel_size", "space_unit", "frame_interval", "time_unit")
    args = _arguments(track_command, ["POINTS.csv", "--out", "tracks.csv"], options, "link", exclude=units)
    table = _columns(points, "points", ("frame", "x", "y"), integer=("frame",))
    said: list[str] = []
    with _python_names():
        track_command.check_options(args)
        grouped = group_points(table, "points")
        tracks = track_command.track_points(grouped, args, say=said.append)
    rows, source = point_rows(grouped, tracks)
    result = pd.DataFrame(rows)
    kept = points.drop(columns=[name for name in (*POINT_COLUMNS, *TRACK_COLUMNS) if name in points.columns])
    if len(kept.columns):
        # Row -1 is in no index: reindexing gives the missing values of an interpolated row.
        result = pd.concat([result, kept.reset_index(drop=True).reindex(source).reset_index(drop=True)], axis=1)
    result.attrs["motion"] = "\n".join(said)
    return result


def evaluate(tracks: pd.DataFrame | PathLike | Tracks, truth: pd.DataFrame | PathLike | Tracks, tol: float = 3.0) -> Scores:
    """Score tracks against ground truth, as ``seedtrack evaluate`` does.

    Parameters
    ----------
    tracks, truth : DataFrame, path-like or Tracks
        Tables with columns ``track_id`` (or trackpy's ``particle``), ``frame``, ``x``, ``y`` and
        optionally ``interpolated``; or files in any format the command reads (our csv, trackpy
        csv, MOT txt, TrackMate or ISBI xml).
    tol : float
        Matching distance, pixels (the command's ``--tol``).

    Returns
    -------
    Scores
        The measures the command prints (paper's track error, relaxed merit, link error;
        CLEAR-MOT and IDF1). A hint that the truth's frames look numbered one off is given as
        a warning.

    Examples
    --------
    >>> import pandas as pd, seedtrack
    >>> truth = pd.DataFrame({"track_id": [1, 1, 1, 2, 2, 2], "frame": [0, 1, 2, 0, 1, 2],
    ...                       "x": [0.0, 2.0, 4.0, 0.0, 2.0, 4.0], "y": [0.0, 0.0, 0.0, 9.0, 9.0, 9.0]})
    >>> swapped = truth.assign(track_id=[1, 1, 2, 2, 2, 1])
    >>> scores = seedtrack.evaluate(swapped, truth)
    >>> scores.correct_tracks, scores.id_switches
    (0, 2)
    """
    with _python_names():
        evaluate_command.check_tolerance(tol)
        result, result_name = _tracks(tracks, "tracks")
        true, truth_name = _tracks(truth, "truth")
        scores, _, _, hint = evaluate_command.assess(result, true, tol, truth_name)
    if hint is not None:
        warnings.warn(hint, stacklevel=2)
    return scores


def render(source: PathLike, tracks: pd.DataFrame | PathLike | Tracks, out: PathLike | None, **options) -> str:
    """Draw tracks over a clip, as ``seedtrack render`` does.

    Parameters
    ----------
    source : path-like
        The video file, image folder, glob pattern or TIFF stack the tracks were made from.
    tracks : DataFrame, path-like or Tracks
        As :func:`evaluate` takes them.
    out : path-like or None
        ``.mp4``, ``.gif``, ``.png`` (one frame, see ``frame``) or a folder (one PNG per frame);
        None with ``summary`` only.
    **options
        The options of ``seedtrack render``: ``start`` (0), ``end`` (None), ``step`` (1),
        ``frame`` (a .png's frame; default the tracks' last), ``trail`` (10 positions),
        ``labels`` (True), ``scale`` (1), ``crop`` ("x0,y0,x1,y1"), ``fps`` (the clip's),
        ``summary`` (a PNG of every whole trajectory), ``detections`` (a table or detections.csv:
        those no track holds are crossed out), ``format`` (of a tracks file), ``pixel_size``
        and ``space_unit`` (a scale bar; a calibrated TIFF gives one by itself).

    Returns
    -------
    str
        The line the command prints: what was written.

    Examples
    --------
    >>> import seedtrack, tempfile, pathlib
    >>> from seedtrack.data.dish import DishSpec, write_dish_clip
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> scene = write_dish_clip(DishSpec(seeds=12, frames=4, width=240, height=180), folder)
    >>> tracks = seedtrack.link(seedtrack.detect(folder / "clip.mp4"))
    >>> print(seedtrack.render(folder / "clip.mp4", tracks, folder / "last.png"))  # doctest: +ELLIPSIS
    wrote .../last.png: 1 frame of 12 tracks, 240x180
    """
    options = dict(options)
    if options.get("summary") is not None:
        options["summary"] = Path(options["summary"])
    detections = options.pop("detections", None)
    args = _arguments(render_command, ["INPUT", "TRACKS"], options, "render", exclude=("out",))
    args.input = Path(source)
    args.out = None if out is None else str(out)
    with _python_names():
        kind = render_command.check_view_options(args)
        drawn, args.tracks = _tracks(tracks, "tracks")
        rows = None
        if detections is not None:
            if isinstance(detections, (str, os.PathLike)):
                rows = read_table(detections, required=("frame", "x", "y"))
            else:
                rows = _columns(detections, "detections", ("frame", "x", "y"), integer=("frame",))
        return render_command.draw(args, kind, drawn, rows)


def _arguments(command, placeholders: list[str], options: dict, caller: str, exclude: tuple[str, ...] = ()) -> argparse.Namespace:
    """The command's arguments with its defaults, as its own parser makes them, updated with
    ``options``; the placeholders fill its required arguments, which are not options here.

    Raises
    ------
    TypeError
        If an option is not one of the command's.
    """
    parser = argparse.ArgumentParser(prog="seedtrack")
    subparsers = parser.add_subparsers()
    command.add_parser(subparsers)
    (sub,) = subparsers.choices.values()
    args = sub.parse_args(placeholders)
    fixed = {action.dest for action in sub._actions if action.required or not action.option_strings}
    allowed = sorted(set(vars(args)) - fixed - {"run", *exclude})
    unknown = sorted(set(options) - set(allowed))
    if unknown:
        raise TypeError(f"{caller}() got unexpected keyword argument(s) {', '.join(unknown)}; its options are {', '.join(allowed)}")
    for name, value in options.items():
        setattr(args, name, value)
    return args


@contextlib.contextmanager
def _python_names() -> Iterator[None]:
    """Report a command's usage error as a ValueError naming keywords (``--max-speed`` is
    ``max_speed``), and a problem of a table given in memory (not a file) as a ValueError."""
    try:
        yield
    except UsageError as error:
        raise ValueError(re.sub(r"--(?:no-)?([a-z][a-z-]*)", lambda m: m.group(1).replace("-", "_"), str(error))) from None
    except DataError as error:
        if isinstance(error.path, Path):
            raise
        raise ValueError(str(error)) from None


def _roi_text(roi) -> str:
    """The ``--roi`` text of a region given as a circle, a tuple (x, y, r) or a path."""
    if isinstance(roi, Circle):
        roi = (roi.x, roi.y, roi.r)
    if isinstance(roi, (tuple, list)) and len(roi) == 3:
        return ",".join(repr(float(v)) for v in roi)
    return str(roi) if isinstance(roi, os.PathLike) else roi


# Frame data the detectors take: 8 or 16 bits, or float (their range read from the first frame).
_FRAME_TYPES = (np.dtype(np.uint8), np.dtype(np.uint16), np.dtype(np.float32), np.dtype(np.float64))


def _detect_arrays(source: Iterable[np.ndarray], settings: DetectionSettings) -> Detections:
    """:func:`seedtrack.pipeline.detect_clip` on frames in memory."""
    selected = itertools.islice(enumerate(source), settings.start, settings.end, settings.step)
    shape: list[tuple[int, ...]] = []

    def checked_frames() -> Iterator[tuple[int, np.ndarray]]:
        for index, image in selected:
            image = np.asarray(image)
            if image.dtype not in _FRAME_TYPES or not (image.ndim == 2 or (image.ndim == 3 and image.shape[2] == 3)):
                raise ValueError(
                    f"frame {index} must be an (H, W) or (H, W, 3) array of uint8, uint16 or float, got {image.dtype} of shape {image.shape}"
                )
            if shape and image.shape[:2] != shape[0]:
                raise ValueError(f"frame {index} is {image.shape[1]}x{image.shape[0]}, the first {shape[0][1]}x{shape[0][0]}")
            shape[:] = [image.shape[:2]]
            yield index, image

    checked = checked_frames()
    first = next(checked, None)
    if first is None:
        raise ValueError("no frame to detect in (after start, end and step)")
    frames = itertools.chain([first], checked)
    background = None
    if settings.options.background == "temporal":
        frames = list(frames)
        background = temporal_background([image for _, image in frames])
    roi = settings.roi
    if isinstance(roi, Path):
        roi = read_mask(roi, (first[1].shape[1], first[1].shape[0]))
    return detect_frames(frames, ClipDetector(settings.options, settings.detector, roi, background, settings.diameter, settings.min_mass))


def _columns(table: pd.DataFrame, name: str, required: tuple[str, ...], integer: tuple[str, ...]) -> dict[str, np.ndarray]:
    """The required columns of a table as finite numbers (whole numbers where ``integer``)."""
    if not isinstance(table, pd.DataFrame):
        raise ValueError(f"{name} must be a pandas DataFrame, got {type(table).__name__}")
    missing = [column for column in required if column not in table.columns]
    if missing:
        raise ValueError(f"{name}: missing column(s) {', '.join(missing)}; found {', '.join(map(str, table.columns))}")
    out = {}
    for column in required:
        values = pd.to_numeric(table[column], errors="coerce").to_numpy(dtype=float)
        bad = np.flatnonzero(~np.isfinite(values) | ((values != np.round(values)) if column in integer else False))
        if bad.size:
            kind = "a whole number" if column in integer else "a finite number"
            value = table[column].iloc[bad[0]]
            value = value.item() if isinstance(value, np.generic) else value
            raise ValueError(f"{name}: row {bad[0]}: column {column} holds {value!r}, not {kind}")
        out[column] = values.astype(np.int64) if column in integer else values
    return out


def _tracks(tracks: pd.DataFrame | PathLike | Tracks, name: str) -> tuple[Tracks, object]:
    """A track set and what to call it in errors: a file read, a table converted, or as given."""
    if isinstance(tracks, Tracks):
        return tracks, name
    if isinstance(tracks, (str, os.PathLike)):
        return read_tracks(tracks), Path(tracks)
    if isinstance(tracks, pd.DataFrame) and "track_id" not in tracks.columns and "particle" in tracks.columns:
        tracks = tracks.rename(columns={"particle": "track_id"})
    columns = _columns(tracks, name, ("track_id", "frame", "x", "y"), integer=("track_id", "frame"))
    interpolated = tracks["interpolated"].to_numpy() if "interpolated" in tracks.columns else None
    try:
        return Tracks.from_rows(columns["track_id"], columns["frame"], columns["x"], columns["y"], interpolated), name
    except ValueError as error:
        raise ValueError(f"{name}: {error}") from None
