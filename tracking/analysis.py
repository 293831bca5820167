"""What tracks say about motion: mean squared displacement, drift and per-track velocity.

Only measured points count (positions filled in between measurements are straight lines and
would bias all three). Lengths are pixels times ``pixel_size`` and times frames times
``frame_interval``, so the results are in whatever units those two are given in (pixels and
frames by default). Tables are dicts of equal-length columns.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .tracks import Tracks


def _measured(tracks: Tracks) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Track row, 0-based frame index and position (pixels) of each measured point, sorted by
    track then frame."""
    keep = ~tracks.point_interpolated
    return tracks.point_track[keep], tracks.point_column[keep] + tracks.first_frame, tracks.point_xy[keep]


def displacements(tracks: Tracks, max_lag: int) -> tuple[np.ndarray, np.ndarray]:
    """Summed squared displacements and their counts, per track and lag.

    Every pair of measured points of one track ``lag`` frames apart counts, gaps included.

    Returns
    -------
    summed : ndarray, shape (n_tracks, max_lag)
        Sum of squared displacements, pixels squared; column ``k`` is lag ``k + 1`` frames.
    count : ndarray of int, shape (n_tracks, max_lag)
        Number of point pairs.

    Example
    -------
    >>> tracks = Tracks.from_rows([0, 0, 0], [0, 1, 2], [0.0, 1.0, 3.0], [0.0, 0.0, 0.0])
    >>> displacements(tracks, 2)[0]
    array([[5., 9.]])
    """
    track, frame, xy = _measured(tracks)
    span = int(frame.max()) + max_lag + 1 if frame.size else 1
    key = track * span + frame  # sorted, since points are sorted by track then frame
    summed = np.zeros((tracks.n_tracks, max_lag))
    count = np.zeros((tracks.n_tracks, max_lag), dtype=np.int64)
    for lag in range(1, max_lag + 1):
        at = np.searchsorted(key, key + lag)
        found = at < key.size
        found[found] = key[at[found]] == key[found] + lag
        step = xy[at[found]] - xy[found]
        summed[:, lag - 1] = np.bincount(track[found], (step**2).sum(axis=1), tracks.n_tracks)
        count[:, lag - 1] = np.bincount(track[found], minlength=tracks.n_tracks)
    return summed, count


def msd_table(tracks: Tracks, pixel_size: float = 1.0, frame_interval: float = 1.0, max_lag: int = 100, per_track: bool = False) -> dict[str, np.ndarray]:
    """Mean squared displacement against lag time, over all tracks or per track (trackpy's
    ``emsd`` and ``imsd``).

    Over all tracks every point pair weighs the same. trackpy's ``emsd`` weighs each track's
    MSD by its effective number of independent displacements instead: the same on tracks of
    one length, apart on many short tracks of unequal lengths.

    Parameters
    ----------
    tracks : Tracks
    pixel_size : float
        Length of a pixel in the unit wanted (1.0: pixels).
    frame_interval : float
        Time between frames in the unit wanted (1.0: frames).
    max_lag : int
        Longest lag, frames.
    per_track : bool
        One row per track and lag (with a ``track_id`` column) rather than per lag.

    Returns
    -------
    dict of str to ndarray
        ``lag`` (frames), ``lag_time`` (lag * frame_interval), ``msd`` (length squared), ``n``
        (point pairs); lags without a pair are left out.

    Example
    -------
    >>> tracks = Tracks.from_rows([0, 0, 0], [0, 1, 2], [0.0, 1.0, 3.0], [0.0, 0.0, 0.0])
    >>> msd_table(tracks, pixel_size=0.5, frame_interval=2.0)["msd"]
    array([0.625, 2.25 ])
    """
    summed, count = displacements(tracks, max_lag)
    lags = np.arange(1, max_lag + 1)
    if per_track:
        rows, columns = np.nonzero(count)
        table = {"track_id": tracks.track_ids[rows], "lag": lags[columns]}
        summed, count = summed[rows, columns], count[rows, columns]
    else:
        summed, count = summed.sum(axis=0), count.sum(axis=0)
        keep = count > 0
        table = {"lag": lags[keep]}
        summed, count = summed[keep], count[keep]
    return {**table, "lag_time": table["lag"] * frame_interval, "msd": summed / count * pixel_size**2, "n": count}


def fit_msd(lag_time: np.ndarray, msd: np.ndarray, dimensions: int = 2) -> tuple[float, float]:
    """Fit ``msd = 2 * dimensions * D * lag_time ** alpha`` by least squares in log-log.

    Returns
    -------
    D : float
        Diffusion coefficient, length squared per time, in the units of the inputs.
    alpha : float
        Exponent: 1 for free diffusion, below for confined, above for directed motion.

    Example
    -------
    >>> t = np.array([1.0, 2.0, 4.0])
    >>> [round(v, 6) for v in fit_msd(t, 4 * 0.5 * t)]
    [0.5, 1.0]
    """
    good = (lag_time > 0) & (msd > 0)
    if good.sum() < 2:
        return float("nan"), float("nan")
    alpha, intercept = np.polyfit(np.log(lag_time[good]), np.log(msd[good]), 1)
    return float(np.exp(intercept) / (2 * dimensions)), float(alpha)


def drift_table(tracks: Tracks, pixel_size: float = 1.0, frame_interval: float = 1.0) -> dict[str, np.ndarray]:
    """Collective motion over time: the mean step, from each frame to the next, of the tracks
    measured in both, summed from the first frame (as trackpy's ``compute_drift``).

    Returns
    -------
    dict of str to ndarray
        ``frame`` (0-based), ``time`` (frame * frame_interval), ``x``, ``y`` (drift since the
        first frame, in pixel_size units); a frame with no track measured in it and the one
        before adds no step.

    Example
    -------
    >>> tracks = Tracks.from_rows([0, 0, 1, 1], [0, 1, 0, 1], [0.0, 2.0, 5.0, 5.0], [0.0, 0.0, 0.0, 2.0])
    >>> drift_table(tracks)["y"]
    array([0., 1.])
    """
    track, frame, xy = _measured(tracks)
    follows = (np.diff(track) == 0) & (np.diff(frame) == 1)
    first = int(frame.min()) if frame.size else 0
    n = int(frame.max()) - first + 1 if frame.size else 0
    later = frame[1:][follows] - first
    step = (xy[1:] - xy[:-1])[follows]
    pairs = np.bincount(later, minlength=n)
    mean = np.zeros((n, 2))
    for axis in range(2):
        mean[:, axis] = np.bincount(later, step[:, axis], n) / np.maximum(pairs, 1)
    drift = np.cumsum(mean, axis=0) * pixel_size
    frames = np.arange(first, first + n)
    return {"frame": frames, "time": frames * frame_interval, "x": drift[:, 0], "y": drift[:, 1]}


def velocity_table(tracks: Tracks, pixel_size: float = 1.0, frame_interval: float = 1.0) -> dict[str, np.ndarray]:
    """Per track: duration, path length, mean speed and net velocity.

    Returns
    -------
    dict of str to ndarray
        ``track_id``, ``points`` (measured), ``duration`` (first to last measured point, time
        units), ``path_length`` (sum of the steps between measured points), ``mean_speed``
        (path length / duration), ``vx``, ``vy`` (net displacement / duration) and ``net_speed``;
        tracks with fewer than two measured points are left out.

    Example
    -------
    >>> tracks = Tracks.from_rows([3, 3, 3], [0, 1, 2], [0.0, 3.0, 0.0], [0.0, 4.0, 8.0])
    >>> velocity_table(tracks)["mean_speed"], velocity_table(tracks)["vy"]
    (array([5.]), array([4.]))
    """
    track, frame, xy = _measured(tracks)
    same = np.diff(track) == 0
    step = np.hypot(*(xy[1:] - xy[:-1]).T)
    path = np.bincount(track[1:][same], step[same], tracks.n_tracks) * pixel_size
    points = np.bincount(track, minlength=tracks.n_tracks)
    starts = np.searchsorted(track, np.arange(tracks.n_tracks))
    keep = np.flatnonzero(points >= 2)
    first, last = starts[keep], starts[keep] + points[keep] - 1
    duration = (frame[last] - frame[first]) * frame_interval
    net = (xy[last] - xy[first]) * pixel_size / duration[:, None]
    return {
        "track_id": tracks.track_ids[keep],
        "points": points[keep],
        "duration": duration.astype(float),
        "path_length": path[keep],
        "mean_speed": path[keep] / duration,
        "vx": net[:, 0],
        "vy": net[:, 1],
        "net_speed": np.hypot(net[:, 0], net[:, 1]),
    }


def without_drift(tracks: Tracks) -> Tracks:
    """``tracks`` with the drift of :func:`drift_table` taken off every point (as trackpy's
    ``subtract_drift``), so that an MSD measures the motion of the objects, not of the medium.

    Example
    -------
    >>> tracks = Tracks.from_rows([0, 0, 1, 1], [0, 1, 0, 1], [0.0, 2.0, 5.0, 7.0], [0.0, 0.0, 1.0, 1.0])
    >>> without_drift(tracks).point_xy[:, 0]
    array([0., 0., 5., 5.])
    """
    table = drift_table(tracks)
    if table["frame"].size == 0:
        return tracks
    shift = np.column_stack((table["x"], table["y"]))
    # Interpolated points lie between measured ones, so within the drift's frames.
    at = np.clip(tracks.point_column + tracks.first_frame - table["frame"][0], 0, table["frame"].size - 1)
    return replace(tracks, point_xy=tracks.point_xy - shift[at])
