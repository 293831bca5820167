"""CLEAR-MOT and IDF1 agree with py-motmetrics on generated cases with switches, misses and gaps."""

import motmetrics as mm
import numpy as np
import pytest

from frame_points import frames_of
from seedtrack.tracking.clear_mot import clear_mot
from seedtrack.tracking.tracks import Tracks


def _truth(rng, n_tracks, n_frames):
    start = rng.uniform(0, 200, (n_tracks, 1, 2))
    steps = rng.normal(0, 3, (n_tracks, n_frames, 2))
    xy = start + np.cumsum(steps, axis=1)
    # Tracks that start late and end early.
    for row in range(n_tracks):
        begin, end = sorted(rng.integers(0, n_frames + 1, 2))
        if end - begin >= 2 and rng.random() < 0.4:
            xy[row, :begin] = np.nan
            xy[row, end:] = np.nan
    return Tracks.from_dense(xy=xy, measurement=np.zeros(xy.shape[:2], dtype=np.int64), first_frame=3)


def _result(rng, truth, swaps, drop, false_tracks, late_frames):
    xy = truth.xy + rng.normal(0, 0.6, truth.xy.shape)
    n_tracks, n_frames = xy.shape[:2]
    for _ in range(swaps):  # ID switches: two tracks exchange their futures.
        a, b = rng.choice(n_tracks, 2, replace=False)
        frame = rng.integers(1, n_frames)
        xy[[a, b], frame:] = xy[[b, a], frame:]
    xy[rng.random(xy.shape[:2]) < drop] = np.nan  # missed points
    extra = rng.uniform(0, 200, (false_tracks, n_frames, 2)) + np.cumsum(rng.normal(0, 3, (false_tracks, n_frames, 2)), axis=1)
    extra[rng.random(extra.shape[:2]) < 0.3] = np.nan
    xy = np.concatenate([xy, extra])[rng.permutation(n_tracks + false_tracks)]
    ids = rng.choice(10_000, xy.shape[0], replace=False)
    # A result that starts late: its first frames are missing, and its frames must stay aligned.
    xy = xy[:, late_frames:]
    return Tracks.from_dense(xy=xy, measurement=np.zeros(xy.shape[:2], dtype=np.int64), first_frame=truth.first_frame + late_frames, track_ids=ids)


def _motmetrics(result, truth, tolerance):
    accumulator = mm.MOTAccumulator()
    for frame, (o, a), (h, b) in frames_of(result, truth):
        distance = np.sqrt(mm.distances.norm2squared_matrix(a, b, max_d2=tolerance**2))
        accumulator.update(o, h, distance, frameid=frame)
    metrics = ["mota", "motp", "idf1", "num_switches", "num_fragmentations", "num_misses", "num_false_positives", "num_matches"]
    return mm.metrics.create().compute(accumulator, metrics=metrics, name="case").iloc[0]


@pytest.mark.parametrize(
    "seed, swaps, drop, false_tracks, late_frames, tolerance",
    [
        (0, 0, 0.0, 0, 0, 2.0),
        (1, 3, 0.0, 0, 0, 2.0),
        (2, 0, 0.15, 0, 0, 2.0),
        (3, 4, 0.1, 3, 0, 2.5),
        (4, 6, 0.2, 5, 2, 1.5),
        (5, 8, 0.05, 2, 0, 4.0),
        (6, 10, 0.3, 8, 0, 8.0),
    ],
)
def test_agrees_with_motmetrics(seed, swaps, drop, false_tracks, late_frames, tolerance):
    rng = np.random.default_rng(seed)
    truth = _truth(rng, 25, 30)
    result = _result(rng, truth, swaps, drop, false_tracks, late_frames)
    ours = clear_mot(result, truth, tolerance)
    theirs = _motmetrics(result, truth, tolerance)
    assert ours.mota == pytest.approx(theirs["mota"], abs=1e-9)
    assert ours.motp == pytest.approx(theirs["motp"], abs=1e-9)
    assert ours.idf1 == pytest.approx(theirs["idf1"], abs=1e-9)
    assert ours.num_switches == theirs["num_switches"]
    assert ours.num_fragmentations == theirs["num_fragmentations"]
    assert ours.num_misses == theirs["num_misses"]
    assert ours.num_false_positives == theirs["num_false_positives"]
    assert ours.num_matches == theirs["num_matches"]
    if swaps:
        assert ours.num_switches > 0
    if drop:
        assert ours.num_misses > 0


def test_perfect_result_scores_one():
    truth = _truth(np.random.default_rng(9), 10, 12)
    scores = clear_mot(truth, truth, 1.0)
    assert (scores.mota, scores.idf1, scores.motp, scores.num_switches) == (1.0, 1.0, 0.0, 0)
