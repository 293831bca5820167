"""Sethi and Jain's greedy exchange with Salari and Sethi's phantom points (the paper's SS).

Every frame is padded with phantom points to a fixed number of track slots. Slots are first
filled by greedy nearest neighbour, frame by frame. The exchange loop then repeatedly swaps the
remainders (from one frame on) of the two slots whose swap lowers the summed smooth-motion
deviation (IM2, CM1 with z = 1) the most, over the whole sequence, until no swap gains. A
triplet holding a phantom costs phi_max; a real triplet must move at most d_max per frame and
deviate at most phi_max, so a track that cannot continue smoothly is cut by a swap with a
phantom. Each slot is finally split at its phantoms into tracks: SS does not bridge gaps.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from .motion import smooth_motion_cost
from .tracks import Tracks, check_limit, order_independent, point_frames, tracks_from_links

# The cost of a triplet that breaks a constraint: large enough that removing one always pays
# more than any sum of allowed costs, small enough that gains stay exact in float64.
_FORBIDDEN = 1e6
_TOLERANCE = 1e-9


@order_independent
def sethi_jain(
    frames: Sequence[np.ndarray],
    phi_max: float = 0.1,
    d_max: float | None = None,
    w1: float = 0.1,
    w2: float = 0.9,
    spare_slots: int | None = None,
    first_frame: int = 0,
) -> Tracks:
    """Track with greedy exchange over the whole sequence, phantom points for misses.

    Parameters
    ----------
    frames : sequence of ndarray, each (M_k, 2)
        Measurement positions per frame (x, y), pixels.
    phi_max : float
        Largest smooth-motion deviation of a real triplet, and the cost of a phantom triplet.
    d_max : float or None
        Largest speed, pixels/frame; None for no limit.
    w1, w2 : float
        IM2 weights of direction and speed.
    spare_slots : int, optional
        Slots beyond the largest frame, so that tracks can be cut; default as many as that
        frame has points.
    first_frame : int
        0-based frame index of ``frames[0]``.

    Returns
    -------
    Tracks
        One track per run of real points in a slot; gaps are not bridged.
    """
    frames = point_frames(frames)
    phi_max, d_max = check_limit("phi_max", phi_max, optional=False), check_limit("d_max", d_max)
    largest = max((f.shape[0] for f in frames), default=0)
    slots = largest + (largest if spare_slots is None else spare_slots)
    exchange = _Exchange(frames, _initial_slots(frames, slots, d_max), phi_max, d_max, w1, w2)
    exchange.run()
    return tracks_from_links(frames, exchange.links(), first_frame)


def _initial_slots(frames: list[np.ndarray], slots: int, d_max: float | None) -> np.ndarray:
    """Greedy nearest-neighbour filling: index of each slot's point per frame, -1 for a phantom.

    Pairs of a slot's point and a next-frame point are taken shortest first, first come first
    served; points left over go to the free slots in order.
    """
    index = np.full((slots, len(frames)), -1, dtype=np.int64)
    if not frames:
        return index
    index[: frames[0].shape[0], 0] = np.arange(frames[0].shape[0])
    for k in range(1, len(frames)):
        occupied = np.flatnonzero(index[:, k - 1] >= 0)
        before = frames[k - 1][index[occupied, k - 1]]
        after = frames[k]
        taken = np.zeros(after.shape[0], bool)
        if occupied.size and after.shape[0]:
            distance = np.hypot(before[:, None, 0] - after[None, :, 0], before[:, None, 1] - after[None, :, 1])
            order = np.argsort(distance, axis=None, kind="stable")
            slot_done = np.zeros(occupied.size, bool)
            for flat in order:
                row, column = divmod(int(flat), after.shape[0])
                if d_max is not None and distance[row, column] > d_max:
                    break
                if not slot_done[row] and not taken[column]:
                    index[occupied[row], k] = column
                    slot_done[row] = taken[column] = True
        free = np.flatnonzero(index[:, k] < 0)
        left = np.flatnonzero(~taken)
        index[free[: left.size], k] = left
    return index


class _Exchange:
    """The exchange loop's state: slot positions (NaN for phantoms) and the best swap per cut."""

    def __init__(self, frames: list[np.ndarray], index: np.ndarray, phi_max: float, d_max: float | None,
                 w1: float, w2: float):
        self.index = index
        self.phi_max, self.d_max, self.w1, self.w2 = phi_max, d_max, w1, w2
        self.n_frames = index.shape[1]
        self.best = np.full(self.n_frames, -np.inf)
        self.pair = np.zeros((self.n_frames, 2), dtype=np.int64)
        self.xy = np.full(index.shape + (2,), np.nan)
        real = index >= 0
        for k, points in enumerate(frames):
            self.xy[real[:, k], k] = points[index[real[:, k], k]]

    def triplet_cost(self, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
        """Cost of triplets of positions (..., 2): phi_max with a phantom, else IM2 within limits."""
        shape = a.shape[:-1]
        a, b, c = (x.reshape(-1, 2) for x in (a, b, c))
        first, second = b - a, c - b
        cost = np.full(first.shape[0], self.phi_max)
        real = ~(np.isnan(a[:, 0]) | np.isnan(b[:, 0]) | np.isnan(c[:, 0]))
        if real.any():
            deviation = smooth_motion_cost(first[real], second[real], self.w1, self.w2)
            bad = deviation > self.phi_max + _TOLERANCE
            if self.d_max is not None:
                bad |= (np.hypot(*first[real].T) > self.d_max) | (np.hypot(*second[real].T) > self.d_max)
            cost[real] = np.where(bad, _FORBIDDEN, deviation)
        return cost.reshape(shape)

    def cut_slots(self, k: int) -> np.ndarray:
        """Slots a swap at frame k can change: those with a real point in frames k-2 to k+1,
        plus one all-phantom slot there (all such slots are alike, so one stands for them)."""
        window = self.index[:, max(k - 2, 0) : k + 2]
        active = (window >= 0).any(axis=1)
        idle = np.flatnonzero(~active)
        return np.concatenate((np.flatnonzero(active), idle[:1]))

    def cut_cost(self, k: int, before: np.ndarray, after: np.ndarray) -> np.ndarray:
        """Cost of the triplets around a cut at frame k if slot ``before`` continued with slot
        ``after``'s remainder (arrays of slot indices)."""
        xy = self.xy
        cost = np.zeros(before.size)
        if k >= 2:  # the triplet centred on frame k-1
            cost += self.triplet_cost(xy[before, k - 2], xy[before, k - 1], xy[after, k])
        if k + 1 < self.n_frames:  # the triplet centred on frame k
            cost += self.triplet_cost(xy[before, k - 1], xy[after, k], xy[after, k + 1])
        return cost

    def refresh(self, k: int) -> None:
        """Find the best swap at frame k among the slots it can change."""
        if not 1 <= k < self.n_frames:
            return
        self.best[k] = -np.inf
        slots = self.cut_slots(k)
        i, j = np.triu_indices(slots.size, 1)
        i, j = slots[i], slots[j]
        # Both new links must be allowed (or touch a phantom) for a swap to be worth pricing.
        if self.d_max is not None:
            def reach(a, b):
                return ~(np.hypot(*(self.xy[b, k] - self.xy[a, k - 1]).T) > self.d_max)

            allowed = reach(i, j) & reach(j, i)
            i, j = i[allowed], j[allowed]
        if i.size == 0:
            return
        old = np.zeros(self.xy.shape[0])
        old[slots] = self.cut_cost(k, slots, slots)
        gain = old[i] + old[j] - self.cut_cost(k, i, j) - self.cut_cost(k, j, i)
        best = int(np.argmax(gain))
        self.best[k] = gain[best]
        self.pair[k] = (i[best], j[best])

    def run(self) -> None:
        for k in range(1, self.n_frames):
            self.refresh(k)
        while self.n_frames > 1:
            k = int(np.argmax(self.best))
            if self.best[k] <= _TOLERANCE:
                return
            i, j = self.pair[k]
            self.index[[i, j], k:] = self.index[[j, i], k:]
            self.xy[[i, j], k:] = self.xy[[j, i], k:]
            # Later cuts see the two slots exchanged, so their best pairs swap names.
            later = self.pair[k + 2 :]
            later[:] = np.where(later == i, -1, later)
            later[:] = np.where(later == j, i, later)
            later[:] = np.where(later == -1, j, later)
            for cut in (k - 1, k, k + 1):
                self.refresh(cut)

    def links(self) -> np.ndarray:
        """(frame, index, frame + 1, index) for every pair of consecutive real points in a slot."""
        both = (self.index[:, :-1] >= 0) & (self.index[:, 1:] >= 0)
        slot, k = np.nonzero(both)
        rows = np.column_stack((k, self.index[slot, k], k + 1, self.index[slot, k + 1]))
        if self.d_max is not None and rows.size:
            step = np.hypot(*(self.xy[slot, k + 1] - self.xy[slot, k]).T)
            rows = rows[step <= self.d_max]
        return rows
