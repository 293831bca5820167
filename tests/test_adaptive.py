"""The motion measured on a sample of a large clip, and every point tracked once with it."""

import numpy as np
import pytest

import seedtrack.tracking.adaptive as adaptive
from seedtrack.data.walkers import WalkerSpec, generate_walkers
from seedtrack.tracking.adaptive import measuring_sample, sample_frames, track_measured_motion
from seedtrack.tracking.goa import GOAConfig
from seedtrack.tracking.lifecycle import LifecycleConfig, goa_updown_open
from seedtrack.tracking.linking import link_goa, pass_steps
from seedtrack.tracking.metrics import score_tracks


def _walkers(count=400, frames=30, seed=3):
    return generate_walkers(WalkerSpec(walkers=count, frames=frames, size=512 * (count / 300) ** 0.5, missed=0.05, random_seed=seed))


def test_the_sample_is_the_middle_frames_and_at_least_the_fewest_frames():
    assert sample_frames([100] * 1000) == range(400, 600)
    # Too dense for SAMPLE_FRAMES frames: that many, and a window cut from them.
    assert sample_frames([5000] * 100) == range(30, 70)
    assert sample_frames([5000] * 7) == range(0, 7)
    assert sample_frames([]) == range(0, 0)


def test_a_clip_no_larger_than_the_sample_is_the_sample():
    frames, _ = _walkers(count=100, frames=20)
    assert measuring_sample(frames) is frames


def test_a_window_of_the_view_holds_the_sample_where_the_fewest_frames_hold_more(monkeypatch):
    monkeypatch.setattr(adaptive, "SAMPLE_POINTS", 2000)
    frames, _ = _walkers(count=400, frames=10)
    sample = measuring_sample(frames)
    assert len(sample) == 10
    held = sum(f.shape[0] for f in sample)
    assert 2000 <= held < 2100
    # One square about the centre, the same in every frame: the farthest point of a frame from
    # the centre is no farther than the square's half side.
    centre = (np.min([f.min(axis=0) for f in frames], axis=0) + np.max([f.max(axis=0) for f in frames], axis=0)) / 2
    half = max(np.abs(f - centre).max() for f in sample)
    for whole, part in zip(frames, sample):
        inside = np.abs(whole - centre).max(axis=1) <= half
        assert np.array_equal(whole[inside], part)


def _open(moved, fitted):
    return goa_updown_open(moved, fitted, LifecycleConfig())


def test_only_the_last_pass_tracks_every_point_of_a_large_clip(monkeypatch):
    monkeypatch.setattr(adaptive, "SAMPLE_POINTS", 3000)
    frames, truth = _walkers()
    seen = []

    def counting(moved, fitted):
        seen.append(sum(f.shape[0] for f in moved))
        return _open(moved, fitted)

    sampled, _ = track_measured_motion(frames, GOAConfig(), counting)
    total = sum(f.shape[0] for f in frames)
    assert len(seen) == 2 + adaptive.REFITS
    assert max(seen[:-1]) <= 3000 and seen[-1] == total
    monkeypatch.setattr(adaptive, "SAMPLE_POINTS", 10**9)
    whole, _ = track_measured_motion(frames, GOAConfig(), _open)
    # Measured on a tenth of the points, the motion tracks as well as measured on all of them.
    assert score_tracks(sampled, truth, 0.5).link_error <= score_tracks(whole, truth, 0.5).link_error + 0.002


def test_progress_is_called_as_announced_when_the_motion_is_measured_on_a_sample(monkeypatch):
    monkeypatch.setattr(adaptive, "SAMPLE_POINTS", 3000)
    # Longer than SAMPLE_FRAMES: the sample's passes span fewer frames.
    frames, _ = _walkers(count=150, frames=60)
    calls = []
    link_goa(frames, progress=lambda n=1: calls.append(n))
    assert sum(calls) == pass_steps("goa-updown", [f.shape[0] for f in frames]) < 3 * pass_steps("goa-updown", [0] * len(frames), "smooth")


def test_given_first_links_hold_for_the_whole_clip_not_the_sample(monkeypatch):
    monkeypatch.setattr(adaptive, "SAMPLE_POINTS", 3000)
    frames, _ = _walkers(count=200)
    # The last points of the first frame: past the end of the sample's first frame, which is
    # another frame, and cut to a window.
    last = np.arange(frames[0].shape[0] - 5, frames[0].shape[0])
    given = np.column_stack((last, np.full(5, -1)))
    tracks, _ = link_goa(frames, "goa", first_links=given)
    # GOA follows the tracks of the first links given, and only those: the sample's passes, whose
    # first frames are others, chose their own.
    assert tracks.n_tracks == 5
    assert sorted(tracks.point_measurement[tracks.point_column == 0].tolist()) == last.tolist()
