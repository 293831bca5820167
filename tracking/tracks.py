"""The track set: the one data structure that every tracker returns and every metric reads.

Tracks are held as dense arrays over (track, frame) rather than as lists of points, because the
paper's trackers keep a fixed number of heads advancing in lock step, and because metrics and
renderers then become array expressions.
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


@dataclass(frozen=True)
class Tracks:
    """A set of tracks over consecutive frames.

    Attributes
    ----------
    xy : ndarray of float, shape (n_tracks, n_frames, 2)
        Position (x to the right, y down, pixels, pixel centres at integer coordinates) of each
        track in each frame; NaN where the track has no position (before it starts, after it
        ends, or a trailing slave whose position is undefined).
    measurement : ndarray of int, shape (n_tracks, n_frames)
        Index of the measurement within its frame that the track holds, or ``NO_MEASUREMENT``
        (-1) where the position is interpolated or absent.
    first_frame : int
        0-based frame index of column 0.
    track_ids : ndarray of int, shape (n_tracks,)
        Identifier of each track, as written to files.
    """

    xy: np.ndarray
    measurement: np.ndarray
    first_frame: int = 0
    track_ids: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.xy.ndim != 3 or self.xy.shape[2] != 2:
            raise ValueError(f"xy must have shape (n_tracks, n_frames, 2), got {self.xy.shape}")
        if self.measurement.shape != self.xy.shape[:2]:
            raise ValueError("measurement must have shape (n_tracks, n_frames) matching xy")
        if self.track_ids is None:
            object.__setattr__(self, "track_ids", np.arange(self.xy.shape[0]))

    @property
    def n_tracks(self) -> int:
        return self.xy.shape[0]

    @property
    def n_frames(self) -> int:
        return self.xy.shape[1]

    @property
    def present(self) -> np.ndarray:
        """Boolean (n_tracks, n_frames): the track has a position in that frame."""
        return ~np.isnan(self.xy[..., 0])

    @property
    def interpolated(self) -> np.ndarray:
        """Boolean (n_tracks, n_frames): a position that no measurement supports (bound slave)."""
        return self.present & (self.measurement == NO_MEASUREMENT)

    def to_rows(self) -> dict[str, np.ndarray]:
        """Flatten to the columns of ``tracks.csv``, sorted by track then frame.

        Returns
        -------
        dict of str to ndarray
            ``track_id``, ``frame`` (0-based), ``x``, ``y`` (pixels), ``interpolated`` (0 or 1).
        """
        track_index, frame_index = np.nonzero(self.present)
        return {
            "track_id": self.track_ids[track_index],
            "frame": frame_index + self.first_frame,
            "x": self.xy[track_index, frame_index, 0],
            "y": self.xy[track_index, frame_index, 1],
            "interpolated": self.interpolated[track_index, frame_index].astype(np.int64),
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

        Measurement indices are not stored in files; a measured row gets index 0 as a marker
        that it is measured, so only :attr:`interpolated` and positions survive a round trip.

        Raises
        ------
        ValueError
            If a (track_id, frame) pair occurs twice.
        """
        track_id = np.asarray(track_id, dtype=np.int64)
        frame = np.asarray(frame, dtype=np.int64)
        ids, track_index = np.unique(track_id, return_inverse=True)
        first = int(frame.min()) if frame.size else 0
        n_frames = int(frame.max()) - first + 1 if frame.size else 0
        xy = np.full((ids.size, n_frames, 2), np.nan)
        measurement = np.full((ids.size, n_frames), NO_MEASUREMENT, dtype=np.int64)
        column = frame - first
        cell = track_index * max(n_frames, 1) + column
        if np.unique(cell).size != cell.size:
            raise ValueError("a track has two rows for the same frame")
        xy[track_index, column, 0] = x
        xy[track_index, column, 1] = y
        measured = np.ones(track_id.size, bool) if interpolated is None else ~np.asarray(interpolated, bool)
        measurement[track_index[measured], column[measured]] = 0
        return cls(xy=xy, measurement=measurement, first_frame=first, track_ids=ids)


def tracks_from_assignment(
    frames: list[np.ndarray], assignment: np.ndarray, first_frame: int = 0
) -> Tracks:
    """Turn per-frame measurement indices into positions, interpolating bound slaves.

    A bound slave (a frame without a measurement between two true measurements of the same
    track) gets the position on the straight line between them, evenly spaced in time, as the
    paper's slave interpolation does. Slaves before a track's first or after its last true
    measurement have no defined position and stay NaN.

    Parameters
    ----------
    frames : list of ndarray, each of shape (M_k, 2)
        Measurement positions per frame, pixels.
    assignment : ndarray of int, shape (n_tracks, n_frames)
        Measurement index per track and frame, or ``NO_MEASUREMENT``.
    first_frame : int
        0-based frame index of ``frames[0]``.
    """
    n_tracks, n_frames = assignment.shape
    xy = np.full((n_tracks, n_frames, 2), np.nan)
    for column, points in enumerate(frames):
        held = assignment[:, column] != NO_MEASUREMENT
        xy[held, column] = points[assignment[held, column]]
    _interpolate_inner_gaps(xy)
    return Tracks(xy=xy, measurement=assignment.copy(), first_frame=first_frame)


def _interpolate_inner_gaps(xy: np.ndarray) -> None:
    """Fill NaN runs that lie between two known positions of the same track, in place."""
    known = ~np.isnan(xy[..., 0])
    frame = np.arange(xy.shape[1])
    # Index of the latest known frame at or before each frame, and the earliest at or after.
    before = np.maximum.accumulate(np.where(known, frame, -1), axis=1)
    after = np.minimum.accumulate(np.where(known, frame, xy.shape[1])[:, ::-1], axis=1)[:, ::-1]
    inner = ~known & (before >= 0) & (after < xy.shape[1])
    if not inner.any():
        return
    track, column = np.nonzero(inner)
    start, end = before[track, column], after[track, column]
    fraction = (column - start) / (end - start)
    xy[track, column] = xy[track, start] + fraction[:, None] * (xy[track, end] - xy[track, start])


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
    measured = tracks.measurement != NO_MEASUREMENT
    both = measured[:, 1:] & measured[:, :-1]
    speed = np.hypot(*np.diff(tracks.xy, axis=1)[both].T)
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


def canonical_order(frames: list[np.ndarray]) -> list[np.ndarray]:
    """Per frame, the row order that sorts its points by x, then y.

    Trackers break ties (two assignments of equal cost) by the order of the rows they are
    given; tracking the points in this order, whatever order they came in, makes the result
    independent of the order of the rows within a frame.

    Parameters
    ----------
    frames : list of ndarray, each (M_k, 2)
        Positions (x, y) per frame, pixels.

    Returns
    -------
    list of ndarray of int, each (M_k,)
        Input row of each sorted row.

    Examples
    --------
    >>> canonical_order([np.array([[3.0, 1.0], [1.0, 5.0], [1.0, 2.0]])])[0]
    array([2, 1, 0])
    """
    return [np.lexsort((f[:, 1], f[:, 0])) for f in frames]


def in_input_order(tracks: "Tracks", order: list[np.ndarray]) -> "Tracks":
    """``tracks`` found on frames reordered by ``order`` (:func:`canonical_order`), with its
    measurement indices turned back into rows of the frames as given."""
    measurement = tracks.measurement.copy()
    for column, rows in enumerate(order):
        held = measurement[:, column] != NO_MEASUREMENT
        measurement[held, column] = rows[measurement[held, column]]
    return replace(tracks, measurement=measurement)


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
        bound.arguments["frames"] = [f[o] for f, o in zip(frames, order)]
        if bound.arguments.get("initial") is not None:
            initial = np.array(bound.arguments["initial"], dtype=np.int64)
            for column in range(min(initial.shape[1], len(order))):
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

