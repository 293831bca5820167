"""MSD, drift and velocity: random walkers of known step against theory and against trackpy."""

import numpy as np
import pandas as pd
import pytest
import trackpy

import seedtrack

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning", "ignore::FutureWarning")
from seedtrack.tracking.analysis import fit_msd

STEP = 1.5  # pixels per frame, standard deviation per axis
PIXEL, INTERVAL = 0.2, 0.05  # micrometres per pixel, seconds per frame


def _walkers(seed=0, n_tracks=400, n_frames=60, drift=(0.0, 0.0), missing=0.1):
    rng = np.random.default_rng(seed)
    steps = rng.normal(0, STEP, (n_tracks, n_frames, 2)) + np.array(drift)
    xy = rng.uniform(0, 500, (n_tracks, 1, 2)) + np.cumsum(steps, axis=1)
    track, frame = np.meshgrid(np.arange(n_tracks), np.arange(n_frames), indexing="ij")
    keep = rng.random((n_tracks, n_frames)) >= missing  # gaps: lags across them still count
    return pd.DataFrame({"track_id": track[keep], "frame": frame[keep], "x": xy[..., 0][keep], "y": xy[..., 1][keep]})


@pytest.fixture(scope="module")
def walkers():
    return _walkers()


def test_msd_of_random_walkers_is_theory_within_5_percent_and_trackpy_within_2(walkers):
    table = seedtrack.msd(walkers, pixel_size=PIXEL, frame_interval=INTERVAL, max_lag=10)
    np.testing.assert_allclose(table["lag_time"], np.arange(1, 11) * INTERVAL)
    # Two axes, each of variance STEP**2 per frame.
    theory = 2 * STEP**2 * table["lag"] * PIXEL**2
    assert np.all(np.abs(table["msd"] / theory - 1) < 0.05)
    theirs = trackpy.emsd(walkers.rename(columns={"track_id": "particle"}), mpp=PIXEL, fps=1 / INTERVAL, max_lagtime=10)
    np.testing.assert_allclose(table["msd"].to_numpy(), theirs.to_numpy(), rtol=0.02)
    D, alpha = fit_msd(table["lag_time"].to_numpy(), table["msd"].to_numpy())
    assert D == pytest.approx(STEP**2 * PIXEL**2 / (2 * INTERVAL), rel=0.05)  # MSD = 4 D t
    assert alpha == pytest.approx(1.0, abs=0.05)


def test_msd_per_track_pools_to_the_ensemble(walkers):
    per_track = seedtrack.msd(walkers, max_lag=5, per_track=True)
    ensemble = seedtrack.msd(walkers, max_lag=5)
    pooled = (per_track["msd"] * per_track["n"]).groupby(per_track["lag"]).sum() / per_track.groupby("lag")["n"].sum()
    np.testing.assert_allclose(pooled.to_numpy(), ensemble["msd"].to_numpy())
    assert set(per_track["track_id"]) == set(walkers["track_id"])


def test_drift_of_walkers_carried_by_a_current_is_the_current():
    walkers = _walkers(seed=1, n_tracks=300, n_frames=40, drift=(0.8, -0.3))
    table = seedtrack.drift(walkers, pixel_size=PIXEL, frame_interval=INTERVAL)
    assert table["frame"].tolist() == list(range(40))
    last = table.iloc[-1]
    assert last["time"] == pytest.approx(39 * INTERVAL)
    assert last["x"] == pytest.approx(0.8 * 39 * PIXEL, rel=0.05)
    assert last["y"] == pytest.approx(-0.3 * 39 * PIXEL, rel=0.1)
    theirs = trackpy.compute_drift(walkers.rename(columns={"track_id": "particle"}))
    np.testing.assert_allclose(table["x"].to_numpy()[1:], theirs["x"].to_numpy() * PIXEL, atol=1e-9)


def test_velocity_per_track_in_the_units_given():
    tracks = pd.DataFrame({"track_id": [4, 4, 4, 9], "frame": [0, 1, 3, 0], "x": [0.0, 3.0, 3.0, 1.0], "y": [0.0, 4.0, 0.0, 1.0]})
    table = seedtrack.velocity(tracks, pixel_size=2.0, frame_interval=0.5)
    assert table["track_id"].tolist() == [4]  # track 9 has a single point
    row = table.iloc[0]
    assert row["duration"] == 1.5 and row["path_length"] == pytest.approx(2.0 * (5 + 4))
    assert row["mean_speed"] == pytest.approx(18 / 1.5)
    assert (row["vx"], row["vy"]) == pytest.approx((2.0 * 3 / 1.5, 0.0))


def test_units_must_be_positive(walkers):
    with pytest.raises(ValueError, match="pixel_size"):
        seedtrack.msd(walkers, pixel_size=0)


def test_msd_with_the_drift_subtracted_is_the_walk_and_trackpys():
    walkers = _walkers(seed=2, n_tracks=300, n_frames=40, drift=(1.0, 0.5))
    carried = seedtrack.msd(walkers, max_lag=10)
    table = seedtrack.msd(walkers, max_lag=10, subtract_drift=True)
    theory = 2 * STEP**2 * table["lag"]
    assert np.all(np.abs(table["msd"] / theory - 1) < 0.05)
    assert carried["msd"].iloc[-1] > 1.5 * theory.iloc[-1]  # the current adds (v t)^2
    particles = walkers.rename(columns={"track_id": "particle"})
    theirs = trackpy.emsd(trackpy.subtract_drift(particles, trackpy.compute_drift(particles)).reset_index(drop=True), mpp=1.0, fps=1.0, max_lagtime=10)
    np.testing.assert_allclose(table["msd"].to_numpy(), theirs.to_numpy(), rtol=0.02)
