"""Track sets scored against the truth, and the links two track sets disagree on.

What ``seedtrack evaluate`` and :func:`seedtrack.evaluate` report (:func:`assess`), and what
``seedtrack compare`` and the annotation tool's doubts mark (:func:`disagreeing_links`).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from seedtrack.data.errors import DataError
from seedtrack.tracking.clear_mot import ClearMotScores
from seedtrack.tracking.diagnosis import first_errors
from seedtrack.tracking.evaluation import Scores, evaluate_tracks
from seedtrack.tracking.metrics import UNMATCHED, match_points
from seedtrack.tracking.tracks import Tracks

from .drawing import track_links

__all__ = ["DEFAULT_TOLERANCE", "assess", "disagreeing_links"]

# Matching distance, pixels, unless told.
DEFAULT_TOLERANCE = 3.0
# A result matching fewer true points than this is checked against the truth one frame off.
_WELL_MATCHED = 0.9


def assess(result: Tracks, truth: Tracks, tolerance: float, truth_source) -> tuple[Scores, ClearMotScores, dict[str, np.ndarray], str | None]:
    """Score a result against the truth read from ``truth_source`` (named in errors and hints).

    Returns
    -------
    scores : Scores
        Rates in [0, 1], MOTP in pixels.
    clear : ClearMotScores
        With the per-frame counts.
    wrong : dict of str to ndarray
        :func:`seedtrack.tracking.diagnosis.first_errors` of the result.
    hint : str or None
        When most true points match nothing but would with the truth's frame numbers one off,
        a line that says so (truth numbered from 1 against tracks from 0 is a common slip).

    Raises
    ------
    DataError
        If the truth holds no track or a single frame.
    """
    if truth.n_tracks == 0:
        raise DataError(truth_source, "holds no true tracks; there is nothing to score against")
    if truth.n_frames < 2:
        raise DataError(truth_source, f"holds a single frame ({truth.first_frame}); scoring links needs at least two")
    scores, clear = evaluate_tracks(result, truth, tolerance)
    return scores, clear, first_errors(result, truth, tolerance), _offset_hint(result, truth, tolerance, clear, truth_source)


def _offset_hint(result: Tracks, truth: Tracks, tolerance: float, clear: ClearMotScores, truth_path) -> str | None:
    if clear.num_objects - clear.num_misses >= _WELL_MATCHED * clear.num_objects:
        return None
    # Points with a result point near them, not one-to-one matches: as good a sign at a
    # fraction of the cost, which matters when large poor results are scored.
    near = {shift: _share_near(result, truth, tolerance, shift) for shift in (0, -1, 1)}
    for shift in (-1, 1):
        if near[shift] >= max(_WELL_MATCHED, near[0] + 0.2):
            return (
                f"hint: {near[shift]:.0%} of the true points have a result point within {tolerance:g} px with "
                f"{truth_path}'s frame numbers shifted by {shift:+d} (against {near[0]:.0%} as given); are both "
                "files' frames 0-based?"
            )
    return None


def _share_near(result: Tracks, truth: Tracks, tolerance: float, shift: int) -> float:
    """Share of the true points with a result point within ``tolerance`` pixels in the frame
    ``shift`` frames after theirs."""
    near = 0
    for column in range(truth.n_frames):
        true_points = truth.xy[truth.present[:, column], column]
        other = truth.first_frame + column + shift - result.first_frame
        if true_points.size == 0 or not 0 <= other < result.n_frames:
            continue
        result_points = result.xy[result.present[:, other], other]
        if result_points.size:
            distance = cKDTree(result_points).query(true_points, distance_upper_bound=tolerance)[0]
            near += int(np.count_nonzero(np.isfinite(distance)))
    return near / max(int(truth.present.sum()), 1)


def disagreeing_links(tracks: Tracks, other: Tracks, tolerance: float) -> np.ndarray:
    """Links of ``tracks`` that ``other`` does not make.

    Parameters
    ----------
    tracks, other : Tracks
        Frames aligned by their 0-based frame indices.
    tolerance : float
        Matching distance, pixels (points matched one to one per frame, optimal assignment).

    Returns
    -------
    ndarray of bool, shape (tracks.n_tracks, tracks.n_frames)
        True at the column where a link (see :func:`seedtrack.drawing.track_links`) ends when its two
        points are not both matched to the same track of ``other``.
    """
    matched = match_points(tracks, other, tolerance)
    rows, starts, ends = track_links(tracks.present)
    differ = (matched[rows, starts] != matched[rows, ends]) | (matched[rows, ends] == UNMATCHED)
    warnings = np.zeros(tracks.present.shape, bool)
    warnings[rows[differ], ends[differ]] = True
    return warnings
