"""How well a track set reproduces the true trajectories (paper section 9.3).

Result points are first matched to true points frame by frame, one to one within a distance
tolerance, by optimal assignment; the metrics then compare which true trajectory each result
point stands for.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .tracks import Tracks

UNMATCHED = -1


def match_points(result: Tracks, truth: Tracks, tolerance: float) -> np.ndarray:
    """For every result point, the true track it coincides with in that frame.

    Parameters
    ----------
    result, truth : Tracks
        The track sets; frames are aligned by their 0-based frame indices.
    tolerance : float
        Largest distance, pixels, at which a result point can stand for a true point.

    Returns
    -------
    ndarray of int, shape (result.n_tracks, result.n_frames)
        Row index into ``truth`` of the matched true track, or -1.
    """
    matched = np.full(result.measurement.shape, UNMATCHED, dtype=np.int64)
    for column in range(result.n_frames):
        truth_column = column + result.first_frame - truth.first_frame
        if not 0 <= truth_column < truth.n_frames:
            continue
        ours = np.flatnonzero(result.present[:, column])
        theirs = np.flatnonzero(truth.present[:, truth_column])
        if ours.size == 0 or theirs.size == 0:
            continue
        rows, cols = match_frame(result.xy[ours, column], truth.xy[theirs, truth_column], tolerance)
        matched[ours[rows], column] = theirs[cols]
    return matched


def match_frame(found: np.ndarray, true: np.ndarray, tolerance: float) -> tuple[np.ndarray, np.ndarray]:
    """One-to-one matches of found to true points of one frame, within ``tolerance``, that
    minimise the summed distance.

    Parameters
    ----------
    found, true : ndarray, shape (n, 2) and (m, 2)
        Positions, pixels.
    tolerance : float
        Largest distance of a match, pixels.

    Returns
    -------
    rows, cols : ndarray of int
        ``found[rows[i]]`` matches ``true[cols[i]]``.
    """
    if len(found) == 0 or len(true) == 0:
        return np.empty(0, int), np.empty(0, int)
    # scipy.optimize loads all of its solvers (about 0.6 s): paid here, when points are
    # matched, not by every import of the metrics.
    from scipy.optimize import linear_sum_assignment

    distance = np.hypot(found[:, None, 0] - true[None, :, 0], found[:, None, 1] - true[None, :, 1])
    # Pairs beyond the tolerance must never be chosen, and a finite stand-in keeps the
    # problem feasible; any pair beyond it is discarded afterwards.
    cost = np.where(distance <= tolerance, distance, 1e6 + tolerance)
    rows, cols = linear_sum_assignment(cost)
    good = distance[rows, cols] <= tolerance
    return rows[good], cols[good]


def true_track_owners(matched: np.ndarray, result: Tracks, truth: Tracks) -> np.ndarray:
    """Invert :func:`match_points`: the result track standing for each true point.

    Parameters
    ----------
    matched : ndarray of int, shape (result.n_tracks, result.n_frames)
        As returned by :func:`match_points`.
    result, truth : Tracks

    Returns
    -------
    ndarray of int, shape (truth.n_tracks, truth.n_frames)
        Row index into ``result`` of the track matched to the true point, or -1.
    """
    owner = np.full(truth.measurement.shape, UNMATCHED, dtype=np.int64)
    rows, columns = np.nonzero(matched != UNMATCHED)
    owner[matched[rows, columns], columns + result.first_frame - truth.first_frame] = rows
    return owner


@dataclass(frozen=True)
class TrackScores:
    """The paper's measures of a track set against the truth.

    Attributes
    ----------
    true_tracks : int
        Trajectories in the truth.
    correct_tracks : int
        True trajectories that one result track follows point for point over every frame in
        which the truth is measured (strict trajectory merit).
    relaxed_correct : int
        True trajectories whose first and last measured points lie on one result track.
    true_links, correct_links : int
        Links between measured points of consecutive frames in the truth, and how many of them
        a result track also makes.
    """

    true_tracks: int
    correct_tracks: int
    relaxed_correct: int
    true_links: int
    correct_links: int

    @property
    def track_error(self) -> float:
        """E_track = 1 - correct / true trajectories."""
        return 1.0 - self.correct_tracks / self.true_tracks if self.true_tracks else 0.0

    @property
    def relaxed_error(self) -> float:
        """1 - relaxed trajectory merit."""
        return 1.0 - self.relaxed_correct / self.true_tracks if self.true_tracks else 0.0

    @property
    def link_error(self) -> float:
        """E_link = 1 - correct / true links."""
        return 1.0 - self.correct_links / self.true_links if self.true_links else 0.0


def score_tracks(result: Tracks, truth: Tracks, tolerance: float = 1.0) -> TrackScores:
    """Strict track error, relaxed trajectory merit and link error of ``result``.

    Only frames in which the truth holds a measured point are judged, so a true occlusion
    (interpolated in the truth) neither helps nor hurts.

    Parameters
    ----------
    result, truth : Tracks
    tolerance : float
        Matching distance, pixels.
    """
    owner = true_track_owners(match_points(result, truth, tolerance), result, truth)
    measured = truth.present & ~truth.interpolated

    correct = 0
    relaxed = 0
    for track in range(truth.n_tracks):
        frames = np.flatnonzero(measured[track])
        if frames.size == 0:
            continue
        owners = owner[track, frames]
        if owners[0] != UNMATCHED and np.all(owners == owners[0]):
            correct += 1
        if owners[0] != UNMATCHED and owners[0] == owners[-1]:
            relaxed += 1
    link_exists = measured[:, :-1] & measured[:, 1:]
    link_kept = link_exists & (owner[:, :-1] == owner[:, 1:]) & (owner[:, :-1] != UNMATCHED)
    return TrackScores(
        true_tracks=int(measured.any(axis=1).sum()),
        correct_tracks=correct,
        relaxed_correct=relaxed,
        true_links=int(link_exists.sum()),
        correct_links=int(link_kept.sum()),
    )
