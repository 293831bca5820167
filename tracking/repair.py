"""Near crossings decided over five frames: swaps between two tracks that the next frames refute.

When two points pass within a pixel or two of each other, one frame step cannot tell which
went where: both pairings cost about the same, and a frame-by-frame assignment may swap them,
for one frame (the tracks zigzag and come back) or for good (each continues the other's path).
The frames after the crossing do tell: a wrong pairing leaves both tracks with a kink. This
looks at every pair of tracks whose points in a frame lie closer than the model's noise allows
telling apart, and compares, over the five frames around it (Veenman, Reinders and Backer's
extended temporal scope, reduced to pairs), the links as they are with the two points
exchanged in that frame alone and with the tails exchanged from that frame on or from the next;
the pairing whose velocity changes are most likely under the measured motion
(:class:`seedtrack.tracking.persistence.MotionStatistics`, its noise along and across the
velocity apart: speed steps and turns) is kept. A track whose velocity
kinks in a frame is also paired with every track near it there, out to the final pass's gate:
after a wrong link nearby it may hold a neighbour's point that was never close to its own.
Pairs are found with a KD-tree per frame, so the work grows with the number of close
encounters and kinks, not with the square of the tracks.
"""

from __future__ import annotations

import heapq

import numpy as np

from .initialisation import pairs_within, shared_trees, tree_of
from .persistence import MotionStatistics, _predicted, _turned
from .tracks import NO_MEASUREMENT, Tracks

# Frames either side of the encounter whose velocity changes are compared.
_REACH = 2
# Two points are an encounter when closer than this many noise sigmas (at their speed).
_ENCOUNTER_SIGMAS = 3.0
# A track whose velocity changes beyond the encounter distance at k is paired with the tracks
# whose points lie within this many of its noise sigmas: the final pass's gate
# (adaptive.MEASURED_MOTION_GATE_SIGMAS), the farthest a point it took can be from its prediction.
_KINK_REACH = 9.0
# An exchange is made only if it makes the window this much more likely (log-likelihood units),
# so that rounding never flips a tie.
_MARGIN = 1e-6
_SWEEPS = 2
# Pairs weighed again one at a time (after an exchange changed one of their tracks), at most this
# share of the measured points over the whole repair; beyond it such pairs wait for the next sweep
# or are left. In a swarm whose nearest neighbour is within a step (150 points in 80 px, 3,000
# points a clip) every track kinks near many others: 6,500 pairs were weighed one at a time, 28 of
# 32 s of CPU, where scenes of that size take about a second.
_REWEIGHED_SHARE = 0.1


def resolve_crossings(tracks: Tracks, statistics: MotionStatistics) -> Tracks:
    """``tracks`` with the pairings at close encounters that the frames around them favour.

    Parameters
    ----------
    tracks : Tracks
        Tracks in image coordinates (pixels), as a tracker returns them.
    statistics : MotionStatistics
        The motion measured on them (forward in time).

    Returns
    -------
    Tracks
        The same points, some exchanged between tracks (a point alone, or a track's tail from
        that frame on, interpolated positions with it); track ids and order as before.

    Example
    -------
    >>> x = np.arange(7.0)
    >>> straight = np.stack([np.column_stack((x, 0.3 * (x - 3))), np.column_stack((x, -0.3 * (x - 3)))])
    >>> swapped = straight.copy(); swapped[:, 4:] = straight[::-1, 4:]
    >>> stats = MotionStatistics(1.0, 0.1, 0.0, (0.0, 0.0), 1.0, 100)
    >>> fixed = resolve_crossings(Tracks.from_dense(swapped, np.zeros((2, 7), np.int64)), stats)
    >>> bool(np.allclose(fixed.xy, straight))
    True
    """
    n_tracks, n_frames = tracks.n_tracks, tracks.n_frames
    if n_tracks < 2 or n_frames < 3:
        return tracks
    # Dense arrays of its own rather than copies of the cached views, and the tracks let go: on a
    # million points the views and the point arrays were 65 MB held through the repair and the
    # new track set, the peak of seedtrack track.
    xy = np.full((n_tracks, n_frames, 2), np.nan)
    xy[tracks.point_track, tracks.point_column] = tracks.point_xy
    measurement = np.full((n_tracks, n_frames), NO_MEASUREMENT, dtype=np.int64)
    measurement[tracks.point_track, tracks.point_column] = tracks.point_measurement
    first_frame, track_ids = tracks.first_frame, tracks.track_ids
    del tracks
    measured = measurement != NO_MEASUREMENT
    drift = np.asarray(statistics.drift)
    budget = int(_REWEIGHED_SHARE * np.count_nonzero(measured))
    for _ in range(_SWEEPS):
        changed = False
        for k in range(n_frames):
            rows = np.flatnonzero(measured[:, k])
            if rows.size < 2:
                continue
            # Each track's speed at k, from its step into k (or out of it), sets its noise.
            into = measured[rows, k - 1] if k else np.zeros(rows.size, bool)
            out = measured[rows, k + 1] if k + 1 < n_frames else np.zeros(rows.size, bool)
            step = np.zeros((rows.size, 2))
            if out.any():
                step[out] = xy[rows[out], k + 1] - xy[rows[out], k] - drift
            if into.any():
                step[into] = xy[rows[into], k] - xy[rows[into], k - 1] - drift
            sigma = np.sqrt(statistics.noise**2 + statistics.relative**2 * np.einsum("ij,ij->i", step, step))
            here = xy[rows, k]
            # A track that changes its velocity at k beyond the encounter distance may hold a
            # neighbour's point there (taken after a wrong link nearby): its pairs reach to the gate.
            both = np.flatnonzero(into & out)
            change = np.zeros((0, 2)) if not both.size else xy[rows[both], k + 1] - xy[rows[both], k] - drift - statistics.persistence * _turned(step[both], statistics.turn)
            kinked = both[np.hypot(*change.T) > _ENCOUNTER_SIGMAS * sigma[both]]
            # One tree of the frame's points serves both searches, let go after them: built twice,
            # trees were a third of the repair at 10,000 points a frame.
            with shared_trees():
                pairs = [tree_of(here).query_pairs(_ENCOUNTER_SIGMAS * float(sigma.max()), output_type="ndarray")]
                if kinked.size:
                    owner, near = pairs_within(here[kinked], _KINK_REACH * sigma[kinked], here)
                    pairs.append(np.column_stack((kinked[owner], near))[kinked[owner] != near])
            if not any(p.size for p in pairs):
                continue
            # Each pair once, smaller index first, in order: as one number per pair, which sorts
            # as the pairs do (np.unique over rows gives the same, several times slower).
            ordered = np.sort(np.concatenate(pairs), axis=1)
            key = np.unique(ordered[:, 0] * rows.size + ordered[:, 1])
            a, b = key // rows.size, key % rows.size
            i, j = rows[a], rows[b]
            is_kinked = np.zeros(rows.size, bool)
            is_kinked[kinked] = True
            kink = is_kinked[a] | is_kinked[b]
            close = np.hypot(*(xy[i, k] - xy[j, k]).T) <= _ENCOUNTER_SIGMAS * np.maximum(sigma[a], sigma[b])
            # Every pair weighed at once on the tracks as they are; one after another, as an
            # exchange changes its two tracks, pairs that hold one of them are weighed again.
            weighed = np.flatnonzero(close | kink)
            if not weighed.size:
                continue
            now, best, spans = _pairings(xy, measured, i[weighed], j[weighed], k, statistics)
            exchanged: set[int] = set()
            # Only the pairs that gain by an exchange, and those after an exchange that hold one
            # of its tracks, can change anything: the others are passed over, in order (the
            # swarm's thousands of pairs a frame went one by one through Python).
            first_i, first_j = i[weighed], j[weighed]
            visit = list(np.flatnonzero(best < now - _MARGIN))
            heapq.heapify(visit)
            seen = -1
            # Pairs weighed again on the tracks as they are now, by their place in ``visit``.
            fresh: dict[int, tuple] = {}
            while visit:
                p = heapq.heappop(visit)
                if p <= seen:
                    continue
                seen, q = p, weighed[p]
                pair = (int(i[q]), int(j[q]))
                if exchanged.intersection(pair):
                    if budget <= 0 or not (kink[q] or np.hypot(*(xy[pair[0], k] - xy[pair[1], k])) <= _ENCOUNTER_SIGMAS * max(sigma[a[q]], sigma[b[q]])):
                        continue
                    budget -= 1
                    if p not in fresh:
                        # Weighed together with the pairs still to visit that hold an exchanged
                        # track, as many as the budget allows: until the next exchange the tracks
                        # stay as they are (a swarm's pairs were weighed one call each).
                        pending = sorted({r for r in visit if r > p and exchanged.intersection((int(first_i[r]), int(first_j[r])))})
                        batch = np.array([p, *pending[:budget]])
                        fresh = dict(zip(batch.tolist(), zip(*_pairings(xy, measured, first_i[batch], first_j[batch], k, statistics))))
                    pair_now, pair_best, span = fresh[p]
                else:
                    pair_now, pair_best, span = now[p], best[p], spans[p]
                if pair_best < pair_now - _MARGIN:
                    for array in (xy, measurement, measured):
                        array[pair, span[0] : span[1]] = array[pair[::-1], span[0] : span[1]]
                    exchanged.update(pair)
                    fresh = {}
                    changed = True
                    later = p + 1 + np.flatnonzero(np.isin(first_i[p + 1 :], pair) | np.isin(first_j[p + 1 :], pair))
                    for r in later.tolist():
                        heapq.heappush(visit, r)
        if not changed:
            break
    del measured
    return Tracks.from_dense(xy, measurement, first_frame, track_ids)


def _pairings(xy, measured, i: np.ndarray, j: np.ndarray, k: int, statistics: MotionStatistics):
    """For the pairs of tracks (i[p], j[p]) about frame k: the cost of the frames around k as
    they are, and of the cheapest exchange of their points at k alone or of their tails from k or
    from k + 1 (the links into k or out of k crossed), with its frames (start, end)."""
    n_frames = xy.shape[1]
    low, high = max(k - _REACH - 1, 0), min(k + _REACH + 3, n_frames)
    pair_xy = np.stack((xy[i, low:high], xy[j, low:high]), axis=1)
    pair_seen = np.stack((measured[i, low:high], measured[j, low:high]), axis=1)
    # In this order, so that of equally cheap exchanges the one of the fewest frames is taken (k
    # is a frame, so the first is always there).
    spans = [(start, end) for start, end in ((k, k + 1), (k, n_frames), (k + 1, n_frames)) if start < n_frames]
    # The pairings as they are and each exchange weighed in one call, stacked along the pairs: a
    # call per pairing was a quarter of the linking CPU on the held-out scenes (about a hundred
    # points a frame), most of it numpy's cost per call.
    trial_xy = np.tile(pair_xy, (len(spans) + 1, 1, 1, 1))
    trial_seen = np.tile(pair_seen, (len(spans) + 1, 1, 1))
    for n, (start, end) in enumerate(spans, start=1):
        rows, frames = slice(n * len(i), (n + 1) * len(i)), slice(start - low, min(end, high) - low)
        trial_xy[rows, :, frames] = pair_xy[:, ::-1, frames]
        trial_seen[rows, :, frames] = pair_seen[:, ::-1, frames]
    every = _window_costs(trial_xy, trial_seen, statistics).reshape(len(spans) + 1, len(i))
    now, costs = every[0], every[1:].T
    choice = np.argmin(costs, axis=1)
    return now, costs[np.arange(len(i)), choice], [spans[c] for c in choice]


def _window_costs(xy: np.ndarray, seen: np.ndarray, statistics: MotionStatistics) -> np.ndarray:
    """Negative log-likelihood of the velocity changes of pairs of tracks (P, 2, w, 2) over a
    window: on triplets of consecutive measured points, on links across missed frames
    (:func:`_bridge_costs`) and, for a step with no step before
    it (a track's first, the window's, or the first after a missed frame), against the drift
    with the spread of the velocities as a head with no velocity is: every link of the window
    is weighed, so no exchange wins by leaving one out. (A triplet lacking used to count as a
    change at the gate instead; on Brownian points 10% missed that moved the missed frames of
    two tracks onto one, taking a neighbour's point across the gap: strict merit on tuning
    seeds 0-9 0.570 against 0.584 without it.)"""
    step = np.diff(xy, axis=2) - np.asarray(statistics.drift)
    linked = seen[..., 1:] & seen[..., :-1]
    both = linked[..., 1:] & linked[..., :-1]
    before, after = step[:, :, :-1], step[:, :, 1:]
    change = after - statistics.persistence * _turned(before.reshape(-1, 2), statistics.turn).reshape(before.shape)
    with np.errstate(invalid="ignore", divide="ignore"):  # unmeasured positions are NaN, and left out by the masks
        triplets = np.where(both, _change_cost(before, change, statistics), 0.0)
    opening = linked.copy()
    opening[..., 1:] &= ~linked[..., :-1]
    spread2 = statistics.spread**2 + statistics.noise**2
    first = np.where(opening, np.einsum("...i,...i->...", step, step), 0.0).sum(axis=(1, 2))
    return (
        triplets.sum(axis=(1, 2)) + first / (2.0 * spread2) + opening.sum(axis=(1, 2)) * np.log(spread2)
        + _bridge_costs(xy, seen, statistics)
    )


def _bridge_costs(xy: np.ndarray, seen: np.ndarray, statistics: MotionStatistics) -> np.ndarray:
    """Negative log-likelihood, per pair of tracks (P, 2, w, 2), of the links across missed frames
    in the window, as the final pass weighs them (:meth:`PersistentModel.cost`: the velocity over
    the gap from the one before it, or from the drift with the spread of the velocities, its
    variance grown with the gap, the density of a position over g frames g**2 times thinner).
    Left out, an exchange of tails after a missed point was judged by the other track's link
    alone, and on Brownian points 10% missed it gave a track whose point was missed its
    neighbour's (the bridge it left the other track was never weighed)."""
    s = statistics
    drift = np.asarray(s.drift)
    total = np.zeros(xy.shape[0])
    width = xy.shape[2]
    # Frames from each measured point to its track's next measured one (width for none): every
    # bridge found at once, and only the gaps that occur looked at (most windows have none;
    # masks of the missed frames, gap by gap, were a quarter of the repair on a swarm).
    if seen.all():
        return total
    frame = np.arange(width)
    following = np.minimum.accumulate(np.where(seen, frame, width)[..., :0:-1], axis=-1)[..., ::-1]
    span = np.where(seen[..., :-1] & (following < width), following - frame[:-1], 0)
    for gap in np.unique(span[span >= 2]).tolist():
        # Measured at j and j + gap, missed in between.
        pair, track, j = np.nonzero(span == gap)
        velocity = (xy[pair, track, j + gap] - xy[pair, track, j]) / gap - drift
        known = (j > 0) & seen[pair, track, np.maximum(j - 1, 0)]
        before = np.where(known[:, None], xy[pair, track, j] - xy[pair, track, np.maximum(j - 1, 0)] - drift, 0.0)
        growth = s.gap_growth(float(gap))
        speed2 = np.einsum("ij,ij->i", before, before)
        variance = np.where(known, s.noise**2 + s.relative**2 * speed2, s.spread**2 + s.noise**2) * growth
        residual = velocity - _predicted(before, np.full(j.size, gap), np.ones(j.size, np.int64), s.persistence, s.turn)
        cost = np.einsum("ij,ij->i", residual, residual) / (2.0 * variance) + np.log(variance) + 2.0 * np.log(gap)
        np.add.at(total, pair, cost)
    return total


def _change_cost(before: np.ndarray, change: np.ndarray, statistics: MotionStatistics) -> np.ndarray:
    """Twice the negative log-likelihood of velocity changes (..., 2) after velocities ``before``
    (..., 2), under the noise along and across ``before`` where it was measured apart: at a near
    crossing of PSMG-like motion the two pairings differ mostly in one of the two."""
    b0, b1, c0, c1 = before[..., 0], before[..., 1], change[..., 0], change[..., 1]
    speed2 = b0 * b0 + b1 * b1
    squared = c0 * c0 + c1 * c1
    if statistics.along is None or statistics.across is None:
        variance = statistics.noise**2 + statistics.relative**2 * speed2
        return squared / (2.0 * variance) + np.log(variance)
    along = statistics.along[0] ** 2 + statistics.along[1] ** 2 * speed2
    across = statistics.across[0] ** 2 + statistics.across[1] ** 2 * speed2
    # The change's parts along and across ``before``, times its speed: no unit vector is formed.
    dot, cross = b0 * c0 + b1 * c1, b0 * c1 - b1 * c0
    moving = speed2 > 0
    # A point at rest has no direction: its change is scored on the mean of the two variances.
    still = squared / (along + across)
    return np.where(moving, (dot * dot / along + cross * cross / across) / (2.0 * np.where(moving, speed2, 1.0)), still) + 0.5 * np.log(along * across)


__all__ = ["resolve_crossings"]
