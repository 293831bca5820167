"""GOA-updown for points that come and go: when tracks start and when they end.

GOA as published keeps the heads it starts with. Its discussion proposes the open variant that
the one up-down driver (:func:`seedtrack.tracking.goa.goa_updown`) runs when given these parts:
at every frame step GOA first extends the running tracks (one optimal assignment with slaves and
false tracks), then :class:`OpenTracks` links the measurements that no track took into new
tracks. A new track opens only when its first measurements chain smoothly over three frames in
a row (scored like the first links of GOA-updown, then confirmed by GOA itself on the leftover
measurements), so that a false detection does not open a track. :class:`EndTracks` ends a track
that has taken more than ``max_gap`` slaves in a row; its trailing slaves are dropped and its
inner gaps are interpolated. A point seen in two frames only, where it enters or leaves the view
or the clip, is made a two-point track after the passes
(:func:`seedtrack.tracking.gap_closing.pair_at_view_edge`).

The up pass runs forwards; the down pass runs backwards in time from the tracks the up pass
holds at the last frame, so that every track start is re-decided with the velocities learned
later, as in GOA-updown. Gap filling (:mod:`seedtrack.tracking.gap_closing`) then joins a track
end to a later track start when the motion model says they are one object.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from .assignment import UNASSIGNED
from .gap_closing import FillGaps
from .goa import GOAConfig, HeadState, Progress, _initial_links, assign_step, goa_updown
from .initialisation import pairs_within
from .motion import Candidates, acceptable_links
from .tracks import Tracks

# Next frames in which a track back from slaves must show that its motion continues.
_CONTINUATION_FRAMES = 2
# Measured frames in a row that open a track: one triplet, the least that shows smooth motion.
# Longer confirmation missed more short stays near the view's border than it saved from false
# starts (PSMG with entry/exit: strict merit 87% with five frames, 91% with three).
_CONFIRMATION = 3


@dataclass(frozen=True)
class OpenTracks:
    """Track start: new tracks among the measurements no head holds, confirmed over
    ``confirmation`` measured frames in a row (two in a two-frame clip)."""

    confirmation: int = _CONFIRMATION

    def open(self, frames: Sequence[np.ndarray], free: list[np.ndarray], step: int, config: GOAConfig) -> tuple[np.ndarray, int]:
        """Tracks confirmed at ``step`` from the free measurements of the window that ends there.

        The first links are chosen as GOA-updown chooses them (each scored by the smoothest
        path it starts over the free measurements of the next ``config.lookahead`` frames,
        beyond ``step`` where the clip allows), then GOA runs on the free measurements of the
        window alone; a candidate that needs a slave in it is not confirmed.

        Returns
        -------
        rows : ndarray of int, shape (B, len(frames))
            Each confirmed track's measurement index per frame, -1 outside the window.
        start : int
            The window's first step.
        """
        start = step - min(self.confirmation, len(frames)) + 1
        # Checked before the window is gathered: on most steps of a tracked clip nothing is free,
        # and a track needs a free point in every frame of the window.
        if start < 0 or not all(free[k].any() for k in range(start, step + 1)):
            return np.empty((0, len(frames)), np.int64), start
        # Scoring reaches past the window: a wrong first link can look smooth for one triplet by chance.
        horizon = max(step + 1, min(start + config.lookahead, len(frames)))
        index = [np.flatnonzero(free[k]) for k in range(start, horizon)]
        ahead = [frames[k][i] for k, i in zip(range(start, horizon), index)]
        window = ahead[: step - start + 1]
        if len(window) == 1:
            local = np.arange(window[0].shape[0])[:, None]
        else:
            first = _initial_links(ahead, config)
            local = _confirmed(window, first[first[:, 1] != UNASSIGNED], config)
        rows = np.full((local.shape[0], len(frames)), UNASSIGNED, dtype=np.int64)
        for column, k in enumerate(range(start, step + 1)):
            rows[:, k] = index[column][local[:, column]]
        return rows, start


def _confirmed(window: Sequence[np.ndarray], links: np.ndarray, config: GOAConfig) -> np.ndarray:
    """The rows (B, len(window)) of the heads on ``links`` (k, 2) that GOA, run over the
    window alone, gives a measurement in every frame: the steps of :func:`~seedtrack.tracking.goa.goa_pass` without
    start or end, whose bookkeeping cost more than the steps on the few free points."""
    if not links.shape[0]:
        return np.empty((0, len(window)), np.int64)
    state = HeadState.from_history(window, links, 0, 1)
    columns = [links[:, 0], links[:, 1]]
    for step in range(2, len(window)):
        taken = assign_step(state, step, window[step], config)
        state.advance(step, taken, window[step])
        columns.append(taken)
    local = np.column_stack(columns)
    return local[(local != UNASSIGNED).all(axis=1)]


@dataclass(frozen=True)
class EndTracks:
    """Track end: a track ends after more than ``max_gap`` slaves in a row (frames)."""

    max_gap: int = 10

    def ended(self, slaves: np.ndarray) -> np.ndarray:
        """Boolean per head: its run of ``slaves`` is longer than ``max_gap``."""
        return slaves > self.max_gap

    def confirm_returns(
        self, state: HeadState, step: int, frames: Sequence[np.ndarray], free: list[np.ndarray], taken: np.ndarray, config: GOAConfig
    ) -> np.ndarray:
        """``taken`` (measurement per head at ``step``, -1 a slave), where a head back from
        slaves keeps its measurement only if the motion continues smoothly into one of the next
        two frames and did not come from a free measurement of the frame before: a point that
        enters the view near where a track was lost can fit the gap-normalised step as well as
        the lost point would. At the last frame there is nothing to confirm by."""
        after = frames[step + 1 : step + 1 + _CONTINUATION_FRAMES]
        back = (taken != UNASSIGNED) & (step - state.last_step > 1)
        if not (len(after) and back.any()):
            return taken
        gap = step - state.last_step[back]
        origin = frames[step][taken[back]]
        bridge = (origin - state.last_xy[back]) / gap[:, None]
        # The gate depends on the speed alone, the same backwards and forwards.
        speed = np.hypot(*bridge.T)
        radius = config.speed.reach(config.individual.gate_radius(speed, np.ones(speed.size, bool), config.phi_max))
        undone = _continues(origin, -bridge, gap, radius, [frames[step - 1][free[step - 1]]], config)
        if not undone.all():
            undone |= ~_continues(origin, bridge, gap, radius, after, config)
        taken = taken.copy()
        taken[np.flatnonzero(back)[undone]] = UNASSIGNED
        return taken


def _continues(
    origin: np.ndarray, velocity: np.ndarray, span: np.ndarray, radius: np.ndarray, after: Sequence[np.ndarray], config: GOAConfig
) -> np.ndarray:
    """Boolean per origin: a measurement of one of the frames ``after`` (the next frames, in
    order) within ``radius`` per frame continues ``velocity`` (gap-normalised over ``span``
    frames) within phi_max, so a point hidden again right after it reappears keeps its track."""
    found = np.zeros(origin.shape[0], bool)
    for gap, points in enumerate(after, start=1):
        owner, target = pairs_within(origin, radius * gap, points)
        if not owner.size:
            continue
        pairs = Candidates(owner, target, points[target] - origin[owner], np.full(owner.size, gap), velocity[owner], span[owner])
        found[acceptable_links(config.individual, pairs, config.phi_max, config.speed)[0].head] = True
        if found.all():
            break
    return found


@dataclass(frozen=True)
class LifecycleConfig:
    """When tracks open, end and are joined again: the parts GOA-updown runs with to let
    tracks come and go.

    Attributes
    ----------
    max_gap : int
        Longest run of missed frames (consecutive slaves) a track survives, frames; gaps up to
        this length are filled by interpolation, and gap closing joins a track end to a track
        start at most this many frames later.
    close_gaps : bool
        Join track ends to later starts after the passes (see :mod:`seedtrack.tracking.gap_closing`).
    max_slaves : int or None
        Longest run of slaves a head keeps in the passes, frames, when shorter than ``max_gap``;
        gap closing still joins a track end to a start up to ``max_gap`` frames later. None: ``max_gap``.
    """

    max_gap: int = 10
    close_gaps: bool = True
    max_slaves: int | None = None

    def __post_init__(self) -> None:
        if not (isinstance(self.max_gap, (int, np.integer)) and self.max_gap >= 0):
            raise ValueError(f"max_gap must be a whole number of frames >= 0, got {self.max_gap}")
        if self.max_slaves is not None and not (isinstance(self.max_slaves, (int, np.integer)) and self.max_slaves >= 0):
            raise ValueError(f"max_slaves must be a whole number of frames >= 0 or None, got {self.max_slaves}")

    @property
    def start(self) -> OpenTracks:
        return OpenTracks()

    @property
    def end(self) -> EndTracks:
        return EndTracks(self.max_gap if self.max_slaves is None else min(self.max_gap, self.max_slaves))

    @property
    def gaps(self) -> FillGaps:
        return FillGaps(self.max_gap, join=self.close_gaps)


def goa_updown_open(
    frames: Sequence[np.ndarray],
    config: GOAConfig = GOAConfig(),
    lifecycle: LifecycleConfig = LifecycleConfig(),
    first_frame: int = 0,
    progress: Progress | None = None,
) -> Tracks:
    """GOA-updown whose tracks open and end anywhere, followed by gap filling: the one driver
    :func:`seedtrack.tracking.goa.goa_updown` with the parts of ``lifecycle``.

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

    Examples
    --------
    >>> frames = [np.array([[0.0, 0.0], [50.0, 0.0]]) + [2.0 * k, 1.0 * k] for k in range(5)]
    >>> goa_updown_open(frames, GOAConfig(d_max=10.0)).n_tracks
    2
    """
    return goa_updown(
        frames, config, first_frame, progress, start=lifecycle.start, end=lifecycle.end, gaps=lifecycle.gaps
    )


def drop_short(tracks: Tracks, min_length: int) -> Tracks:
    """The tracks that span at least ``min_length`` frames (first to last position, gaps included).

    Parameters
    ----------
    tracks : Tracks
    min_length : int
        Frames; 0 or 1 keeps every track that has a position.
    """
    first, last = tracks.spans()
    keep = (last >= first) & (last - first + 1 >= min_length)
    # Keeping them all, a copy of every point would only add to the peak memory.
    return tracks if keep.all() else tracks.select(keep)


__all__ = ["LifecycleConfig", "OpenTracks", "EndTracks", "goa_updown_open", "drop_short"]
