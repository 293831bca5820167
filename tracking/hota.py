"""HOTA, the higher-order tracking accuracy (Luiten et al., IJCV 2021), for points.

HOTA needs a similarity in [0, 1] between a true and a result point; for boxes it is their
overlap. For points we use ``S = max(0, 1 - d / tolerance)`` with ``d`` the distance, a
linear distance similarity as adaptations of HOTA to point tracking use: a point at the true
position scores 1, one at the tolerance 0. HOTA is then
computed as TrackEval (``trackeval.metrics.HOTA``, the reference code) computes it: for each
threshold alpha in 0.05, 0.10 ... 0.95, points are matched frame by frame by an optimal
assignment weighted by how often the two tracks coincide over the whole clip, matches with
``S >= alpha`` count, and

- DetA = TP / (TP + FN + FP), detection accuracy;
- AssA = mean over TP of TPA / (TPA + FNA + FPA), association accuracy, where TPA counts the
  matches between the same true and result track, FNA and FPA their remaining points;
- HOTA = sqrt(DetA * AssA); LocA = mean similarity of the matches.

The reported figures are the means over the 19 thresholds.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .point_pairs import near_pairs
from .tracks import Tracks

ALPHAS = np.arange(0.05, 0.99, 0.05)
_EPS = np.finfo(float).eps


@dataclass(frozen=True)
class HotaScores:
    """HOTA and its parts, each the mean over :data:`ALPHAS`; per-threshold values in ``*_alpha``.

    Attributes
    ----------
    hota, det_a, ass_a, loc_a : float
        In [0, 1].
    hota_alpha, det_a_alpha, ass_a_alpha, loc_a_alpha : ndarray, shape (19,)
    """

    hota: float
    det_a: float
    ass_a: float
    loc_a: float
    hota_alpha: np.ndarray
    det_a_alpha: np.ndarray
    ass_a_alpha: np.ndarray
    loc_a_alpha: np.ndarray


def hota(result: Tracks, truth: Tracks, tolerance: float = 3.0) -> HotaScores:
    """HOTA, DetA, AssA and LocA of ``result`` against ``truth``, with the similarity
    ``max(0, 1 - distance / tolerance)``.

    Parameters
    ----------
    result, truth : Tracks
        Frames aligned by their 0-based frame indices; every present point counts.
    tolerance : float
        Distance, pixels, at which the similarity reaches 0.

    Example
    -------
    >>> from seedtrack.tracking.tracks import Tracks
    >>> truth = Tracks.from_rows([0, 0], [0, 1], [0.0, 1.0], [5.0, 5.0])
    >>> round(hota(truth, truth).hota, 6)
    1.0
    """
    from scipy.optimize import linear_sum_assignment

    n_gt, n_tr = truth.point_track.size, result.point_track.size
    k = len(ALPHAS)
    if n_gt == 0 or n_tr == 0:
        zero = np.zeros(k)
        return HotaScores(0.0, 0.0, 0.0, 1.0, zero, zero, zero, np.ones(k))
    # Only pairs of positive similarity count anywhere: the others add nothing to the overlap
    # sums, and fail every threshold.
    pairs = near_pairs(result, truth, tolerance)
    similarity = 1.0 - pairs.distance / tolerance
    keep = similarity > 0
    t_point, r_point, similarity = pairs.truth_point[keep], pairs.result_point[keep], similarity[keep]
    t_track, r_track, frame = pairs.truth_track[keep], pairs.result_track[keep], pairs.frame[keep]

    # How often each true and result track coincide over the clip, each point pair weighted
    # by its similarity over the similarities its two points share with all others.
    denominator = np.bincount(t_point, similarity, n_gt)[t_point] + np.bincount(r_point, similarity, n_tr)[r_point] - similarity
    share = np.where(denominator > _EPS, similarity / np.where(denominator > _EPS, denominator, 1.0), 0.0)
    gt_count = np.bincount(truth.point_track, minlength=truth.n_tracks).astype(float)
    tr_count = np.bincount(result.point_track, minlength=result.n_tracks).astype(float)
    code = t_track * result.n_tracks + r_track
    track_pair, pair_of = np.unique(code, return_inverse=True)
    potential = np.bincount(pair_of, share, track_pair.size)
    pair_gt, pair_tr = np.divmod(track_pair, result.n_tracks)
    alignment = potential / (gt_count[pair_gt] + tr_count[pair_tr] - potential)

    tp, loc = np.zeros(k), np.zeros(k)
    matched_pairs: list[list[np.ndarray]] = [[] for _ in ALPHAS]
    bounds = np.flatnonzero(np.diff(frame)) + 1
    for members in np.split(np.arange(frame.size), bounds):
        if members.size == 0:
            continue
        rows, row_of = np.unique(t_point[members], return_inverse=True)
        cols, col_of = np.unique(r_point[members], return_inverse=True)
        score = np.zeros((rows.size, cols.size))
        score[row_of, col_of] = alignment[pair_of[members]] * similarity[members]
        lookup = np.full((rows.size, cols.size), -1)
        lookup[row_of, col_of] = members
        a_rows, a_cols = linear_sum_assignment(-score)
        chosen = lookup[a_rows, a_cols]
        chosen = chosen[chosen >= 0]
        for a, alpha in enumerate(ALPHAS):
            good = chosen[similarity[chosen] >= alpha - _EPS]
            tp[a] += good.size
            loc[a] += similarity[good].sum()
            matched_pairs[a].append(code[good])

    fn, fp = n_gt - tp, n_tr - tp
    ass_a = np.array([_association(np.concatenate(codes or [np.empty(0, np.int64)]), gt_count, tr_count, result.n_tracks) for codes in matched_pairs]) / np.maximum(1, tp)
    det_a = tp / np.maximum(1, tp + fn + fp)
    loc_a = np.maximum(1e-10, loc) / np.maximum(1e-10, tp)
    hota_alpha = np.sqrt(det_a * ass_a)
    return HotaScores(float(hota_alpha.mean()), float(det_a.mean()), float(ass_a.mean()), float(loc_a.mean()), hota_alpha, det_a, ass_a, loc_a)


def _association(codes: np.ndarray, gt_count: np.ndarray, tr_count: np.ndarray, n_result: int) -> float:
    """Sum over matches of TPA / (TPA + FNA + FPA), from the matched pairs' codes."""
    pair, matches = np.unique(codes, return_counts=True)
    gt, tr = np.divmod(pair, n_result)
    return float(np.sum(matches * matches / np.maximum(1, gt_count[gt] + tr_count[tr] - matches)))
