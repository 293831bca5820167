"""CLEAR-MOT (MOTA, MOTP, ID switches, fragmentations) and the identity measures (IDF1).

Computed the way py-motmetrics computes them (``MOTAccumulator.update`` with a distance matrix
whose pairs beyond the tolerance are NaN, then ``mm.metrics``), so that figures can be compared
with published ones; only plain numpy and scipy are used.

Per frame, a true object keeps the result track it was matched to last time if that track is
present and within the tolerance; the remaining objects and tracks are matched by an optimal
assignment that first maximises the number of pairs within the tolerance and then minimises
their total distance. A match to a track other than the object's previous one is an ID switch.
Unmatched objects are misses, unmatched result points false positives.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from .tracks import Tracks

UNMATCHED = -1


@dataclass(frozen=True)
class ClearMotScores:
    """Counts over all frames, and per frame, of a track set against the truth.

    Attributes
    ----------
    num_objects, num_predictions : int
        True points and result points.
    num_matches : int
        Matches that are not ID switches (motmetrics' ``num_matches``).
    num_switches, num_misses, num_false_positives, num_fragmentations : int
        ID switches, missed true points, unmatched result points, and times a true track goes
        from tracked to missed between its first and last tracked frame.
    total_distance : float
        Sum of the distances of all matches, pixels.
    idtp : int
        True points matched by the best one-to-one pairing of whole true and result tracks.
    frames : ndarray of int
        0-based frame index of each entry of the per-frame arrays.
    frame_misses, frame_false_positives, frame_switches : ndarray of int
        The counts per frame.
    """

    num_objects: int
    num_predictions: int
    num_matches: int
    num_switches: int
    num_misses: int
    num_false_positives: int
    num_fragmentations: int
    total_distance: float
    idtp: int
    frames: np.ndarray
    frame_misses: np.ndarray
    frame_false_positives: np.ndarray
    frame_switches: np.ndarray

    @property
    def mota(self) -> float:
        """1 - (misses + false positives + ID switches) / true points."""
        errors = self.num_misses + self.num_false_positives + self.num_switches
        return 1.0 - errors / self.num_objects if self.num_objects else float("nan")

    @property
    def motp(self) -> float:
        """Mean distance of the matches, pixels (lower is better)."""
        detections = self.num_matches + self.num_switches
        return self.total_distance / detections if detections else float("nan")

    @property
    def idf1(self) -> float:
        """2 IDTP / (true points + result points)."""
        total = self.num_objects + self.num_predictions
        return 2.0 * self.idtp / total if total else float("nan")

    @property
    def idp(self) -> float:
        """IDTP / result points."""
        return self.idtp / self.num_predictions if self.num_predictions else float("nan")

    @property
    def idr(self) -> float:
        """IDTP / true points."""
        return self.idtp / self.num_objects if self.num_objects else float("nan")


def clear_mot(result: Tracks, truth: Tracks, tolerance: float) -> ClearMotScores:
    """CLEAR-MOT and identity measures of ``result`` against ``truth``.

    Every present point counts, measured or interpolated, in both track sets.

    Parameters
    ----------
    result, truth : Tracks
        Frames are aligned by their 0-based frame indices.
    tolerance : float
        Largest distance, pixels, at which a result point can stand for a true point.
    """
    first = min(result.first_frame, truth.first_frame)
    last = max(result.first_frame + result.n_frames, truth.first_frame + truth.n_frames)
    frames = np.arange(first, last)
    previous = np.full(truth.n_tracks, UNMATCHED, dtype=np.int64)  # motmetrics' m: object -> track
    tracked = np.zeros((truth.n_tracks, frames.size), dtype=np.int8)  # 0 absent, 1 matched, 2 missed
    together = np.zeros((truth.n_tracks, result.n_tracks), dtype=np.int64)
    misses = np.zeros(frames.size, dtype=np.int64)
    false_positives = np.zeros(frames.size, dtype=np.int64)
    switches = np.zeros(frames.size, dtype=np.int64)
    matches, total_distance = 0, 0.0
    for k, frame in enumerate(frames):
        objects = _present_rows(truth, frame)
        hypotheses = _present_rows(result, frame)
        distance = _distances(truth, objects, result, hypotheses, frame, tolerance)
        valid_o, valid_h = np.nonzero(~np.isnan(distance))
        together[objects[valid_o], hypotheses[valid_h]] += 1
        pair_o, pair_h, switched = _match_frame(distance, previous[objects], hypotheses)
        matched_objects = objects[pair_o]
        previous[matched_objects] = hypotheses[pair_h]
        total_distance += float(distance[pair_o, pair_h].sum())
        switches[k] = int(switched.sum())
        matches += pair_o.size - switches[k]
        misses[k] = objects.size - pair_o.size
        false_positives[k] = hypotheses.size - pair_h.size
        tracked[objects, k] = 2
        tracked[matched_objects, k] = 1
    return ClearMotScores(
        num_objects=int(truth.present.sum()),
        num_predictions=int(result.present.sum()),
        num_matches=int(matches),
        num_switches=int(switches.sum()),
        num_misses=int(misses.sum()),
        num_false_positives=int(false_positives.sum()),
        num_fragmentations=_fragmentations(tracked),
        total_distance=total_distance,
        idtp=_identity_true_positives(together),
        frames=frames,
        frame_misses=misses,
        frame_false_positives=false_positives,
        frame_switches=switches,
    )


def _present_rows(tracks: Tracks, frame: int) -> np.ndarray:
    column = frame - tracks.first_frame
    if not 0 <= column < tracks.n_frames:
        return np.zeros(0, dtype=np.int64)
    return np.flatnonzero(tracks.present[:, column])


def _distances(truth: Tracks, objects: np.ndarray, result: Tracks, hypotheses: np.ndarray, frame: int, tolerance: float) -> np.ndarray:
    """Object-by-hypothesis distances, pixels, NaN beyond the tolerance."""
    a = truth.xy[objects, frame - truth.first_frame] if objects.size else np.zeros((0, 2))
    b = result.xy[hypotheses, frame - result.first_frame] if hypotheses.size else np.zeros((0, 2))
    distance = np.hypot(a[:, None, 0] - b[None, :, 0], a[:, None, 1] - b[None, :, 1])
    distance[distance > tolerance] = np.nan
    return distance


def _match_frame(distance: np.ndarray, previous: np.ndarray, hypotheses: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One frame of motmetrics' matching.

    Returns
    -------
    pair_o, pair_h : ndarray of int
        Matched object and hypothesis positions within the frame.
    switched : ndarray of bool
        For each pair, whether it is an ID switch.
    """
    n_o, n_h = distance.shape
    # Step 1: keep last correspondences that are still present and within the tolerance; when
    # two objects last held the same track, the first in order keeps it.
    # hypotheses are row indices in increasing order, so a binary search finds each one.
    position = np.minimum(np.searchsorted(hypotheses, previous), max(n_h - 1, 0))
    keep = (previous != UNMATCHED) & (n_h > 0)
    if n_h:
        keep &= hypotheses[position] == previous
    keep[keep] = ~np.isnan(distance[keep, position[keep]])
    kept_o = np.flatnonzero(keep)
    _, first = np.unique(position[kept_o], return_index=True)
    kept_o = np.sort(kept_o[first])
    kept_h = position[kept_o]
    # Step 2: optimal assignment of the rest, most pairs first, then least total distance.
    free_o = np.setdiff1d(np.arange(n_o), kept_o)
    free_h = np.setdiff1d(np.arange(n_h), kept_h)
    sub = distance[np.ix_(free_o, free_h)]
    new_o = new_h = np.zeros(0, dtype=np.int64)
    valid = ~np.isnan(sub)
    if valid.any():
        # Any invalid pair must cost more than every valid pairing it could replace.
        large = 2 * min(sub.shape) * (np.nanmax(sub) + 1) + 1
        rows, cols = linear_sum_assignment(np.where(valid, sub, large))
        good = valid[rows, cols]
        new_o, new_h = free_o[rows[good]], free_h[cols[good]]
    switched_new = (previous[new_o] != UNMATCHED) & (previous[new_o] != hypotheses[new_h])
    pair_o = np.concatenate([kept_o, new_o])
    pair_h = np.concatenate([kept_h, new_h])
    return pair_o, pair_h, np.concatenate([np.zeros(kept_o.size, bool), switched_new])


def _fragmentations(tracked: np.ndarray) -> int:
    """Times a true track goes from tracked to missed between its first and last tracked frame."""
    count = 0
    for row in tracked:
        states = row[row != 0]
        hit = np.flatnonzero(states == 1)
        if hit.size == 0:
            continue
        span = states[hit[0] : hit[-1] + 1] == 2
        count += int(np.sum(~span[:-1] & span[1:]))
    return count


def _identity_true_positives(together: np.ndarray) -> int:
    """Largest number of co-located points over one-to-one pairings of true and result tracks."""
    if together.size == 0:
        return 0
    rows, cols = linear_sum_assignment(together, maximize=True)
    return int(together[rows, cols].sum())
