"""Motion analysis as tables: ``seedtrack.msd``, ``seedtrack.drift``, ``seedtrack.velocity``.

Each takes tracks as a DataFrame (``track_id`` or trackpy's ``particle``, ``frame``, ``x``,
``y``), a file in any track format, or :class:`~seedtrack.tracking.tracks.Tracks`, and returns
a DataFrame in the units given: lengths are pixels times ``pixel_size``, times frames times
``frame_interval`` (pixels and frames by default). The computing is
:mod:`seedtrack.tracking.analysis`.
"""

from __future__ import annotations

import pandas as pd

from seedtrack.data.calibration import Calibration
from seedtrack.tracking.analysis import drift_table, msd_table, velocity_table, without_drift
from seedtrack.tracking.tracks import Tracks

from .api import PathLike, _tracks


def msd(
    tracks: pd.DataFrame | PathLike | Tracks,
    pixel_size: float = 1.0,
    frame_interval: float = 1.0,
    max_lag: int = 100,
    per_track: bool = False,
    subtract_drift: bool = False,
) -> pd.DataFrame:
    """Mean squared displacement against lag time over all tracks, every point pair weighing the
    same (trackpy's ``emsd`` weighs tracks otherwise, see
    :func:`seedtrack.tracking.analysis.msd_table`), or per track (its ``imsd``).

    Parameters
    ----------
    tracks : DataFrame, path-like or Tracks
    pixel_size : float
        Length of a pixel (e.g. micrometres per pixel); 1.0 keeps pixels.
    frame_interval : float
        Time between frames (e.g. seconds); 1.0 keeps frames.
    max_lag : int
        Longest lag, frames.
    per_track : bool
        One row per track and lag, with a ``track_id`` column.
    subtract_drift : bool
        Take the drift (:func:`drift`) off the positions first, as trackpy's ``subtract_drift``.

    Returns
    -------
    DataFrame
        ``lag`` (frames), ``lag_time``, ``msd`` (length squared), ``n`` (point pairs averaged).

    Example
    -------
    >>> import pandas as pd, seedtrack
    >>> walk = pd.DataFrame({"track_id": [1, 1, 1], "frame": [0, 1, 2], "x": [0.0, 1.0, 2.0], "y": [0.0, 0.0, 0.0]})
    >>> seedtrack.msd(walk, pixel_size=0.5, frame_interval=0.1)[["lag_time", "msd"]].to_numpy().tolist()
    [[0.1, 0.25], [0.2, 1.0]]
    """
    _check_units(pixel_size, frame_interval)
    if not (isinstance(max_lag, int) and max_lag >= 1):
        raise ValueError(f"max_lag must be a whole number of frames of at least 1, got {max_lag!r}")
    table = _tracks(tracks, "tracks")[0]
    return pd.DataFrame(msd_table(without_drift(table) if subtract_drift else table, pixel_size, frame_interval, max_lag, per_track))


def drift(tracks: pd.DataFrame | PathLike | Tracks, pixel_size: float = 1.0, frame_interval: float = 1.0) -> pd.DataFrame:
    """Drift of the whole set over time (the summed mean step of the tracks, frame to frame),
    as trackpy's ``compute_drift``.

    Returns
    -------
    DataFrame
        ``frame``, ``time``, ``x``, ``y`` (drift since the first frame, pixel_size units).

    Example
    -------
    >>> import pandas as pd, seedtrack
    >>> walk = pd.DataFrame({"track_id": [1, 1], "frame": [0, 1], "x": [0.0, 2.0], "y": [0.0, 0.0]})
    >>> seedtrack.drift(walk)["x"].tolist()
    [0.0, 2.0]
    """
    _check_units(pixel_size, frame_interval)
    return pd.DataFrame(drift_table(_tracks(tracks, "tracks")[0], pixel_size, frame_interval))


def velocity(tracks: pd.DataFrame | PathLike | Tracks, pixel_size: float = 1.0, frame_interval: float = 1.0) -> pd.DataFrame:
    """Per track: points, duration, path length, mean speed and net velocity.

    Returns
    -------
    DataFrame
        ``track_id``, ``points``, ``duration``, ``path_length``, ``mean_speed``, ``vx``, ``vy``,
        ``net_speed``, in pixel_size and frame_interval units; tracks of fewer than two
        measured points are left out.

    Example
    -------
    >>> import pandas as pd, seedtrack
    >>> walk = pd.DataFrame({"track_id": [1, 1], "frame": [0, 2], "x": [0.0, 3.0], "y": [0.0, 4.0]})
    >>> seedtrack.velocity(walk, frame_interval=0.5)["mean_speed"].tolist()
    [5.0]
    """
    _check_units(pixel_size, frame_interval)
    return pd.DataFrame(velocity_table(_tracks(tracks, "tracks")[0], pixel_size, frame_interval))


def _check_units(pixel_size: float, frame_interval: float) -> None:
    if not all(isinstance(value, (int, float)) for value in (pixel_size, frame_interval)):
        raise ValueError(f"pixel_size and frame_interval must be numbers, got {pixel_size!r} and {frame_interval!r}")
    Calibration(float(pixel_size), "length", float(frame_interval), "time")
