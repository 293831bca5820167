"""The track set: the one data structure that every tracker returns and every metric reads.

Tracks are held as their points, flat arrays sorted by track and then frame (like the rows of
``tracks.csv``), so that memory grows with the points held and not with tracks x frames: on
long recordings most tracks span a small part of the clip. Dense (track, frame) views are
built on demand for metrics and renderers, which are array expressions over them.
"""

from __future__ import annotations

import functools
import inspect
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

NO_MEASUREMENT = -1
# A speed limit estimated from tracks leaves this much room above their fastest links.
_SPEED_MARGIN = 1.5
_SPEED_PERCENTILE = 99


@dataclass(frozen=True, eq=False)
class Tracks:
    """A set of tracks over consecutive frames, held as one row per point.

    Positions are pixels, x to the right, y down, pixel centres at integer coordinates. A point
    is a frame where a track has a position: a measurement it holds, or a position filled in
    between two of them (a bound slave, ``interpolated``).

    Attributes
    ----------
    n_frames : int
        Frames spanned, column 0 being ``first_frame``.
    point_track : ndarray of int, shape (N,)
        Track of each point, 0 .. n_tracks - 1; points are sorted by track, then column.
    point_column : ndarray of int, shape (N,)
        Frame of each point, 0-based from ``first_frame``; at most one point per track and column.
    point_xy : ndarray of float, shape (N, 2)
        Position of each point, pixels.
    point_measurement : ndarray of int, shape (N,)
        Index, within its frame of the tracker's input, of the measurement the point is; -1
        (``NO_MEASUREMENT``) for an interpolated point and where no index is known (tracks
        read from a file).
    point_interpolated : ndarray of bool, shape (N,)
        The position is filled in, not measured.
    first_frame : int
        0-based frame index of column 0.
    track_ids : ndarray of int, shape (n_tracks,)
        Identifier of each track, as written to files (a track may hold no point).

    Examples
    --------
    >>> tracks = Tracks.from_rows(np.array([7, 7, 9]), np.array([3, 5, 4]), np.array([1.0, 3.0, 8.0]), np.array([2.0, 2.0, 5.0]))
    >>> tracks.n_tracks, tracks.n_frames, tracks.first_frame
    (2, 3, 3)
    >>> tracks.to_rows()["frame"]
    array([3, 5, 4])
    """

    n_frames: int
    point_track: np.ndarray
    point_column: np.ndarray
    point_xy: np.ndarray
    point_measurement: np.ndarray
    point_interpolated: np.ndarray
    first_frame: int = 0
    track_ids: np.ndarray | None = None

    def __post_init__(self) -> None:
        n = self.point_track.shape[0]
        if self.point_xy.shape != (n, 2) or self.point_column.shape != (n,) or self.point_measurement.shape != (n,):
            raise ValueError("point arrays must have matching lengths, and point_xy shape (N, 2)")
        if self.point_interpolated.shape != (n,):
            raise ValueError("point_interpolated must have one flag per point")
        if self.track_ids is None:
            object.__setattr__(self, "track_ids", np.arange(int(self.point_track.max()) + 1 if n else 0))
        key = self.point_track * max(self.n_frames, 1) + self.point_column
        if n and (np.diff(key) <= 0).any():
            raise ValueError("points must be sorted by track, then frame, with one point per track and frame")
        if n and (self.point_column.min() < 0 or self.point_column.max() >= self.n_frames or self.point_track.max() >= self.n_tracks):
            raise ValueError("a point lies outside the tracks' frames or tracks")

    @classmethod
    def from_dense(
        cls,
        xy: np.ndarray,
        measurement: np.ndarray,
        first_frame: int = 0,
        track_ids: np.ndarray | None = None,
    ) -> "Tracks":
        """Build a track set from (track, frame) arrays.

        Parameters
        ----------
        xy : ndarray of float, shape (n_tracks, n_frames, 2)
            Positions, pixels; NaN where a track has none.
        measurement : ndarray of int, shape (n_tracks, n_frames)
            Measurement index, -1 where a present position is interpolated.
        first_frame : int
        track_ids : ndarray of int, shape (n_tracks,), optional
        """
        xy = np.asarray(xy, dtype=float)
        if xy.ndim != 3 or xy.shape[2] != 2:
            raise ValueError(f"xy must have shape (n_tracks, n_frames, 2), got {xy.shape}")
        if measurement.shape != xy.shape[:2]:
            raise ValueError("measurement must have shape (n_tracks, n_frames) matching xy")
        track, column = np.nonzero(~np.isnan(xy[..., 0]))
        index = np.asarray(measurement, dtype=np.int64)[track, column]
        ids = np.arange(xy.shape[0]) if track_ids is None else np.asarray(track_ids)
        return cls(xy.shape[1], track, column, xy[track, column], index, index == NO_MEASUREMENT, first_frame, ids)

    @property
    def n_tracks(self) -> int:
        return int(self.track_ids.shape[0])

    @functools.cached_property
    def offsets(self) -> np.ndarray:
        """ndarray of int, shape (n_tracks + 1,): track i's points are ``offsets[i]:offsets[i + 1]``."""
        return np.searchsorted(self.point_track, np.arange(self.n_tracks + 1))

    @functools.cached_property
    def xy(self) -> np.ndarray:
        """Dense view, shape (n_tracks, n_frames, 2): position per track and frame, NaN where none."""
        xy = np.full((self.n_tracks, self.n_frames, 2), np.nan)
        xy[self.point_track, self.point_column] = self.point_xy
        return xy

    @functools.cached_property
    def measurement(self) -> np.ndarray:
        """Dense view, shape (n_tracks, n_frames): :attr:`point_measurement`, -1 where no point."""
        measurement = np.full((self.n_tracks, self.n_frames), NO_MEASUREMENT, dtype=np.int64)
        measurement[self.point_track, self.point_column] = self.point_measurement
        return measurement

    @functools.cached_property
    def present(self) -> np.ndarray:
        """Dense view, boolean (n_tracks, n_frames): the track has a position in that frame."""
        present = np.zeros((self.n_tracks, self.n_frames), bool)
        present[self.point_track, self.point_column] = True
        return present

    @functools.cached_property
    def interpolated(self) -> np.ndarray:
        """Dense view, boolean (n_tracks, n_frames): a position that no measurement supports."""
        interpolated = np.zeros((self.n_tracks, self.n_frames), bool)
        interpolated[self.point_track, self.point_column] = self.point_interpolated
        return interpolated

    def spans(self) -> tuple[np.ndarray, np.ndarray]:
        """First and last column of each track; -1 and -2 for a track with no point (it spans
        no frame)."""
        first, last = np.full(self.n_tracks, -1, np.int64), np.full(self.n_tracks, -2, np.int64)
        held = self.offsets[1:] > self.offsets[:-1]
        first[held] = self.point_column[self.offsets[:-1][held]]
        last[held] = self.point_column[self.offsets[1:][held] - 1]
        return first, last

    def select(self, keep: np.ndarray) -> "Tracks":
        """The tracks chosen by a boolean mask over tracks, in their order, with their ids."""
        keep = np.asarray(keep, bool)
        rows = keep[self.point_track]
        renumber = np.cumsum(keep) - 1
        return Tracks(
            self.n_frames,
            renumber[self.point_track[rows]],
            self.point_column[rows],
            self.point_xy[rows],
            self.point_measurement[rows],
            self.point_interpolated[rows],
            self.first_frame,
            self.track_ids[keep],
        )

    def shifted(self, velocity: tuple[float, float]) -> "Tracks":
        """The tracks seen from a frame moving with ``velocity`` (x, y), pixels/frame: column k
        moved by ``k * velocity``."""
        shift = self.point_column[:, None] * np.asarray(velocity, dtype=float)
        return replace(self, point_xy=self.point_xy + shift)

    def to_rows(self) -> dict[str, np.ndarray]:
        """Flatten to the columns of ``tracks.csv``, sorted by track then frame.

        Returns
        -------
        dict of str to ndarray
            ``track_id``, ``frame`` (0-based), ``x``, ``y`` (pixels), ``interpolated`` (0 or 1).
        """
        return {
            "track_id": self.track_ids[self.point_track],
            "frame": self.point_column + self.first_frame,
            "x": self.point_xy[:, 0].copy(),
            "y": self.point_xy[:, 1].copy(),
            "interpolated": self.point_interpolated.astype(np.int64),
        }

    @classmethod
    def from_rows(
        cls,
        track_id: np.ndarray,
        frame: np.ndarray,
        x: np.ndarray,
        y: np.ndarray,
        interpolated: np.ndarray | None = None,
    ) -> "Tracks":
        """Build a track set from flat rows (the inverse of :meth:`to_rows`).

        Files hold no measurement indices: every point gets ``NO_MEASUREMENT``, and the
        ``interpolated`` flags (none by default) say which positions were filled in.

        Raises
        ------
        ValueError
            If a (track_id, frame) pair occurs twice.
        """
        track_id = np.asarray(track_id, dtype=np.int64)
        frame = np.asarray(frame, dtype=np.int64)
        ids, track = np.unique(track_id, return_inverse=True)
        first = int(frame.min()) if frame.size else 0
        n_frames = int(frame.max()) - first + 1 if frame.size else 0
        column = frame - first
        order = np.lexsort((column, track))
        track, column = track[order].astype(np.int64), column[order]
        if track.size > 1 and ((np.diff(track) == 0) & (np.diff(column) == 0)).any():
            raise ValueError("a track has two rows for the same frame")
        xy = np.column_stack((np.asarray(x, dtype=float), np.asarray(y, dtype=float)))[order]
        flags = np.zeros(track.size, bool) if interpolated is None else np.asarray(interpolated, bool)[order]
        return cls(n_frames, track, column, xy, np.full(track.size, NO_MEASUREMENT, np.int64), flags, first, ids)


def tracks_from_assignment(
    frames: list[np.ndarray], assignment: np.ndarray, first_frame: int = 0
) -> Tracks:
    """Turn per-frame measurement indices into positions, interpolating bound slaves.

    A bound slave (a frame without a measurement between two true measurements of the same
    track) gets the position on the straight line between them, evenly spaced in time, as the
    paper's slave interpolation does. Slaves before a track's first or after its last true
    measurement have no defined position and are left out.

    Parameters
    ----------
    frames : list of ndarray, each of shape (M_k, 2)
        Measurement positions per frame, pixels.
    assignment : ndarray of int, shape (n_tracks, n_frames)
        Measurement index per track and frame, or ``NO_MEASUREMENT``.
    first_frame : int
        0-based frame index of ``frames[0]``.
    """
    # Every cell from a track's first to its last measurement is a point, in (track, frame)
    # order; the points are found and filled in place, with no full-size temporary beyond the
    # result and one index per cell.
    held = assignment != NO_MEASUREMENT
    present = np.logical_or.accumulate(held, axis=1) & np.logical_or.accumulate(held[:, ::-1], axis=1)[:, ::-1]
    del held
    track, column = np.nonzero(present)
    measurement = assignment[track, column].astype(np.int64)
    position = np.cumsum(present.ravel()).reshape(present.shape) - 1
    del present
    xy = np.empty((track.size, 2))
    for k, points in enumerate(frames):
        rows = np.flatnonzero(assignment[:, k] != NO_MEASUREMENT)
        xy[position[rows, k]] = np.asarray(points, dtype=float).reshape(-1, 2)[assignment[rows, k]]
    del position
    interpolated = measurement == NO_MEASUREMENT
    filled = np.flatnonzero(interpolated)
    if filled.size:
        measured = np.flatnonzero(~interpolated)
        after = np.searchsorted(measured, filled)
        start, end = measured[after - 1], measured[after]
        fraction = ((column[filled] - column[start]) / (column[end] - column[start]))[:, None]
        xy[filled] = xy[start] + fraction * (xy[end] - xy[start])
    return Tracks(len(frames), track, column, xy, measurement, interpolated, first_frame, np.arange(assignment.shape[0]))


def tracks_from_links(
    frames: list[np.ndarray],
    links: np.ndarray,
    first_frame: int = 0,
) -> Tracks:
    """Chain links between measurements into tracks, interpolating the frames a link skips.

    Trackers that start and end tracks anywhere (nearest neighbour, SS, IPAN) report which
    measurement follows which; every measurement without a predecessor starts a track and
    every measurement, linked or not, belongs to exactly one track.

    Parameters
    ----------
    frames : list of ndarray, each of shape (M_k, 2)
        Measurement positions per frame, pixels.
    links : ndarray of int, shape (L, 4)
        Rows (frame, index, later_frame, later_index) in positions of ``frames``; a link may
        skip frames (a closed gap), which are then filled by straight-line interpolation. Each
        measurement has at most one successor and one predecessor.
    first_frame : int
        0-based frame index of ``frames[0]``.

    Returns
    -------
    Tracks
        Tracks ordered by their first frame, then by the index of their first measurement.
    """
    counts = np.array([f.shape[0] for f in frames], dtype=np.int64)
    offset = np.concatenate(([0], np.cumsum(counts)))
    total = int(offset[-1])
    frame_of = np.repeat(np.arange(len(frames)), counts)
    index_of = np.arange(total) - offset[frame_of]
    links = np.asarray(links, dtype=np.int64).reshape(-1, 4)
    source = offset[links[:, 0]] + links[:, 1]
    target = offset[links[:, 2]] + links[:, 3]
    successor = np.full(total, -1, dtype=np.int64)
    successor[source] = target
    has_predecessor = np.zeros(total, bool)
    has_predecessor[target] = True
    if np.unique(source).size != source.size or np.unique(target).size != target.size:
        raise ValueError("a measurement has two successors or two predecessors")

    current = np.flatnonzero(~has_predecessor)  # global ids are already in (frame, index) order
    assignment = np.full((current.size, len(frames)), NO_MEASUREMENT, dtype=np.int64)
    row = np.arange(current.size)
    while current.size:
        assignment[row, frame_of[current]] = index_of[current]
        more = successor[current] >= 0
        row, current = row[more], successor[current[more]]
    return tracks_from_assignment(frames, assignment, first_frame)


def link_speed_limit(tracks: Tracks) -> float:
    """A speed limit that the measured links of ``tracks`` suggest: 1.5 times their 99th percentile.

    Returns
    -------
    float
        Pixels/frame; 1.0 when there are no links to measure.
    """
    measured = ~tracks.point_interpolated
    both = (np.diff(tracks.point_track) == 0) & (np.diff(tracks.point_column) == 1) & measured[1:] & measured[:-1]
    speed = np.hypot(*np.diff(tracks.point_xy, axis=0)[both].T)
    return float(_SPEED_MARGIN * np.percentile(speed, _SPEED_PERCENTILE)) if speed.size and speed.max() > 0 else 1.0


def point_frames(frames) -> list[np.ndarray]:
    """The measurements every tracker takes: one float array of shape (M_k, 2) per frame.

    Parameters
    ----------
    frames : sequence of array-like
        Positions (x, y) per frame, pixels; an empty frame may have any empty shape.

    Raises
    ------
    ValueError
        If a frame is not a list of (x, y) pairs or holds a non-finite position.
    """
    out = []
    for k, frame in enumerate(frames):
        points = np.asarray(frame, dtype=float)
        if points.size == 0:
            points = points.reshape(0, 2)
        if points.ndim != 2 or points.shape[1] != 2:
            raise ValueError(f"frame {k} must hold (x, y) pairs, got shape {points.shape}")
        if not np.isfinite(points).all():
            raise ValueError(f"frame {k} holds a non-finite position")
        out.append(points)
    return out


def canonical_order(frames: list[np.ndarray]) -> list[np.ndarray | None]:
    """Per frame, the row order that sorts its points by x, then y (None where they already are).

    Trackers break ties (two assignments of equal cost) by the order of the rows they are
    given; tracking the points in this order, whatever order they came in, makes the result
    independent of the order of the rows within a frame.

    Parameters
    ----------
    frames : list of ndarray, each (M_k, 2)
        Positions (x, y) per frame, pixels.

    Returns
    -------
    list of (ndarray of int, each (M_k,), or None)
        Input row of each sorted row; None for a frame in that order already (as ``seedtrack
        track`` gives them), which then needs no copy.

    Examples
    --------
    >>> canonical_order([np.array([[3.0, 1.0], [1.0, 5.0], [1.0, 2.0]]), np.array([[1.0, 2.0], [1.0, 3.0]])])
    [array([2, 1, 0]), None]
    """
    return [None if _is_sorted(f) else np.lexsort((f[:, 1], f[:, 0])) for f in frames]


def _is_sorted(points: np.ndarray) -> bool:
    dx = np.diff(points[:, 0])
    return bool((dx >= 0).all() and (np.diff(points[:, 1])[dx == 0] >= 0).all())


def in_input_order(tracks: "Tracks", order: list[np.ndarray | None]) -> "Tracks":
    """``tracks`` found on frames reordered by ``order`` (:func:`canonical_order`), with its
    measurement indices turned back into rows of the frames as given."""
    if all(rows is None for rows in order):
        return tracks
    sizes = np.array([0 if rows is None else rows.size for rows in order], dtype=np.int64)
    everything = np.concatenate([rows for rows in order if rows is not None])
    start = np.concatenate(([0], np.cumsum(sizes)))
    measurement = tracks.point_measurement.copy()
    moved = (measurement != NO_MEASUREMENT) & (sizes[tracks.point_column] > 0)
    measurement[moved] = everything[start[tracks.point_column[moved]] + measurement[moved]]
    return replace(tracks, point_measurement=measurement)


def order_independent(tracker: Callable[..., "Tracks"]) -> Callable[..., "Tracks"]:
    """Wrap ``tracker(frames, ...) -> Tracks`` so that it tracks each frame's points sorted by
    (x, y) and reports measurement indices into the frames as given; an ``initial`` argument
    (measurement indices of given first links, (m, 2), -1 for none) is turned into the sorted
    rows too.

    The result then does not depend on the order of the rows within a frame: equal-cost
    choices fall the same way whatever that order (issue 18: with no speed limit, a link that
    costs exactly phi_max ties with a slave plus a false track, and the solver took whichever
    came first).
    """

    signature = inspect.signature(tracker)

    @functools.wraps(tracker)
    def run(*args, **kwargs) -> Tracks:
        bound = signature.bind(*args, **kwargs)
        frames = point_frames(bound.arguments["frames"])
        order = canonical_order(frames)
        bound.arguments["frames"] = [f if o is None else f[o] for f, o in zip(frames, order)]
        if bound.arguments.get("initial") is not None:
            initial = np.array(bound.arguments["initial"], dtype=np.int64)
            for column in range(min(initial.shape[1], len(order))):
                if order[column] is not None:
                    rank = np.argsort(order[column])
                    held = initial[:, column] != NO_MEASUREMENT
                    initial[held, column] = rank[initial[held, column]]
            bound.arguments["initial"] = initial
        return in_input_order(tracker(*bound.args, **bound.kwargs), order)

    return run


def check_limit(name: str, value: float | None, optional: bool = True) -> float | None:
    """``value`` as a float when it is a positive limit (None passes when ``optional``).

    Raises
    ------
    ValueError
        Naming the limit, if it is not positive (or None where one is required).
    """
    if value is None and optional:
        return None
    if value is None or not float(value) > 0:
        raise ValueError(f"{name} must be positive, got {value}")
    return float(value)

