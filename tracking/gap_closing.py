"""Gap filling after the passes: extend track ends, pair the points seen in two frames only at
the view's edge, and join a track that ends to a track that starts a few frames later when they
are one object.

A track opens only from a run of measured frames, so the first point of a track that starts
badly placed for its first links stays free; :func:`extend_track_ends` gives it back. A point
in view for two frames only has no third to open a track with; :func:`pair_at_view_edge` makes
it a track where no third frame could have shown it.
:func:`join_track_ends` is IPAN's post-processing idea, in GOA's terms: the end of track A (its last measured point and
velocity) is joined to the start of track B (first point and velocity) across ``gap`` missed
frames when both moves through the bridge, from A's velocity to the bridging velocity and from
it to B's, pass the individual motion model within phi_max. A join costs the two links' costs
plus phi_max for every missed frame (the cost of a slave), so short, smooth bridges win; the
joins are chosen together by one optimal assignment of ends to starts. With a measured motion
model a join is made only where it is likelier than the end and the start being two objects
(:meth:`seedtrack.tracking.persistence.PersistentModel.join_costs`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np
from scipy.spatial import cKDTree

from .assignment import UNASSIGNED, solve_split
from .goa import GOAConfig, HeadState, assign_step
from .motion import Candidates
from .tracks import Tracks

# Missed frames in a row across which a track end takes a free measurement after the passes. In the
# passes a head back from slaves keeps its point only if a point continues it in one of the next two
# frames (lifecycle.EndTracks.confirm_returns); a true point whose next two are missed, or that
# comes back in the clip's last frames, was left on no track, and its trajectory broken. Chosen on
# tuning seeds among 0, 1, 2 and 3: on Brownian points of diffusion 0.5 to 3 px, 15% missed (seeds
# 0-9), strict merit 0.369, 0.396, 0.401, 0.406; with 10% missed 0.568, 0.584, -, 0.593; but on
# bead-like walkers with satellites (bench_beads.py, seeds 0-2) 3 took the link error from 0.0274 to
# 0.0280 where 1 kept 0.0275 (reproduced 0.632 -> 0.651), as ends took satellites across the gap.
_EXTEND_ACROSS = 1
# A bridge that passes within this distance (pixels) of a measured point another track holds in
# one of its missed frames goes through that point: the object was not missed there, and the
# end and the start are two tracks taking turns at one object or two objects joined across it.
# Half a pixel: rounded to whole pixels, a point and one off it by less round to the same pixel.
_ON_POINT = 0.5


@dataclass(frozen=True)
class FillGaps:
    """Gap filling: both ends of every track extended, pairs of free points at the view's edge
    made tracks, then (with ``join``) track ends joined to track starts at most ``max_gap``
    frames later."""

    max_gap: int = 10
    join: bool = True

    def fill(self, frames: Sequence[np.ndarray], assignment: np.ndarray, config: GOAConfig) -> np.ndarray:
        """The tracks of ``assignment`` (measurement index per track and frame, -1 for none)
        with their ends extended and their gaps joined."""
        assignment = extend_track_ends(frames, assignment, config)
        assignment = extend_track_ends(frames[::-1], assignment[:, ::-1], config)[:, ::-1]
        assignment = pair_at_view_edge(frames, assignment, config)
        if self.join:
            assignment = join_track_ends(frames, assignment, config, self.max_gap)
        return assignment


def extend_track_ends(frames: Sequence[np.ndarray], assignment: np.ndarray, config: GOAConfig) -> np.ndarray:
    """Extend track ends frame by frame with the measurements no track holds, when they continue
    the motion (one GOA step per frame among the tracks that end just before it, or one missed
    frame before it).

    Parameters
    ----------
    frames : sequence of ndarray, each (M_k, 2)
        Measurement positions per frame, pixels, in the order the ends are extended.
    assignment : ndarray of int, shape (n_tracks, n_frames)
        Measurement index per track and frame, -1 where none.
    config : GOAConfig

    Returns
    -------
    ndarray of int, shape (n_tracks, n_frames)

    Example
    -------
    A track whose point is missed in frame 3 takes the free point of frame 4 that continues it:

    >>> frames = [np.array([[10.0 + 2 * k, 10.0]]) for k in range(5)]
    >>> frames[3] = np.empty((0, 2))
    >>> extend_track_ends(frames, np.array([[0, 0, 0, -1, -1]]), GOAConfig(d_max=5.0)).tolist()
    [[0, 0, 0, -1, 0]]
    """
    assignment = assignment.copy()
    n = len(frames)
    held = assignment != UNASSIGNED
    free = [np.ones(f.shape[0], bool) for f in frames]
    for k in range(n):
        free[k][assignment[held[:, k], k]] = False
    # Each track's newest measured frame and the one before it (-1 for none).
    frame = np.arange(n)
    last = np.where(held, frame, -1).max(axis=1)
    before = np.where(held & (frame < last[:, None]), frame, -1).max(axis=1)
    del held
    # Every frame's points in one array, each frame from its offset: a head's points are looked up
    # at once (frame by frame they took a unique and a loop at every step).
    everything = np.concatenate([np.asarray(f, dtype=float).reshape(-1, 2) for f in frames])
    offset = np.concatenate(([0], np.cumsum([len(f) for f in frames])))
    for k in range(2, n):
        heads = np.flatnonzero((last < k) & (last >= k - 1 - _EXTEND_ACROSS) & (before >= 0))
        index = np.flatnonzero(free[k])
        if heads.size == 0 or index.size == 0:
            continue
        newest = everything[offset[last[heads]] + assignment[heads, last[heads]]]
        span = last[heads] - before[heads]
        velocity = (newest - everything[offset[before[heads]] + assignment[heads, before[heads]]]) / span[:, None]
        state = HeadState(newest, last[heads].copy(), velocity, span)
        taken = assign_step(state, k, frames[k][index], config)
        got = taken != UNASSIGNED
        assignment[heads[got], k] = index[taken[got]]
        free[k][index[taken[got]]] = False
        before[heads[got]] = last[heads[got]]
        last[heads[got]] = k
    return assignment


def pair_at_view_edge(frames: Sequence[np.ndarray], assignment: np.ndarray, config: GOAConfig) -> np.ndarray:
    """Two-point tracks for free measurements of consecutive frames that no third frame could
    confirm: where a point is seen in two frames only because it entered or left the view, or
    the clip begins or ends.

    A track opens on three measured frames in a row, so that a false detection does not open
    one; but a point in view for two frames has no third to show. Each free measurement of
    frame k is linked to the free measurements of frame k + 1 by one GOA step (heads with no
    velocity yet, as first links are gated), and a link makes a track only when the region
    where the model would look for the point in frame k - 1, and the one in frame k + 2, each
    reaches outside that frame's measured view (the bounding box of its measurements) or lies
    outside the clip. Inside the view a missing third point is evidence against the pair.

    Parameters
    ----------
    frames : sequence of ndarray, each (M_k, 2)
        Measurement positions per frame, pixels.
    assignment : ndarray of int, shape (n_tracks, n_frames)
        Measurement index per track and frame, -1 where none.
    config : GOAConfig

    Returns
    -------
    ndarray of int, shape (n_tracks + n_pairs, n_frames)
        ``assignment`` with one row per pair added, in frame order.

    Examples
    --------
    A point at the left edge for frames 1 and 2 of 4, beside one tracked all along:

    >>> frames = [np.array([[50.0, 50.0]]), np.array([[51.0, 50.0], [1.0, 20.0]]),
    ...           np.array([[52.0, 50.0], [0.0, 21.0]]), np.array([[53.0, 50.0]])]
    >>> pair_at_view_edge(frames, np.zeros((1, 4), np.int64), GOAConfig(d_max=3.0)).tolist()
    [[0, 0, 0, 0], [-1, 1, 1, -1]]
    """
    n = len(frames)
    held = assignment != UNASSIGNED
    free = [np.ones(f.shape[0], bool) for f in frames]
    for k in range(n):
        free[k][assignment[held[:, k], k]] = False
    rows = [assignment]
    # No gate reaches past the speed limit: where every free point of frame k, or of k + 1, lies
    # that far inside the view, no pair can make a track, and the step is not made.
    limit = config.speed.d_max
    for k in range(n - 1):
        first, second = np.flatnonzero(free[k]), np.flatnonzero(free[k + 1])
        if first.size == 0 or second.size == 0:
            continue
        if limit is not None and not (
            _reaches_out(frames, k - 1, frames[k][first], np.full(first.size, limit)).any()
            and _reaches_out(frames, k + 2, frames[k + 1][second], np.full(second.size, limit)).any()
        ):
            continue
        state = HeadState(frames[k][first], np.full(first.size, k), np.full((first.size, 2), np.nan))
        taken = assign_step(state, k + 1, frames[k + 1][second], config)
        linked = taken != UNASSIGNED
        a, b = first[linked], second[taken[linked]]
        speed = np.hypot(*(frames[k + 1][b] - frames[k][a]).T)
        reach = config.speed.reach(config.individual.gate_radius(speed, np.ones(speed.size, bool), config.phi_max))
        unconfirmable = _reaches_out(frames, k - 1, frames[k][a], reach) & _reaches_out(frames, k + 2, frames[k + 1][b], reach)
        pairs = np.full((int(unconfirmable.sum()), n), UNASSIGNED, dtype=np.int64)
        pairs[:, k], pairs[:, k + 1] = a[unconfirmable], b[unconfirmable]
        free[k + 1][b[unconfirmable]] = False
        rows.append(pairs)
    # Joined only when there is something to add: on long clips the assignment is large.
    return np.concatenate(rows) if any(r.shape[0] for r in rows[1:]) else assignment


def _reaches_out(frames: Sequence[np.ndarray], k: int, points: np.ndarray, reach: np.ndarray) -> np.ndarray:
    """Boolean per point: the disc of radius ``reach`` (pixels) about it is not all inside the
    bounding box of ``frames[k]``'s measurements, or frame k is outside the clip or empty."""
    if not 0 <= k < len(frames) or frames[k].shape[0] == 0:
        return np.ones(points.shape[0], bool)
    low, high = frames[k].min(axis=0), frames[k].max(axis=0)
    return ((points - reach[:, None] < low) | (points + reach[:, None] > high)).any(axis=1)


def _ends(frames: Sequence[np.ndarray], assignment: np.ndarray, reverse: bool) -> tuple[np.ndarray, ...]:
    """Per track: frame, position and velocity (pixels/frame, pointing forwards in time) of its
    last measured point, or of its first when ``reverse``; NaN velocity for one-point tracks."""
    n_tracks, n = assignment.shape
    held = assignment != UNASSIGNED
    frame = np.arange(n)
    if reverse:
        outer = np.where(held, frame, n).min(axis=1)
        inner = np.where(held & (frame > outer[:, None]), frame, n).min(axis=1)
    else:
        outer = np.where(held, frame, -1).max(axis=1)
        inner = np.where(held & (frame < outer[:, None]), frame, -1).max(axis=1)
    everything = np.concatenate([np.asarray(f, dtype=float).reshape(-1, 2) for f in frames] + [np.full((1, 2), np.nan)])
    offset = np.concatenate(([0], np.cumsum([len(f) for f in frames])))
    xy = []
    for column in (outer, inner):
        ok = (column >= 0) & (column < n)
        at = np.where(ok, column, 0)
        xy.append(everything[np.where(ok, offset[at] + assignment[np.arange(n_tracks), at], -1)])
    # (outer - inner) is negative at a start, so the velocity points forwards in time either way.
    return outer, xy[0], (xy[0] - xy[1]) / (outer - inner)[:, None]


def join_track_ends(frames: Sequence[np.ndarray], assignment: np.ndarray, config: GOAConfig, max_gap: int) -> np.ndarray:
    """Join track ends to later track starts across at most ``max_gap`` missed frames.

    Parameters
    ----------
    frames : sequence of ndarray, each (M_k, 2)
        Measurement positions per frame, pixels.
    assignment : ndarray of int, shape (n_tracks, n_frames)
        Measurement index per track and frame, -1 where none.
    config : GOAConfig
        The motion model, phi_max and the speed limits.
    max_gap : int
        Longest bridge, in missed frames (0 joins only a track that ends right before another starts).

    Returns
    -------
    ndarray of int, shape (n_joined, n_frames)
        The joined tracks, each in the row of its earliest part; the bridged frames hold -1.
    """
    n_tracks, n = assignment.shape
    if n_tracks < 2:
        return assignment
    last, end_xy, end_velocity = _ends(frames, assignment, reverse=False)
    first, start_xy, start_velocity = _ends(frames, assignment, reverse=True)
    usable = ~np.isnan(end_velocity[:, 0]) & ~np.isnan(start_velocity[:, 0])
    order = np.flatnonzero(usable)[np.argsort(first[usable], kind="stable")]
    # Starts of each end's candidates are contiguous in ``order``: first frames last+1..last+1+max_gap.
    ends = np.flatnonzero(usable)
    low = np.searchsorted(first[order], last[ends] + 1, side="left")
    high = np.searchsorted(first[order], last[ends] + 2 + max_gap, side="left")
    count = high - low
    end = np.repeat(ends, count)
    start = order[np.repeat(low, count) + np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)]
    gap = first[start] - last[end]  # frames the bridge spans, missed frames + 1

    bridge = Candidates(end, start, start_xy[start] - end_xy[end], gap, end_velocity[end])
    bridge = bridge.subset(config.speed.admits(bridge.velocity))
    end, start, gap = bridge.head, bridge.measurement, bridge.gap
    # Both moves, into the bridge and out of it, are scored on the bridges' scale.
    scale = config.speed.scale(bridge.velocity)
    leaving = Candidates(end, start, start_velocity[start], np.ones_like(gap), bridge.velocity)
    odds = config.individual.join_costs(bridge, leaving) if hasattr(config.individual, "join_costs") else None
    if odds is None:
        into = config.individual.cost(bridge, config.phi_max, scale)
        out = config.individual.cost(leaving, config.phi_max, scale)
        valid = (into <= config.phi_max) & (out <= config.phi_max)
    else:
        # A measured model weighs each join against the end and the start being two objects,
        # within its gate: a join is made when it is the likelier, the likeliest set together.
        # The gate holds the motion alone: the misses are weighed in the odds, and in the cost
        # as well they put every seed hidden for 5 frames on a turning dish beyond the gate
        # (the miss chance of seeds missed nowhere else is Laplace's 1 / points).
        valid = config.individual.within_gate(bridge) & config.individual.within_gate(leaving) & (odds < 0)
    # A bridge through a point another track holds is no miss: the object was seen there.
    valid[valid] = ~_through_held(lambda k: frames[k][assignment[:, k][assignment[:, k] != UNASSIGNED]], last[end[valid]], end_xy[end[valid]], start_xy[start[valid]], gap[valid])
    if odds is not None:
        end, start, weight = end[valid], start[valid], odds[valid]
        unmatched = -float(weight.min(initial=0.0)) / 2
        weight = weight + 2 * unmatched
        return _chain(assignment, solve_split(n_tracks, n_tracks, end, start, weight, unmatched))
    end, start, gap = end[valid], start[valid], gap[valid]
    weight = into[valid] + out[valid] + (gap - 1) * config.phi_max
    # Leaving an end and a start apart costs more than any valid join, so every join that does
    # not compete with a better one is made.
    unmatched = (2 + max_gap) * config.phi_max / 2
    successor = solve_split(n_tracks, n_tracks, end, start, weight, unmatched)
    return _chain(assignment, successor)


def split_through_held(tracks: Tracks) -> Tracks:
    """``tracks`` split at every run of filled-in points one of which lies on a measured point
    another track holds: the object was seen there, so the parts either side are not one
    object missed (two tracks taking turns at one object, or two objects).

    Parameters
    ----------
    tracks : Tracks

    Returns
    -------
    Tracks
        ``tracks`` itself when nothing is split; otherwise the split runs' filled-in points are
        gone and each part after one is a track of its own, right after the part before it.

    Example
    -------
    One walker whose points two tracks took in turns: each fills its missed frames with points
    on the other's, so every part is one point.

    >>> from seedtrack.tracking.tracks import tracks_from_assignment
    >>> frames = [np.array([[float(k), 0.0]]) for k in range(5)]
    >>> turns = tracks_from_assignment(frames, np.array([[0, -1, 0, -1, 0], [-1, 0, -1, 0, -1]]))
    >>> turns.interpolated.sum(), split_through_held(turns).n_tracks, split_through_held(turns).interpolated.sum()
    (np.int64(3), 5, np.int64(0))
    """
    filled = np.flatnonzero(tracks.point_interpolated)
    if filled.size == 0:
        return tracks
    measured = np.flatnonzero(~tracks.point_interpolated)
    column = tracks.point_column[measured]
    by_column = measured[np.argsort(column, kind="stable")]
    bounds = np.searchsorted(tracks.point_column[by_column], np.arange(tracks.n_frames + 1))
    on = _near_held(lambda k: tracks.point_xy[by_column[bounds[k] : bounds[k + 1]]], tracks.point_column[filled], tracks.point_xy[filled])
    if not on.any():
        return tracks
    # Runs of filled-in points (a track's points are in frame order, and a run ends before the
    # track's next measured point); a run with a point on a held one goes, and the track is cut.
    track = tracks.point_track
    opens = np.r_[True, (filled[1:] != filled[:-1] + 1) | (track[filled[1:]] != track[filled[:-1]])]
    run = np.cumsum(opens) - 1
    cut = np.zeros(run[-1] + 1, bool)
    cut[run[on]] = True
    keep = np.ones(track.size, bool)
    keep[filled[cut[run]]] = False
    starts = np.r_[True, track[1:] != track[:-1]]
    ends = np.r_[opens[1:], True]
    after = filled[ends & cut[run]] + 1
    starts[after[after < track.size]] = True
    number = np.cumsum(starts) - 1
    return Tracks(
        tracks.n_frames,
        number[keep],
        tracks.point_column[keep],
        tracks.point_xy[keep],
        tracks.point_measurement[keep],
        tracks.point_interpolated[keep],
        tracks.first_frame,
    )


def _through_held(held: Callable[[int], np.ndarray], last: np.ndarray, end_xy: np.ndarray, start_xy: np.ndarray, gap: np.ndarray) -> np.ndarray:
    """Boolean per bridge from ``end_xy`` in frame ``last`` to ``start_xy`` ``gap`` frames later:
    a point filled in on the straight line between them (as the tracks fill missed frames) lies
    on one of ``held(k)`` (see :func:`_near_held`)."""
    through = np.zeros(gap.size, bool)
    bridge, step = np.nonzero(np.arange(1, max(int(gap.max(initial=1)), 1))[None, :] < gap[:, None])
    if bridge.size == 0:
        return through
    step = step + 1
    filled = end_xy[bridge] + (step / gap[bridge])[:, None] * (start_xy[bridge] - end_xy[bridge])
    through[bridge[_near_held(held, last[bridge] + step, filled)]] = True
    return through


def _near_held(held: Callable[[int], np.ndarray], column: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """Boolean per point (``xy`` (P, 2) in frames ``column``): within ``_ON_POINT`` of one of
    ``held(k)``, the positions (Q, 2) of the measurements tracks hold in frame k."""
    near = np.zeros(column.size, bool)
    for k in np.unique(column):
        points = held(int(k))
        if points.shape[0] == 0:
            continue
        here = np.flatnonzero(column == k)
        distance = cKDTree(points).query(xy[here], distance_upper_bound=np.nextafter(_ON_POINT, np.inf))[0]
        near[here[np.isfinite(distance)]] = True
    return near


def _chain(assignment: np.ndarray, successor: np.ndarray) -> np.ndarray:
    """Merge each track with its successor's chain into the row of the chain's first track."""
    n_tracks = assignment.shape[0]
    predecessor = np.full(n_tracks, UNASSIGNED, dtype=np.int64)
    joined = successor != UNASSIGNED
    predecessor[successor[joined]] = np.flatnonzero(joined)
    root = np.arange(n_tracks)
    while True:
        up = predecessor[root]
        if (up == UNASSIGNED).all():
            break
        root = np.where(up != UNASSIGNED, up, root)
    roots, row = np.unique(root, return_inverse=True)
    merged = np.full((roots.size, assignment.shape[1]), UNASSIGNED, dtype=np.int64)
    # Parts of a chain never share a frame, and -1 is below every index.
    np.maximum.at(merged, row, assignment)
    return merged


__all__ = ["FillGaps", "extend_track_ends", "pair_at_view_edge", "join_track_ends", "split_through_held"]
