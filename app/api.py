"""The Python API: the commands' stages as functions over tables (pandas DataFrames).

``seedtrack.detect`` finds objects in frames, ``seedtrack.link`` links them into tracks,
``seedtrack.evaluate`` scores tracks against the truth and ``seedtrack.render`` draws them over
the clip. Each takes the options of its command as keywords, by the same names with underscores
(``--max-speed`` is ``max_speed=``) and with the same defaults; they make the stage's settings
(:mod:`seedtrack.settings`, :class:`seedtrack.pipeline.DetectSettings`) and call the library
functions the command calls, so that both give the same answer. Tables hold the columns the
command's CSV files hold: frames 0-based, positions in pixels, x to the right and y down, pixel
centres at integer coordinates.

Errors: an option or a table that makes no sense is a ``ValueError`` (an option's an
:class:`seedtrack.errors.OptionError` naming it); a file that cannot be read is a
:class:`seedtrack.data.errors.DataError` naming it.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import warnings
from pathlib import Path
from typing import Iterable, Iterator

import numpy as np
import pandas as pd

from seedtrack.data.csvio import read_table
from seedtrack.data.errors import DataError
from seedtrack.data.trackfile import read_tracks
from seedtrack.tracking.evaluation import Scores
from seedtrack.tracking.tracks import Tracks

from .pipeline import DetectSettings, detect_clip
from .points import POINT_COLUMNS, group_points, link_points, track_rows
from .rendering import draw, output_checked
from .scoring import DEFAULT_TOLERANCE, assess
from .settings import EvaluateSettings, LinkSettings, RenderSettings

__all__ = ["detect", "link", "evaluate", "render", "Scores"]

PathLike = str | os.PathLike
_DETECT = DetectSettings()
_LINK = LinkSettings()
_RENDER = RenderSettings()


def detect(
    source: PathLike | Iterable[np.ndarray],
    *,
    detector: str = _DETECT.detector,
    diameter: int | None = _DETECT.diameter,
    min_mass: float | None = _DETECT.min_mass,
    snr: float | None = _DETECT.snr,
    polarity: str = _DETECT.polarity,
    background: str = _DETECT.background,
    background_size: float = _DETECT.background_size,
    threshold: str | float = _DETECT.threshold,
    min_area: float = _DETECT.min_area,
    max_area: float | None = _DETECT.max_area,
    roi=_DETECT.roi,
    split: bool = _DETECT.split,
    start: int = _DETECT.start,
    end: int | None = _DETECT.end,
    step: int = _DETECT.step,
) -> pd.DataFrame:
    """Find objects in every frame, as ``seedtrack detect`` does.

    Parameters
    ----------
    source : path-like or iterable of ndarray
        A video file, image folder, glob pattern or TIFF stack; or frames, each an (H, W) grey
        or (H, W, 3) BGR array of uint8, uint16 or float (a list, or a generator: frames are
        read once, except with ``background="temporal"``, which keeps them in memory). A file
        is read at its own depth (:func:`seedtrack.data.frames.open_frames`), so it gives the
        detections of its frames as arrays.
    detector : {"auto", "blob", "spot"}
        Threshold blobs (seeds: dark, elongated, touching), Crocker-Grier spots (beads: small,
        round, faint), or the one that suits the first frame.
    diameter : int, optional
        The spot detector's diameter, pixels, odd (default: measured on the first frame).
    min_mass : float, optional
        The spot detector's least mass, integrated brightness in grey levels times pixels
        (default: set from the first frame's noise).
    snr : float, optional
        The spot detector's least mass as a multiple of the typical mass of the background's own
        maxima (default: where the first frame's masses show objects apart from the background,
        else from the noise; ``min_mass`` wins).
    polarity : {"auto", "dark", "light"}
        Objects darker or lighter than the background ("auto": decided on the first frame).
    background : {"local", "none", "temporal"}
        What contrast is measured against: a median over ``background_size`` windows, the
        frame's median grey, or the per-pixel median over the clip.
    background_size : float
        Window of the local background, pixels.
    threshold : "otsu", "adaptive" or float
        Object pixels: Otsu's level, local mean + 3 local standard deviations, or a contrast of
        at least this many grey levels.
    min_area, max_area : float
        Smallest and largest object, pixels (max_area None: 1% of the frame).
    roi : "auto", "none", (x, y, r) or path-like
        Where to look: the dish if the first frame shows one, everywhere, a circle in pixels,
        or a mask image of the frames' size (nonzero inside).
    split : bool
        Split blobs of touching objects.
    start, end, step : int
        0-based frames processed: ``range(start, end, step)`` (end None: the end).

    Returns
    -------
    DataFrame
        One row per object: ``frame`` (0-based index in the source), ``x``, ``y`` (pixels),
        ``area`` (pixels), ``mean_intensity`` (0-255), ``eccentricity`` (0 round, towards 1
        elongated), ``ep`` (the centre's localisation error, pixels per axis); the columns of
        detections.csv.

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
    ['frame', 'x', 'y', 'area', 'mean_intensity', 'eccentricity', 'ep']
    """
    settings = _settings(DetectSettings, locals())
    return pd.DataFrame(detect_clip(source, settings, say=None).detections.to_rows())


def link(
    points: pd.DataFrame,
    *,
    algorithm: str = _LINK.algorithm,
    max_speed: float | None = _LINK.max_speed,
    motion: str = _LINK.motion,
    phi_max: float = _LINK.phi_max,
    max_gap: int | None = _LINK.max_gap,
    fixed_count: bool = _LINK.fixed_count,
    min_length: int = _LINK.min_length,
    individual_model: str | None = _LINK.individual_model,
    combined_model: str | None = _LINK.combined_model,
    min_speed: float | None = _LINK.min_speed,
    first_links: str | PathLike | None = _LINK.first_links,
) -> pd.DataFrame:
    """Link points into tracks, as ``seedtrack track`` does.

    Parameters
    ----------
    points : DataFrame
        Columns ``frame`` (0-based, whole numbers), ``x``, ``y`` (pixels), any others; row order
        does not matter. Frame numbers all N apart are consecutive measurements (speeds per N
        frames), as in the command. An ``ep`` column (each point's localisation error, pixels
        per axis, as :func:`detect` and trackpy give it) floors the measured motion's noise at
        sqrt(6) times its median.
    algorithm : str
        "goa-updown" (tracks open and end anywhere), "goa-updown-fixed" (the paper's fixed count
        of tracks), "goa" (one forward pass), or a comparison tracker "nn", "ss", "rs", "ipan".
    max_speed : float, optional
        Largest speed, pixels/frame (default: twice the fastest measured on a first pass).
    motion : {"auto", "smooth", "random"}
        Measure how the points move on a first pass, or say it.
    phi_max : float
        Largest smoothness cost of a link (0..1.1), also the cost of a missed point.
    max_gap : int, optional
        A track ends after this many missed frames in a row (default 10); gaps up to it are
        filled by interpolation.
    fixed_count : bool
        GOA-updown as published: one track per point of the first frame.
    min_length : int
        Keep only tracks spanning at least this many frames, gaps included.
    individual_model, combined_model : str, optional
        "im1", "im2", "im3"; "cm1", "cm2" (default: fitted to the motion; cm1).
    min_speed : float, optional
        Smallest speed, pixels/frame.
    first_links : str or path-like, optional
        How tracks start: "lookahead" (default), "nearest", "paper", or (algorithm "goa") a
        tracks file giving the first two frames' links.

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
    settings = _settings(LinkSettings, locals())
    table = _columns(points, "points", POINT_COLUMNS, integer=("frame",))
    table.update({name: points[name].to_numpy() for name in points.columns if name not in table})
    said: list[str] = []
    with _in_memory_errors():
        grouped = group_points(table, "points")
        tracks = link_points(grouped, settings, say=said.append)
    result = pd.DataFrame(track_rows(grouped, tracks, blank=None))
    result.attrs["motion"] = "\n".join(said)
    return result


def evaluate(
    tracks: pd.DataFrame | PathLike | Tracks,
    truth: pd.DataFrame | PathLike | Tracks,
    *,
    tol: float = DEFAULT_TOLERANCE,
    format: str | None = None,
    truth_format: str | None = None,
) -> Scores:
    """Score tracks against ground truth, as ``seedtrack evaluate`` does.

    Parameters
    ----------
    tracks, truth : DataFrame, path-like or Tracks
        Tables with columns ``track_id`` (or trackpy's ``particle``), ``frame``, ``x``, ``y`` and
        optionally ``interpolated``; or files in any format the command reads (our csv, trackpy
        csv, MOT txt, TrackMate or ISBI xml).
    tol : float
        Matching distance, pixels.
    format, truth_format : str, optional
        Formats of the files (csv, trackpy, mot, trackmate, isbi; default: from the extension
        and contents).

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
    settings = _settings(EvaluateSettings, locals())
    with _in_memory_errors():
        result, _ = _tracks(tracks, "tracks", settings.format)
        true, truth_name = _tracks(truth, "truth", settings.truth_format)
        scores, _, _, hint = assess(result, true, settings.tol, truth_name)
    if hint is not None:
        warnings.warn(hint, stacklevel=2)
    return scores


def render(
    source: PathLike,
    tracks: pd.DataFrame | PathLike | Tracks,
    out: PathLike | None = None,
    *,
    start: int = _RENDER.start,
    end: int | None = _RENDER.end,
    step: int = _RENDER.step,
    frame: int | None = _RENDER.frame,
    trail: int = _RENDER.trail,
    labels: bool = _RENDER.labels,
    scale: float = _RENDER.scale,
    crop: str | None = _RENDER.crop,
    fps: float | None = _RENDER.fps,
    summary: PathLike | None = None,
    detections: pd.DataFrame | PathLike | None = None,
    format: str | None = None,
) -> str:
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
    start, end, step : int
        0-based frames drawn: ``range(start, end, step)`` (end None: the end of the clip).
    frame : int, optional
        The frame a .png shows (default: the tracks' last).
    trail : int
        Past positions in each fading trail.
    labels : bool
        Write each track's id beside it.
    scale : float
        Enlarge (or shrink, below 1) the frames.
    crop : str, optional
        "x0,y0,x1,y1": draw only this box of the frame, pixels (x1, y1 exclusive).
    fps : float, optional
        Frames per second of the output (default: the clip's).
    summary : path-like, optional
        Also draw every whole trajectory over the first frame into this PNG.
    detections : DataFrame or path-like, optional
        A table or detections.csv (frame, x, y): those no track holds are crossed out.
    format : str, optional
        Format of a tracks file (default: from the extension and contents).

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
    settings = _settings(RenderSettings, locals())
    with _in_memory_errors():
        kind = output_checked(None if out is None else str(out), settings, None if summary is None else Path(summary))
        drawn, name = _tracks(tracks, "tracks", format)
        rows, rows_name = None, "detections"
        if isinstance(detections, (str, os.PathLike)):
            rows, rows_name = read_table(detections, required=("frame", "x", "y")), Path(detections)
        elif detections is not None:
            rows = _columns(detections, "detections", ("frame", "x", "y"), integer=("frame",))
        return draw(Path(source), drawn, name, None if out is None else str(out), kind, settings, None if summary is None else Path(summary), rows, rows_name)


def _settings(kind: type, given: dict):
    """``kind``, a settings dataclass, made of a function's keywords (its ``locals()`` on entry:
    the inputs, which it does not hold, are left out)."""
    return kind(**{f.name: given[f.name] for f in dataclasses.fields(kind) if f.init})


@contextlib.contextmanager
def _in_memory_errors() -> Iterator[None]:
    """Report a problem of a table given in memory (not a file) as a ValueError."""
    try:
        yield
    except DataError as error:
        if isinstance(error.path, Path):
            raise
        raise ValueError(str(error)) from None


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


def _tracks(tracks: pd.DataFrame | PathLike | Tracks, name: str, format: str | None = None) -> tuple[Tracks, object]:
    """A track set and what to call it in errors: a file read (in ``format``, if given), a table
    converted, or as given."""
    if isinstance(tracks, Tracks):
        return tracks, name
    if isinstance(tracks, (str, os.PathLike)):
        return read_tracks(tracks, format), Path(tracks)
    if isinstance(tracks, pd.DataFrame) and "track_id" not in tracks.columns and "particle" in tracks.columns:
        tracks = tracks.rename(columns={"particle": "track_id"})
    columns = _columns(tracks, name, ("track_id", "frame", "x", "y"), integer=("track_id", "frame"))
    interpolated = tracks["interpolated"].to_numpy() if "interpolated" in tracks.columns else None
    try:
        return Tracks.from_rows(columns["track_id"], columns["frame"], columns["x"], columns["y"], interpolated), name
    except ValueError as error:
        raise ValueError(f"{name}: {error}") from None
