"""Where each wrongly tracked true trajectory first goes wrong, and what happened there."""

from __future__ import annotations

import numpy as np

from .metrics import UNMATCHED, match_points, true_track_owners
from .tracks import Tracks


def first_errors(result: Tracks, truth: Tracks, tolerance: float) -> dict[str, np.ndarray]:
    """For every true track that no single result track follows throughout, its first error.

    A true track is followed by the result track matched to it in its first measured frame
    (points matched as in :func:`seedtrack.tracking.metrics.match_points`); its first error is the first
    measured frame where another result track, or none, stands for it. These are exactly the
    tracks that the strict track error counts as wrong.

    Parameters
    ----------
    result, truth : Tracks
    tolerance : float
        Matching distance, pixels.

    Returns
    -------
    dict of str to ndarray, one entry per wrong true track, in truth order
        ``truth_track`` (id), ``frame`` (0-based), ``result_track`` (id of the follower, -1 if
        none), ``taken_over_by`` (id of the result track standing for the true track in that
        frame, -1 if none), ``jumped_to_truth`` (id of the true track the follower stands for
        in that frame, -1 if none) and ``what`` (a short description).
    """
    matched = match_points(result, truth, tolerance)
    owner = true_track_owners(matched, result, truth)
    measured = truth.present & ~truth.interpolated
    records = []
    for track in range(truth.n_tracks):
        columns = np.flatnonzero(measured[track])
        if columns.size == 0:
            continue
        owners = owner[track, columns]
        follower = owners[0]
        wrong = np.flatnonzero(owners != follower) if follower != UNMATCHED else np.array([0])
        if wrong.size == 0:
            continue
        column = columns[wrong[0]]
        records.append((track, column, follower, owners[wrong[0]], *_follower_state(result, truth, matched, follower, column, tolerance)))
    return _columns(records, result, truth)


def _follower_state(result: Tracks, truth: Tracks, matched: np.ndarray, follower: int, column: int, tolerance: float) -> tuple[int, str]:
    """The true track row the follower stands for at truth column ``column`` and why it left."""
    if follower == UNMATCHED:
        return UNMATCHED, "no result track within tolerance at its first point"
    result_column = column + truth.first_frame - result.first_frame
    if not 0 <= result_column < result.n_frames or not result.present[follower, result_column]:
        later = np.flatnonzero(result.present[follower, max(result_column, 0):]) if result_column < result.n_frames else np.empty(0, int)
        if later.size:
            return UNMATCHED, f"its result track misses this frame (it goes on from frame {result.first_frame + max(result_column, 0) + int(later[0])})"
        return UNMATCHED, "its result track ends"
    other = matched[follower, result_column]
    if other == UNMATCHED:
        return UNMATCHED, f"its result track strays beyond {tolerance:g} px"
    return int(other), "its result track jumps to another true track"


def _columns(records: list[tuple], result: Tracks, truth: Tracks) -> dict[str, np.ndarray]:
    def ids(tracks: Tracks, rows) -> np.ndarray:
        rows = np.asarray(rows, dtype=np.int64)
        found = np.full(rows.size, -1, dtype=np.int64)
        found[rows != UNMATCHED] = tracks.track_ids[rows[rows != UNMATCHED]]
        return found

    track, column, follower, taker, jumped, what = (list(values) for values in zip(*records)) if records else ([],) * 6
    return {
        "truth_track": ids(truth, track),
        "frame": np.asarray(column, dtype=np.int64) + truth.first_frame,
        "result_track": ids(result, follower),
        "taken_over_by": ids(result, taker),
        "jumped_to_truth": ids(truth, jumped),
        "what": np.array(what, dtype=object),
    }
