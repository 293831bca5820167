"""GOA-updown for points that come and go: track initiation, termination and gap closing.

GOA as published keeps the heads it starts with. Its discussion proposes the open variant
implemented here: at every frame step GOA first extends the established tracks (one optimal
assignment with slaves and false tracks, :func:`seedtrack.tracking.goa.assign_step`), then the
measurements that no track took are linked into new tracks. A new track opens only when its
first measurements chain smoothly over three frames in a row (scored like the first links of
GOA-updown, then confirmed by GOA itself on the leftover measurements), so that a false
detection does not open a track. A track ends when it has taken more than ``max_gap``
slaves in a row; its trailing slaves are dropped and its inner gaps are interpolated.

The up pass runs forwards; the down pass runs backwards in time from the tracks the up pass
holds at the last frame, so that every track start is re-decided with the velocities learned
later, as in GOA-updown. Gap closing (:mod:`seedtrack.tracking.gap_closing`) then joins a track end to a
later track start when the motion model says they are one object.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from .assignment import UNASSIGNED
from .gap_closing import close_gaps
from .goa import GOAConfig, Progress, _HeadState, _initial_links, assign_step, goa_pass
from .initialisation import pairs_within
from .motion import Candidates
from .tracks import Tracks, order_independent, point_frames, tracks_from_assignment

# Next frames in which a track back from slaves must show that its motion continues.
_CONTINUATION_FRAMES = 2
# Measured frames in a row that open a track: one triplet, the least that shows smooth motion.
# Longer confirmation missed more short stays near the view's border than it saved from false
# starts (PSMG with entry/exit: strict merit 87% with five frames, 91% with three).
_CONFIRMATION = 3


@dataclass(frozen=True)
class LifecycleConfig:
    """When tracks open, end and are joined again.

    Attributes
    ----------
    max_gap : int
        Longest run of missed frames (consecutive slaves) a track survives, frames; gaps up to
        this length are filled by interpolation, and gap closing joins a track end to a track
        start at most this many frames later.
    close_gaps : bool
        Join track ends to later starts after the passes (see :mod:`seedtrack.tracking.gap_closing`).
    """

    max_gap: int = 10
    close_gaps: bool = True

    def __post_init__(self) -> None:
        if not (isinstance(self.max_gap, (int, np.integer)) and self.max_gap >= 0):
            raise ValueError(f"max_gap must be a whole number of frames >= 0, got {self.max_gap}")


class _Heads:
    """Every head of one pass: its state, whether it still runs, and what it holds per frame."""

    def __init__(self, n_frames: int):
        self.assignment = np.empty((0, n_frames), dtype=np.int64)
        self.state = _HeadState(np.empty((0, 2)), np.empty(0, np.int64), np.empty((0, 2)))
        self.slaves = np.empty(0, np.int64)  # consecutive slaves up to the latest step
        self.running = np.empty(0, bool)

    def add(self, frames: Sequence[np.ndarray], rows: np.ndarray, start: int, until: int) -> None:
        """Add heads whose measurements of steps ``start..until`` are given in ``rows`` (H, n)."""
        span = until - start + 1
        state = _HeadState.from_history(frames[start : until + 1], rows[:, start : until + 1], span)
        last_step = np.where(state.last_step >= 0, state.last_step + start, -1)
        self.assignment = np.concatenate((self.assignment, rows))
        self.state = _HeadState(
            np.concatenate((self.state.last_xy, state.last_xy)),
            np.concatenate((self.state.last_step, last_step)),
            np.concatenate((self.state.velocity, state.velocity)),
        )
        self.slaves = np.concatenate((self.slaves, until - last_step))
        self.running = np.concatenate((self.running, np.ones(rows.shape[0], bool)))

    def extend(
        self, step: int, points: np.ndarray, after: Sequence[np.ndarray], before: np.ndarray, config: GOAConfig, max_gap: int
    ) -> np.ndarray:
        """Assign the running heads to the frame at ``step``; returns the measurements taken.

        ``after`` holds the measurements of the next frames (none at the last): a head that
        comes back from slaves keeps its measurement only if the motion continues smoothly
        into one of them, since a point that enters the view near where a track was lost can
        fit the gap-normalised step as well as the lost point would.
        """
        running = np.flatnonzero(self.running)
        state = _HeadState(self.state.last_xy[running], self.state.last_step[running], self.state.velocity[running])
        taken = assign_step(state, step, points, config)
        back = (taken != UNASSIGNED) & (step - state.last_step > 1)
        if len(after) and back.any():
            gap = step - state.last_step[back]
            bridge = (points[taken[back]] - state.last_xy[back]) / gap[:, None]
            origin = points[taken[back]]
            untracked = _continues(origin, -bridge, [before], config)
            taken[np.flatnonzero(back)[~_continues(origin, bridge, after, config) | untracked]] = UNASSIGNED
        state.advance(step, taken, points)
        self.state.last_xy[running], self.state.last_step[running] = state.last_xy, state.last_step
        self.state.velocity[running] = state.velocity
        self.assignment[running, step] = taken
        missed = taken == UNASSIGNED
        self.slaves[running] = np.where(missed, self.slaves[running] + 1, 0)
        self.running[running[missed & (self.slaves[running] > max_gap)]] = False
        return taken[~missed]


def _continues(origin: np.ndarray, velocity: np.ndarray, after: Sequence[np.ndarray], config: GOAConfig) -> np.ndarray:
    """Boolean per origin: a measurement of one of the frames ``after`` (the next frames, in
    order) continues ``velocity`` within phi_max, so a point hidden again right after it
    reappears keeps its track."""
    found = np.zeros(origin.shape[0], bool)
    speed = np.hypot(*velocity.T)
    radius = config.individual.gate_radius(speed, np.ones(speed.size, bool), config.phi_max)
    if config.d_max is not None:
        radius = np.minimum(radius, config.d_max)
    for gap, points in enumerate(after, start=1):
        owner, target = pairs_within(origin, radius * gap, points)
        pairs = Candidates(owner, target, points[target] - origin[owner], np.full(owner.size, gap), velocity[owner])
        speed_out = np.hypot(*pairs.velocity.T)
        scale = config.d_max if config.d_max is not None else max(float(speed_out.max(initial=0.0)), 1.0)
        ok = (config.individual.cost(pairs, config.phi_max, scale) <= config.phi_max) & (speed_out >= config.d_min)
        if config.d_max is not None:
            ok &= speed_out <= config.d_max
        found[owner[ok]] = True
    return found


def _births(frames: Sequence[np.ndarray], free: list[np.ndarray], start: int, end: int, config: GOAConfig) -> np.ndarray:
    """New tracks among the free measurements of frames ``start`` to ``end`` (inclusive).

    The first links are chosen as GOA-updown chooses them (each scored by the smoothest path it
    starts over the free measurements of the next ``config.lookahead`` frames, beyond ``end``
    where the clip allows), then GOA runs on the free measurements of ``start..end`` alone; a
    candidate that needs a slave before ``end`` is not confirmed.

    Returns
    -------
    ndarray of int, shape (B, len(frames))
        Each confirmed track's measurement index per frame, -1 outside ``start..end``.
    """
    # Scoring reaches past ``end``: a wrong first link can look smooth for one triplet by chance.
    horizon = max(end + 1, min(start + config.lookahead, len(frames)))
    index = [np.flatnonzero(free[k]) for k in range(start, horizon)]
    ahead = [frames[k][i] for k, i in zip(range(start, horizon), index)]
    window = ahead[: end - start + 1]
    if window[0].shape[0] == 0:
        return np.empty((0, len(frames)), np.int64)
    if len(window) == 1:
        local = np.arange(window[0].shape[0])[:, None]
    else:
        first = _initial_links(ahead, config)
        local = goa_pass(window, first[first[:, 1] != UNASSIGNED], config)
        local = local[(local != UNASSIGNED).all(axis=1)]
    rows = np.full((local.shape[0], len(frames)), UNASSIGNED, dtype=np.int64)
    for column, k in enumerate(range(start, end + 1)):
        rows[:, k] = index[column][local[:, column]]
    return rows


def open_pass(
    frames: Sequence[np.ndarray],
    initial: np.ndarray,
    config: GOAConfig,
    max_gap: int,
    progress: Progress | None = None,
) -> np.ndarray:
    """One GOA pass in the order given, with track initiation and termination.

    Parameters
    ----------
    frames : sequence of ndarray, each (M_k, 2)
        Measurement positions per frame, pixels, in processing order.
    initial : ndarray of int, shape (m, 2)
        Tracks known from the start: measurement index in ``frames[0]`` and ``frames[1]``
        (-1 for a slave); each must hold a measurement in ``frames[0]``.
    config : GOAConfig
    max_gap : int
        Consecutive slaves after which a track ends.
    progress : callable, optional
        Called with 1 after each frame step.

    Returns
    -------
    ndarray of int, shape (n_tracks, len(frames))
        Measurement index per track and frame, -1 where it holds none. Given tracks come
        first, in their order, then new tracks in the order they opened.
    """
    n = len(frames)
    heads = _Heads(n)
    free = [np.ones(f.shape[0], bool) for f in frames]
    window = min(_CONFIRMATION, n)
    if initial.shape[0]:
        rows = np.full((initial.shape[0], n), UNASSIGNED, dtype=np.int64)
        rows[:, : initial.shape[1]] = initial
        heads.add(frames, rows, 0, initial.shape[1] - 1)
        for k in range(initial.shape[1]):
            free[k][initial[initial[:, k] != UNASSIGNED, k]] = False
    first_step = initial.shape[1] if initial.shape[0] else 1
    for step in range(1, n):
        if step >= first_step:
            after = frames[step + 1 : step + 1 + _CONTINUATION_FRAMES]
            before = frames[step - 1][free[step - 1]]
            free[step][heads.extend(step, frames[step], after, before, config, max_gap)] = False
        start = step - window + 1
        if start >= 0:
            _open(heads, frames, free, start, step, config)
        if progress is not None:
            progress(1)
    return heads.assignment


def _open(heads: _Heads, frames: Sequence[np.ndarray], free: list[np.ndarray], start: int, end: int, config: GOAConfig) -> None:
    rows = _births(frames, free, start, end, config)
    if rows.shape[0]:
        heads.add(frames, rows, start, end)
        for k in range(start, end + 1):
            free[k][rows[:, k]] = False


@order_independent
def goa_updown_open(
    frames: Sequence[np.ndarray],
    config: GOAConfig = GOAConfig(),
    lifecycle: LifecycleConfig = LifecycleConfig(),
    first_frame: int = 0,
    progress: Progress | None = None,
) -> Tracks:
    """GOA-updown whose tracks open and end anywhere, followed by gap closing.

    Parameters
    ----------
    frames : sequence of ndarray, each (M_k, 2)
        Measurement positions per frame (x, y), pixels.
    config : GOAConfig
        Per-step assignment, and the first links of new tracks; a new track must be measured
        in three frames in a row to open (two in a two-frame clip).
    lifecycle : LifecycleConfig
    first_frame : int
        0-based frame index of ``frames[0]``.
    progress : callable, optional
        Called with 1 after each frame step of either pass (``pass_steps(n_frames)`` calls).

    Returns
    -------
    Tracks
        Ordered by first frame, then by measurement index in it; inner gaps interpolated,
        no trailing slaves. Measurements on no track (false detections) are left out.
    """
    frames = point_frames(frames)
    n = len(frames)
    up = open_pass(frames, np.empty((0, 2), np.int64), config, lifecycle.max_gap, progress)
    backwards = frames[::-1]
    last = up[:, ::-1][:, :2]
    down = open_pass(backwards, last[last[:, 0] != UNASSIGNED] if n >= 2 else last[:0], config, lifecycle.max_gap, progress)
    # Both ends of every track, then the joins across gaps.
    assignment = _attach_free_points(frames, down[:, ::-1], config)
    assignment = _attach_free_points(frames[::-1], assignment[:, ::-1], config)[:, ::-1]
    if lifecycle.close_gaps:
        assignment = close_gaps(frames, assignment, config, lifecycle.max_gap)
    return tracks_from_assignment(frames, _in_order(assignment), first_frame)


def _attach_free_points(frames: Sequence[np.ndarray], assignment: np.ndarray, config: GOAConfig) -> np.ndarray:
    """Extend track ends frame by frame with the measurements no track holds, when they continue
    the motion (one GOA step per frame among the tracks that end just before it).

    A track is confirmed only from a run of measured frames, so the first point of a track that
    starts badly placed for its first links stays free; this gives it back to its track.
    """
    assignment = assignment.copy()
    n = len(frames)
    held = assignment != UNASSIGNED
    free = [np.ones(f.shape[0], bool) for f in frames]
    for k in range(n):
        free[k][assignment[held[:, k], k]] = False
    # Frame after each track's last measurement (n when it runs to the end).
    frame = np.arange(n)
    after_last = np.where(held, frame, -1).max(axis=1) + 1
    for k in range(2, n):
        heads = np.flatnonzero((after_last == k) & held[:, k - 1] & held[:, k - 2])
        index = np.flatnonzero(free[k])
        if heads.size == 0 or index.size == 0:
            continue
        last = frames[k - 1][assignment[heads, k - 1]]
        state = _HeadState(last, np.full(heads.size, k - 1), last - frames[k - 2][assignment[heads, k - 2]])
        taken = assign_step(state, k, frames[k][index], config)
        got = taken != UNASSIGNED
        assignment[heads[got], k] = index[taken[got]]
        free[k][index[taken[got]]] = False
        held[heads[got], k] = True
        after_last[heads[got]] = k + 1
    return assignment


def _in_order(assignment: np.ndarray) -> np.ndarray:
    """Rows sorted by first measured frame, then by the measurement index there."""
    if assignment.shape[0] == 0:
        return assignment
    held = assignment != UNASSIGNED
    first = held.argmax(axis=1)
    first_index = assignment[np.arange(assignment.shape[0]), first]
    return assignment[np.lexsort((first_index, first))]


def drop_short(tracks: Tracks, min_length: int) -> Tracks:
    """The tracks that span at least ``min_length`` frames (first to last position, gaps included).

    Parameters
    ----------
    tracks : Tracks
    min_length : int
        Frames; 0 or 1 keeps every track.
    """
    present = tracks.present
    frame = np.arange(tracks.n_frames)
    first = np.where(present, frame, tracks.n_frames).min(axis=1)
    last = np.where(present, frame, -1).max(axis=1)
    keep = last - first + 1 >= min_length
    return Tracks(tracks.xy[keep], tracks.measurement[keep], tracks.first_frame, tracks.track_ids[keep])


__all__ = ["LifecycleConfig", "goa_updown_open", "open_pass", "drop_short"]
