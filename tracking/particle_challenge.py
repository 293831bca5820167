"""The ISBI 2012 particle tracking challenge's measures (Chenouard et al., Nat Methods 2014).

True tracks are paired one to one with result tracks, or with a dummy track, so as to minimise
the summed track distance ``d(θ, ω) = Σ_t min(|θ(t) - ω(t)|, ε)``, the sum running over the
frames where either track has a point, a frame where only one has a point costing the gate
``ε``; pairing a true track with the dummy costs ``ε`` per true point. Then

- alpha = 1 - d(X, Y) / d(X, ∅): how well the true tracks are matched, spurious tracks ignored;
- beta = (d(X, ∅) - d(X, Y)) / (d(X, ∅) + d(Ȳ, ∅)), alpha penalised by the result tracks left
  unpaired (Ȳ, each costing ``ε`` per point);
- JSC = TP / (TP + FN + FP) over points, a true point being a TP when its paired result track
  has a point within ``ε`` (strictly nearer, as in the challenge's code) in the same frame;
- JSC_theta = the same over tracks: paired true tracks, true tracks left to the dummy, result
  tracks left unpaired;
- RMSE: root mean square distance of the TP points.

Differences from the challenge's tool, which reads a track as its span of frames: here a frame
where a track has no point is no point (the tool counts a virtual detection); and a result track
never within ``ε`` of a true track is not paired with it (pairing it would cost exactly as much
as the dummy, a tie the tool breaks either way).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .point_pairs import common_frames, near_pairs
from .tracks import Tracks


@dataclass(frozen=True)
class ChallengeScores:
    """The challenge's measures; alpha, beta, JSC, JSC_theta in [0, 1], RMSE in pixels (NaN
    when no point matches).

    Attributes
    ----------
    alpha, beta, jsc, jsc_theta, rmse : float
    paired_tracks : int
        True tracks paired with a result track.
    """

    alpha: float
    beta: float
    jsc: float
    jsc_theta: float
    rmse: float
    paired_tracks: int


def challenge_scores(result: Tracks, truth: Tracks, gate: float = 5.0) -> ChallengeScores:
    """alpha, beta, JSC, JSC_theta and RMSE of ``result`` against ``truth``.

    Parameters
    ----------
    result, truth : Tracks
        Frames aligned by their 0-based frame indices; every present point counts.
    gate : float
        ε, pixels: the largest distance a point pair costs, and the matching distance
        (the challenge used 5 pixels).

    Example
    -------
    >>> from seedtrack.tracking.tracks import Tracks
    >>> truth = Tracks.from_rows([0, 0], [0, 1], [0.0, 1.0], [5.0, 5.0])
    >>> challenge_scores(truth, truth).alpha
    1.0
    """
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import min_weight_full_bipartite_matching

    n_true = np.bincount(truth.point_track, minlength=truth.n_tracks).astype(float)
    n_found = np.bincount(result.point_track, minlength=result.n_tracks).astype(float)
    # Only track pairs with a point pair nearer than the gate may be paired; for them the
    # distance is gate * (points not in a common frame + far common points) + near distances,
    # counted here in units of the gate, so that any finite gate (1e300 too) keeps it finite.
    pairs = near_pairs(result, truth, gate)
    near = pairs.distance < gate
    code = pairs.truth_track[near] * result.n_tracks + pairs.result_track[near]
    track_pair, pair_of = np.unique(code, return_inverse=True)
    within = np.bincount(pair_of, minlength=track_pair.size).astype(float)
    summed = np.bincount(pair_of, pairs.distance[near], track_pair.size)
    squared = np.bincount(pair_of, pairs.distance[near] ** 2, track_pair.size)
    t_track, r_track = np.divmod(track_pair, result.n_tracks)
    common = common_frames(result, truth, t_track, r_track)
    pair_cost = (n_true[t_track] + n_found[r_track] - common - within) + summed / gate

    # Rows: true tracks with points; columns: result tracks, then one dummy per such true track.
    # Every row takes exactly one edge, so adding 1 to all (the graph needs weights > 0) keeps
    # the optimum.
    real = np.flatnonzero(n_true > 0)
    row_of = np.full(truth.n_tracks, -1)
    row_of[real] = np.arange(real.size)
    dummy = result.n_tracks + np.arange(real.size)
    graph = csr_matrix(
        (np.concatenate([pair_cost, n_true[real]]) + 1.0, (np.concatenate([row_of[t_track], np.arange(real.size)]), np.concatenate([r_track, dummy]))),
        shape=(real.size, result.n_tracks + real.size),
    )
    rows, cols = min_weight_full_bipartite_matching(graph) if real.size else (np.empty(0, int), np.empty(0, int))
    paired = cols < result.n_tracks
    chosen = np.searchsorted(track_pair, real[rows[paired]] * result.n_tracks + cols[paired])

    worst = n_true.sum()
    distance = pair_cost[chosen].sum() + n_true[real[rows[~paired]]].sum()
    unpaired_found = np.ones(result.n_tracks, bool)
    unpaired_found[cols[paired]] = False
    spurious = n_found[unpaired_found].sum()
    tp = within[chosen].sum()
    fn = n_true.sum() - tp
    fp = n_found.sum() - tp
    found_tracks = int(np.count_nonzero(n_found))
    n_paired = int(paired.sum())
    return ChallengeScores(
        alpha=float(1.0 - distance / worst) if worst else float("nan"),
        beta=float((worst - distance) / (worst + spurious)) if worst else float("nan"),
        jsc=float(tp / (tp + fn + fp)) if tp + fn + fp else float("nan"),
        jsc_theta=float(n_paired / (real.size + found_tracks - n_paired)) if real.size + found_tracks else float("nan"),
        rmse=float(np.sqrt(squared[chosen].sum() / tp)) if tp else float("nan"),
        paired_tracks=n_paired,
    )
