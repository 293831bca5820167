"""The points of two track sets frame by frame, the way the reference packages are fed them
(py-motmetrics, TrackEval): a plain loop, kept apart from the code under test."""

import numpy as np


def frames_of(result, truth):
    """Yield ``(frame, (truth rows, truth xy), (result rows, result xy))`` over the frames
    either track set spans."""
    start = min(result.first_frame, truth.first_frame)
    stop = max(result.first_frame + result.n_frames, truth.first_frame + truth.n_frames)
    for frame in range(start, stop):
        yield frame, _present(truth, frame), _present(result, frame)


def _present(tracks, frame):
    column = frame - tracks.first_frame
    if not 0 <= column < tracks.n_frames:
        return np.zeros(0, int), np.zeros((0, 2))
    rows = np.flatnonzero(tracks.present[:, column])
    return rows, tracks.xy[rows, column]
