"""Points grouped by frame and tracked, as ``seedtrack track`` and ``run`` both track them.

Apart from :mod:`seedtrack.pipeline` so that tracking a points file loads no video or detection
code (:mod:`seedtrack.pipeline` re-exports these names).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Callable

import numpy as np

from seedtrack.data.csvio import TRACK_COLUMNS, read_table
from seedtrack.data.errors import DataError
from seedtrack.tracking.goa import GOAConfig
from seedtrack.tracking.lifecycle import LifecycleConfig, drop_short
from seedtrack.tracking.linking import GOA_FAMILY, link_goa, pass_steps
from seedtrack.tracking.trackers import run_tracker
from seedtrack.tracking.tracks import Tracks

from .progress import progress_bar
from .wording import motion_lines

if TYPE_CHECKING:
    from .settings import LinkSettings

__all__ = ["POINT_COLUMNS", "LOCALISATION_COLUMN", "Points", "localised", "TrackingSettings", "group_points", "point_rows", "track_rows", "track_frames", "link_points", "given_first_links"]

POINT_COLUMNS = ("frame", "x", "y")
# Each point's localisation error, pixels per axis, as `detect` writes it (trackpy's name).
LOCALISATION_COLUMN = "ep"


@dataclass(frozen=True)
class Points:
    """Measured points grouped by frame.

    Attributes
    ----------
    frames : list of ndarray, each (M_k, 2)
        Positions (x, y), pixels, of frame ``first_frame + k * frame_step``, sorted by x then y.
    first_frame : int
        0-based frame index of ``frames[0]``.
    frame_step : int
        Spacing of the frame numbers: 1, or N when every frame number present is a multiple
        of N apart (every Nth frame measured, as ``run --step N`` writes them).
    order : ndarray of int
        0-based row of the input table of each point, frame after frame.
    offset : ndarray of int
        Position in ``order`` of each frame's first point.
    kept : dict of str to ndarray
        The input's other columns (as text when read from a file), one entry per row.
    localisation : float
        The points' typical localisation error, pixels per axis: the median of the values
        of an ``ep`` column (as ``detect`` and trackpy write it; blank, NaN or negative: none
        for that point), 0 without one.
    """

    frames: list[np.ndarray]
    first_frame: int
    frame_step: int
    order: np.ndarray
    offset: np.ndarray
    kept: dict[str, np.ndarray]
    localisation: float = 0.0


def group_points(table: dict[str, np.ndarray], source, processed: np.ndarray | None = None) -> Points:
    """Group the points of a table (columns frame, x, y, any others) by frame, sorted by
    position within each, as ``seedtrack track`` and ``run`` both track them.

    Parameters
    ----------
    table : dict of str to ndarray
        ``frame`` (int), ``x``, ``y`` (finite floats), other columns kept as they are.
    source
        What the table was read from, to name in errors.
    processed : ndarray of int, optional
        The 0-based frames measured, evenly spaced, when known (a clip detected frame by frame,
        some frames perhaps empty); by default the frame numbers present.

    Raises
    ------
    DataError
        Without ``processed``: if a frame is negative, or fewer than two frames hold points.

    Examples
    --------
    >>> import numpy as np
    >>> table = {"frame": np.array([2, 0, 0, 4]), "x": np.array([5.0, 9.0, 1.0, 3.0]), "y": np.zeros(4)}
    >>> points = group_points(table, "points")
    >>> points.first_frame, points.frame_step, [f[:, 0].tolist() for f in points.frames]
    (0, 2, [[1.0, 9.0], [5.0], [3.0]])
    >>> points.order.tolist()
    [2, 1, 0, 3]
    """
    frame, x, y = (table[name] for name in POINT_COLUMNS)
    if processed is None:
        if frame.size == 0:
            raise DataError(source, "no points (only a header); tracking needs points in at least two frames")
        if frame.min() < 0:
            bad = int(np.argmax(frame < 0))
            raise DataError(source, f"line {bad + 2}: frame {frame[bad]} is negative (frames are 0-based)")
        processed = np.unique(frame)
        if processed.size < 2:
            raise DataError(source, f"all points are in frame {frame[0]}; tracking needs points in at least two frames")
    # Frames numbered 0, 2, 4, ... are consecutive measurements, not measurements with every
    # other frame missed (which no track would survive).
    step = int(np.gcd.reduce(np.diff(processed))) if processed.size > 1 else 1
    # Sorting by position makes the result independent of the order of the rows.
    order = np.lexsort((y, x, frame))
    first = int(processed[0])
    columns = (int(processed[-1]) - first) // step + 1
    offset = np.concatenate(([0], np.cumsum(np.bincount((frame - first) // step, minlength=columns))))
    xy = np.column_stack((x, y))[order]
    frames = [xy[start:end] for start, end in zip(offset[:-1], offset[1:])]
    kept = {name: values for name, values in table.items() if name not in POINT_COLUMNS + TRACK_COLUMNS}
    localisation = _typical_error(kept[LOCALISATION_COLUMN], source) if LOCALISATION_COLUMN in kept else 0.0
    return Points(frames, first, step, order, offset[:-1], kept, localisation)


def _typical_error(values: np.ndarray, source) -> float:
    """The median of the localisation errors of a column (text or numbers; blank, NaN or
    negative where a point has none), pixels per axis; 0 when no point has one.

    Raises
    ------
    DataError
        If a value is not a number.
    """
    text = values.astype(str) if values.dtype.kind in "OUS" else None
    if text is not None:
        blank = np.char.strip(text) == ""
        try:
            errors = np.where(blank, "nan", text).astype(float)
        except ValueError:
            bad = next(k for k, value in enumerate(text) if not blank[k] and not _is_number(value))
            raise DataError(source, f"line {bad + 2}: column {LOCALISATION_COLUMN} holds {str(text[bad])!r}, not a number (a localisation error, pixels)") from None
    else:
        errors = values.astype(float)
    # trackpy writes NaN, or a negative value where a spot's mass is below its background: no
    # estimate for that point.
    known = errors[np.isfinite(errors) & (errors >= 0)]
    return float(np.median(known)) if known.size else 0.0


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def point_rows(points: Points, tracks: Tracks) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """The track columns of tracks.csv, in the input's frame numbers, and for each row the 0-based
    row of the input table it measures (-1 where interpolated), so that nothing is joined on floats.


    Examples
    --------
    >>> import numpy as np
    >>> table = {"frame": np.array([1, 0, 1, 0]), "x": np.array([11.0, 0.0, 1.0, 10.0]), "y": np.zeros(4)}
    >>> points = group_points(table, "points")
    >>> rows, source = point_rows(points, track_frames(points.frames, TrackingSettings(algorithm="nn"), say=None))
    >>> rows["track_id"].tolist(), source.tolist()
    ([0, 0, 1, 1], [1, 2, 3, 0])
    """
    rows = tracks.to_rows()
    # The point arrays are in to_rows' order. One index array at a time: on a million points each
    # is 8 MB of the peak of seedtrack track.
    column = tracks.point_column
    if points.frame_step != 1:
        rows["frame"] = tracks.first_frame + column * points.frame_step
    measured = np.flatnonzero(tracks.point_measurement >= 0)
    index = points.offset[column[measured]]
    index += tracks.point_measurement[measured]
    source = np.full(column.size, -1, dtype=np.int64)
    source[measured] = points.order[index]
    return rows, source


def track_rows(points: Points, tracks: Tracks, blank: object = "") -> dict[str, np.ndarray]:
    """The columns of tracks.csv: the track columns (:func:`point_rows`), then the input's other
    columns, on a measured row the values of the point it holds and on an interpolated row
    ``blank``; ``blank`` None is NaN, as a table with missing values holds it (whole numbers
    become floats, other values objects, unless no row is interpolated).

    Examples
    --------
    >>> table = {"frame": np.array([0, 0, 2, 2]), "x": np.array([0.0, 9.0, 2.0, 11.0]), "y": np.zeros(4), "id": np.array([5, 6, 7, 8])}
    >>> points = group_points(table, "points")
    >>> rows = track_rows(points, track_frames(points.frames, TrackingSettings(algorithm="nn"), say=None))
    >>> rows["id"].tolist()
    [5, 7, 6, 8]
    """
    rows, source = point_rows(points, tracks)
    measured = source >= 0
    for name, values in points.kept.items():
        if blank is None and measured.all():
            rows[name] = values[source]
            continue
        out = np.full(source.size, np.nan if blank is None else blank, dtype=float if blank is None and values.dtype.kind in "iuf" else object)
        out[measured] = values[source[measured]]
        rows[name] = out
    return rows


@dataclass(frozen=True)
class TrackingSettings:
    """What the tracker is asked to do: the options of ``seedtrack track`` (and of ``run``).

    Attributes
    ----------
    algorithm : str
        A GOA tracker (:data:`seedtrack.tracking.linking.GOA_FAMILY`), fitted to the motion, or
        a comparison tracker of :data:`seedtrack.tracking.trackers.TRACKERS`, which takes only
        ``config.d_max``.
    config : GOAConfig
        Before fitting to the motion.
    lifecycle : LifecycleConfig or None
        When tracks open and end; None for the paper's fixed count of tracks.
    motion : {"auto", "smooth", "random"}
    keep_model : bool
        Keep ``config``'s individual model whatever the motion (the user chose it).
    min_length : int
        Tracks spanning fewer frames, gaps included, are dropped.
    first_links : ndarray of int, shape (n, 2), optional
        For "goa": the first two frames' correspondences given (the paper's protocol).
    """

    algorithm: str = "goa-updown"
    config: GOAConfig = GOAConfig()
    lifecycle: LifecycleConfig | None = LifecycleConfig()
    motion: str = "auto"
    keep_model: bool = False
    min_length: int = 0
    first_links: np.ndarray | None = None


def track_frames(
    frames: list[np.ndarray],
    settings: TrackingSettings = TrackingSettings(),
    first_frame: int = 0,
    say: Callable[[str], None] | None = print,
    verbose: bool = False,
) -> Tracks:
    """Track points as ``settings`` say, with a progress bar, and drop the short tracks.

    The GOA family says on one ``motion: ...`` line how the points move
    (:func:`seedtrack.wording.motion_lines`; with ``verbose``, the details on more lines) to
    ``say`` (None: to nobody). ``first_frame`` is the 0-based index of ``frames[0]``.

    Examples
    --------
    >>> import numpy as np
    >>> frames = [np.array([[10.0 + 2 * k, 10.0], [40.0 - 2 * k, 30.0]]) for k in range(6)]
    >>> track_frames(frames, TrackingSettings(min_length=3)).n_tracks  # doctest: +ELLIPSIS
    motion: smooth-motion default, tracked with IM2, no speed limit
    2
    """
    if settings.algorithm not in GOA_FAMILY:
        return drop_short(run_tracker(settings.algorithm, frames, settings.config.d_max, first_frame), settings.min_length)
    steps = pass_steps(settings.algorithm, [len(f) for f in frames], settings.motion, settings.keep_model)
    with progress_bar(steps, "tracking", unit="step") as bar:
        tracks, fit = link_goa(
            frames,
            settings.algorithm,
            settings.config,
            settings.lifecycle,
            settings.motion,
            settings.keep_model,
            first_frame,
            progress=bar.update,
            first_links=settings.first_links,
        )
    if say is not None:
        for line in motion_lines(fit, verbose):
            say(line)
    return drop_short(tracks, settings.min_length)


def link_points(points: Points, settings: LinkSettings, say: Callable[[str], None] | None = print, verbose: bool = False) -> Tracks:
    """Link grouped points as ``settings`` say (:func:`track_frames`, which says how they move to
    ``say``, in detail with ``verbose``), the first links of a tracks file read first
    (:func:`given_first_links`).

    Examples
    --------
    >>> from seedtrack.settings import LinkSettings
    >>> table = {"frame": np.array([0, 0, 1, 1]), "x": np.array([0.0, 9.0, 1.0, 10.0]), "y": np.zeros(4)}
    >>> link_points(group_points(table, "points"), LinkSettings(algorithm="nn", max_speed=3.0), say=None).n_tracks
    2
    """
    tracking = localised(settings.tracking(), points)
    if settings.first_links_file is not None:
        tracking = replace(tracking, first_links=given_first_links(settings.first_links_file, points))
    return track_frames(points.frames, tracking, points.first_frame, say, verbose)


def localised(settings: TrackingSettings, points: Points) -> TrackingSettings:
    """``settings`` with the points' localisation error (:attr:`Points.localisation`) as the
    floor of the motion noise (:attr:`seedtrack.tracking.goa.GOAConfig.localisation_error`),
    where it is larger than the one given.

    Examples
    --------
    >>> table = {"frame": np.array([0, 1]), "x": np.array([0.0, 1.0]), "y": np.zeros(2), "ep": np.array(["0.25", "0.35"])}
    >>> localised(TrackingSettings(), group_points(table, "points")).config.localisation_error
    0.3
    """
    if points.localisation <= settings.config.localisation_error:
        return settings
    return replace(settings, config=replace(settings.config, localisation_error=points.localisation))


# A given first link's point must lie this close to a measured point, pixels.
_GIVEN_TOLERANCE = 0.5


def given_first_links(path: Path, points: Points) -> np.ndarray:
    """First links from a tracks file: per track with a point in the first frame, the index of
    that point in ``points.frames[0]`` and of its point in the second frame (-1 if none).

    Raises
    ------
    DataError
        If the file cannot be read, or one of its first- or second-frame points is not within
        0.5 px of a measured point, or two of its tracks claim one point.
    """
    from scipy.spatial import cKDTree

    table = read_table(path, required=("track_id", "frame", "x", "y"), integer=("track_id", "frame"))
    frames = (points.first_frame, points.first_frame + points.frame_step)
    index = {}
    for column, frame in enumerate(frames):
        rows = np.flatnonzero(table["frame"] == frame)
        xy = np.column_stack((table["x"][rows], table["y"][rows]))
        distance, found = cKDTree(points.frames[column]).query(xy) if len(rows) else (np.empty(0), np.empty(0, int))
        far = np.flatnonzero(distance > _GIVEN_TOLERANCE)
        if far.size:
            line = rows[far[0]] + 2
            raise DataError(path, f"line {line}: no point of frame {frame} lies within {_GIVEN_TOLERANCE} px of ({xy[far[0], 0]:g}, {xy[far[0], 1]:g})")
        if np.unique(found).size != found.size:
            raise DataError(path, f"two tracks start on the same point of frame {frame}")
        index[column] = dict(zip(table["track_id"][rows].tolist(), found.tolist()))
    if not index[0]:
        raise DataError(path, f"no track has a point in frame {frames[0]}, the first frame of the points")
    ids = sorted(index[0])
    return np.array([[index[0][i], index[1].get(i, -1)] for i in ids], dtype=np.int64)
