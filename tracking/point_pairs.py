"""The pairs of true and result points that lie in one frame within a distance of each other,
found all at once, for the metrics that only care about near pairs (HOTA, the ISBI challenge's)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from .tracks import Tracks


@dataclass(frozen=True)
class PointPairs:
    """Near pairs, sorted by frame, then true point, then result point.

    Attributes
    ----------
    frame : ndarray of int
        0-based frame index of each pair.
    truth_point, result_point : ndarray of int
        Index of the pair's point among ``truth``'s and ``result``'s points.
    truth_track, result_track : ndarray of int
        Row (track) of each in its track set.
    distance : ndarray of float
        Pixels.
    """

    frame: np.ndarray
    truth_point: np.ndarray
    result_point: np.ndarray
    truth_track: np.ndarray
    result_track: np.ndarray
    distance: np.ndarray


def near_pairs(result: Tracks, truth: Tracks, distance: float) -> PointPairs:
    """Every (true point, result point) pair in one frame at most ``distance`` pixels apart.

    Example
    -------
    >>> a = Tracks.from_rows([0, 0], [0, 1], [0.0, 1.0], [0.0, 0.0])
    >>> near_pairs(a, a, 0.5).distance
    array([0., 0.])
    """
    if truth.point_track.size == 0 or result.point_track.size == 0:
        empty = np.empty(0, np.int64)
        return PointPairs(empty, empty, empty, empty, empty, np.empty(0))
    # No two points are farther apart than the diagonal of their bounding box: a longer distance
    # finds the same pairs, and keeps the numbers below finite (a tolerance of 1e300 is valid).
    xy = np.concatenate((truth.point_xy, result.point_xy))
    reach = min(distance, float(np.hypot(*(xy.max(axis=0) - xy.min(axis=0)))) + 1.0)
    # Frames as a third coordinate, spaced far beyond the reach, so that one search finds the
    # pairs of every frame and none across frames.
    spacing = 4.0 * reach + 1.0
    lifted = [np.column_stack((tracks.point_xy, (tracks.point_column + tracks.first_frame) * spacing)) for tracks in (truth, result)]
    found = cKDTree(lifted[0]).sparse_distance_matrix(cKDTree(lifted[1]), reach, output_type="ndarray")
    t, r = found["i"].astype(np.int64), found["j"].astype(np.int64)
    frame = truth.point_column[t] + truth.first_frame
    order = np.lexsort((r, t, frame))
    t, r, frame = t[order], r[order], frame[order]
    # Recomputed in the plane: the tree's distances carry the lifted coordinate's rounding.
    d = np.hypot(*(truth.point_xy[t] - result.point_xy[r]).T)
    return PointPairs(frame, t, r, truth.point_track[t], result.point_track[r], d)


def common_frames(result: Tracks, truth: Tracks, truth_track: np.ndarray, result_track: np.ndarray) -> np.ndarray:
    """For each (true track, result track) pair given, the number of frames both have a point in.

    Example
    -------
    >>> a = Tracks.from_rows([0, 0, 0], [0, 1, 2], [0.0, 1.0, 2.0], [0.0, 0.0, 0.0])
    >>> b = Tracks.from_rows([5, 5], [1, 3], [1.0, 3.0], [0.0, 0.0])
    >>> common_frames(b, a, np.array([0]), np.array([0]))
    array([1])
    """
    if truth_track.size == 0 or result.point_track.size == 0:
        return np.zeros(truth_track.size, np.int64)
    counts = np.diff(truth.offsets)[truth_track]
    pair = np.repeat(np.arange(truth_track.size), counts)
    # The points of each pair's true track, then whether its result track has one in that frame.
    starts = np.repeat(truth.offsets[truth_track], counts)
    point = starts + np.arange(pair.size) - np.repeat(np.cumsum(counts) - counts, counts)
    frame = truth.point_column[point] + truth.first_frame
    span = max(truth.first_frame + truth.n_frames, result.first_frame + result.n_frames) + 1
    keys = result.point_track * span + result.point_column + result.first_frame
    wanted = result_track[pair] * span + frame
    hit = keys[np.minimum(np.searchsorted(keys, wanted), keys.size - 1)] == wanted
    return np.bincount(pair, weights=hit, minlength=truth_track.size).astype(np.int64)
