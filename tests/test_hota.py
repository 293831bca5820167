"""HOTA equals TrackEval's (the reference code, fed the same per-frame similarities) within 1e-6."""

import numpy as np
import pytest
from frame_points import frames_of
from trackeval.metrics import HOTA

from seedtrack.tracking.hota import ALPHAS, hota
from seedtrack.tracking.tracks import Tracks


def _walkers(rng, n_tracks, n_frames, first_frame=0):
    xy = rng.uniform(0, 100, (n_tracks, 1, 2)) + np.cumsum(rng.normal(0, 2, (n_tracks, n_frames, 2)), axis=1)
    for row in range(n_tracks):  # some tracks start late and end early
        begin, end = sorted(rng.integers(0, n_frames + 1, 2))
        if end - begin >= 2 and rng.random() < 0.4:
            xy[row, :begin] = np.nan
            xy[row, end:] = np.nan
    return xy


def _tracks(xy, first_frame=0, ids=None):
    return Tracks.from_dense(xy=xy, measurement=np.zeros(xy.shape[:2], dtype=np.int64), first_frame=first_frame, track_ids=ids)


def _result(rng, truth_xy, noise, swaps, drop, false_tracks, late):
    xy = truth_xy + rng.normal(0, noise, truth_xy.shape)
    n_tracks, n_frames = xy.shape[:2]
    for _ in range(swaps):
        a, b = rng.choice(n_tracks, 2, replace=False)
        frame = rng.integers(1, n_frames)
        xy[[a, b], frame:] = xy[[b, a], frame:]
    xy[rng.random(xy.shape[:2]) < drop] = np.nan
    extra = _walkers(rng, false_tracks, n_frames)
    xy = np.concatenate([xy, extra])[rng.permutation(n_tracks + false_tracks)]
    return xy[:, late:]


def _trackeval(result, truth, tolerance):
    """TrackEval's HOTA on the per-frame ids and similarities, computed here independently."""
    gt_ids, tr_ids, similarity = [], [], []
    for _, (g, a), (t, b) in frames_of(result, truth):
        distance = np.sqrt(((a[:, None, :] - b[None, :, :]) ** 2).sum(-1))
        gt_ids.append(g)
        tr_ids.append(t)
        similarity.append(np.maximum(0.0, 1.0 - distance / tolerance))
    data = {
        "num_gt_dets": int(truth.present.sum()),
        "num_tracker_dets": int(result.present.sum()),
        "num_gt_ids": truth.n_tracks,
        "num_tracker_ids": result.n_tracks,
        "gt_ids": gt_ids,
        "tracker_ids": tr_ids,
        "similarity_scores": similarity,
    }
    with np.errstate(invalid="ignore", divide="ignore"):
        return HOTA().eval_sequence(data)


@pytest.mark.parametrize(
    "seed, noise, swaps, drop, false_tracks, late",
    [
        (1, 0.3, 0, 0.0, 0, 0),  # near-perfect result
        (2, 0.8, 4, 0.1, 3, 0),  # switches, misses, false tracks
        (3, 1.2, 8, 0.3, 6, 5),  # a poor result that starts late
    ],
)
def test_hota_matches_trackeval(seed, noise, swaps, drop, false_tracks, late):
    rng = np.random.default_rng(seed)
    truth_xy = _walkers(rng, 12, 40)
    truth = _tracks(truth_xy, first_frame=2)
    result = _tracks(_result(rng, truth_xy, noise, swaps, drop, false_tracks, late), first_frame=2 + late)
    tolerance = 3.0
    ours = hota(result, truth, tolerance)
    theirs = _trackeval(result, truth, tolerance)
    for name, field in (("hota_alpha", "HOTA"), ("det_a_alpha", "DetA"), ("ass_a_alpha", "AssA"), ("loc_a_alpha", "LocA")):
        np.testing.assert_allclose(getattr(ours, name), theirs[field], atol=1e-6, rtol=0)
    assert abs(ours.hota - theirs["HOTA"].mean()) < 1e-6
    assert 0.0 < ours.hota < 1.0


def test_hota_of_truth_is_one_and_of_nothing_zero():
    rng = np.random.default_rng(4)
    truth = _tracks(_walkers(rng, 5, 10))
    assert hota(truth, truth).hota == pytest.approx(1.0)
    empty = Tracks.from_rows([], [], [], [])
    scores = hota(empty, truth)
    assert scores.hota == 0.0 and scores.loc_a == 1.0
    assert len(ALPHAS) == 19
