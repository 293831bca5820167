"""Where a reviewer should look first: the places in a track set most likely to hold an error.

Computed from what the tracks (and detections) hold, most doubtful first:

* a close call: a link whose point is not clearly the nearest to where the track was heading.
  The prediction is made twice, as standing still and as keeping the last step's velocity, and
  a link is doubtful only when under both another point is nearly as near (or nearer) than the
  one taken; the score is the ratio of the two distances (above 1: another point was nearer).
  Using the better of the two predictions keeps a wrong link from also casting doubt on the
  right link after it, whose velocity prediction the wrong one spoils;
* a link another result (``other``) does not make: its two points are not both matched to
  one and the same track of the other result (as ``seedtrack compare`` marks them);
* a run of interpolated positions (a bound slave: no measurement supports it);
* a short track;
* a track that starts or ends inside the clip (an entry, an exit, or a broken track).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from seedtrack.tracking.tracks import Tracks

from ..scoring import DEFAULT_TOLERANCE, disagreeing_links

# A link is a close call when another point is at most this many times farther than its own.
CLOSE_CALL_RATIO = 0.6
# Fixed scores rank the other kinds between clear close calls and mild ones.
DISAGREEMENT_SCORE = 0.95
INTERPOLATED_SCORE = 0.9
SHORT_SCORE = 0.8
END_SCORE = 0.5
# A track is short below this many frames, or this fraction of the clip.
SHORT_FRAMES = 5
SHORT_FRACTION = 0.05
# A detection this near a track's point (pixels) is the one it holds.
SAME_POINT = 0.5


def doubtful_places(
    tracks: Tracks,
    detections: list[np.ndarray] | None = None,
    n_frames: int | None = None,
    other: Tracks | None = None,
    tolerance: float = DEFAULT_TOLERANCE,
) -> list[dict]:
    """The places to review, most doubtful first.

    Parameters
    ----------
    tracks : Tracks
    detections : list of ndarray of shape (M_k, 2), optional
        Detected positions in each 0-based frame k of the clip, pixels; by default the tracks'
        own points stand for them.
    n_frames : int, optional
        Frames in the clip (default: up to the last frame of the tracks).
    other : Tracks, optional
        A second result for the same clip: the links it does not make are doubtful.
    tolerance : float
        Distance within which points of ``other`` match points of ``tracks``, pixels.

    Returns
    -------
    list of dict
        ``frame`` (0-based), ``track`` (id), ``kind`` (``close call``, ``disagreement``,
        ``interpolated``, ``short``, ``start``, ``end``), ``score`` (higher is more doubtful) and ``text``.

    Example
    -------
    >>> swapped = Tracks.from_rows([1, 1, 1, 2, 2, 2], [0, 1, 2] * 2, [0, 1, 12, 10, 11, 2], [0] * 6)
    >>> [(p["frame"], p["track"], p["kind"]) for p in doubtful_places(swapped)][:2]
    [(2, 1, 'close call'), (2, 2, 'close call')]
    """
    places = _close_calls(tracks, detections)
    if other is not None and tracks.n_tracks and other.n_tracks:
        rows, columns = np.nonzero(disagreeing_links(tracks, other, tolerance))
        for row, column in zip(rows.tolist(), columns.tolist()):
            places.append(_place(tracks.first_frame + column, tracks.track_ids[row], "disagreement", DISAGREEMENT_SCORE, "the other result links it elsewhere"))
    present, slave, ids, offset = tracks.present, tracks.interpolated, tracks.track_ids, tracks.first_frame
    last_frame = (n_frames if n_frames is not None else offset + tracks.n_frames) - 1
    short = max(SHORT_FRAMES, SHORT_FRACTION * (last_frame + 1))
    # Runs of interpolated positions: where one starts and where it stops.
    edges = np.diff(np.pad(slave, ((0, 0), (1, 1))).astype(np.int8), axis=1)
    for (row, start), (_, stop) in zip(np.argwhere(edges == 1).tolist(), np.argwhere(edges == -1).tolist()):
        length = stop - start
        places.append(_place(offset + start, ids[row], "interpolated", INTERPOLATED_SCORE, f"{length} interpolated frame{'s' * (length != 1)}"))
    rows = np.flatnonzero(present.any(axis=1))
    length = present[rows].sum(axis=1)
    # argmax refuses an empty axis, which a set without tracks has.
    first = offset + (np.argmax(present[rows], axis=1) if rows.size else rows)
    last = offset + present.shape[1] - 1 - (np.argmax(present[rows, ::-1], axis=1) if rows.size else rows)
    for row, count, start, end in zip(rows.tolist(), length.tolist(), first.tolist(), last.tolist()):
        if count < short:
            places.append(_place(start, ids[row], "short", SHORT_SCORE, f"only {count} frame{'s' * (count != 1)}"))
        if start > 0:
            places.append(_place(start, ids[row], "start", END_SCORE, f"starts at frame {start}"))
        if end < last_frame:
            places.append(_place(end, ids[row], "end", END_SCORE, f"ends at frame {end}"))
    places.sort(key=lambda place: (-place["score"], place["frame"], place["track"]))
    return places


def _close_calls(tracks: Tracks, detections: list[np.ndarray] | None) -> list[dict]:
    xy, present = tracks.xy, tracks.present
    measured = present & ~tracks.interpolated
    places = []
    for column in range(1, tracks.n_frames):
        rows = np.flatnonzero(measured[:, column] & present[:, column - 1])
        if rows.size == 0:
            continue
        frame = tracks.first_frame + column
        if detections is not None and frame < len(detections) and len(detections[frame]):
            candidates = np.asarray(detections[frame], float)
        else:
            candidates = xy[present[:, column], column]
        if len(candidates) < 2:
            continue
        tree = cKDTree(candidates)
        taken = xy[rows, column]
        previous = xy[rows, column - 1]
        before = xy[rows, column - 2] if column >= 2 else np.full_like(previous, np.nan)
        velocity = np.where(np.isnan(before), 0.0, previous - before)
        ratio = np.minimum(_ratio(tree, previous, taken), _ratio(tree, previous + velocity, taken))
        for row, value in zip(rows[ratio >= CLOSE_CALL_RATIO].tolist(), ratio[ratio >= CLOSE_CALL_RATIO].tolist()):
            text = "another point is nearer" if value > 1 else "another point is nearly as near"
            places.append(_place(frame, int(tracks.track_ids[row]), "close call", round(value, 3), text))
    return places


def _ratio(tree: cKDTree, predicted: np.ndarray, taken: np.ndarray) -> np.ndarray:
    """Distance from the prediction to the point taken over that to the nearest other point."""
    own = np.hypot(*(taken - predicted).T)
    distance, index = tree.query(predicted, k=2)
    nearest_is_taken = np.hypot(*(tree.data[index[:, 0]] - taken).T) <= SAME_POINT
    other = np.where(nearest_is_taken, distance[:, 1], distance[:, 0])
    return own / np.maximum(other, 1e-9)


def _place(frame: int, track: int, kind: str, score: float, text: str) -> dict:
    return {"frame": int(frame), "track": int(track), "kind": kind, "score": float(score), "text": text}
