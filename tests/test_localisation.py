"""Each detection's localisation error (``ep``): near the truth, larger for dimmer objects, and
carried from detect to track as the floor of the motion noise."""

import re
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

import seedtrack
from seedtrack.cli import main
from seedtrack.data.csvio import read_table
from seedtrack.data.dish import DishSpec, write_dish_clip
from seedtrack.data.psmg import PSMGSpec, generate_psmg
from seedtrack.data.spotfield import SpotFieldSpec, make_spot_field
from seedtrack.detection.blobs import BlobOptions, detect_blobs
from seedtrack.detection.clip import ClipDetector
from seedtrack.points import group_points, link_points
from seedtrack.settings import LinkSettings
from seedtrack.tracking.metrics import match_frame


def _estimated_and_true(snr: float) -> tuple[np.ndarray, np.ndarray]:
    """ep and true error per axis of the spots of two small generated frames."""
    estimates, errors = [], []
    for seed in (7, 8):
        field = make_spot_field(SpotFieldSpec(width=256, height=256, spots=60, touching_pairs=0, rings=0, snr=snr, random_seed=seed))
        found = ClipDetector(roi="none", detector="spot").detect(field.image)
        points = np.column_stack((found["x"], found["y"]))
        rows, cols = match_frame(points, field.xy, 2.0)
        estimates.append(found["ep"][rows])
        errors.append(points[rows] - field.xy[cols])
    return np.concatenate(estimates), np.concatenate(errors)


def test_the_spot_estimate_is_near_the_true_error_and_grows_as_spots_dim():
    typical = {}
    for snr in (3, 8):
        ep, error = _estimated_and_true(snr)
        rms_ep, rms_true = np.sqrt(np.mean(ep**2)), np.sqrt(np.mean(error**2))
        assert 0.7 < rms_ep / rms_true < 1.3, (snr, rms_ep, rms_true)
        typical[snr] = np.median(ep)
    assert typical[3] > 2 * typical[8]


def test_within_a_frame_fainter_spots_get_larger_errors():
    rows, columns = np.mgrid[0:80, 0:200].astype(np.float32)
    light = np.full(rows.shape, 10.0, np.float32)
    centres = [(20.0 + 40 * k + 0.3 * k, 20.0 + 40 * j + 0.2 * k) for k in range(5) for j in range(2)]
    for k, (x, y) in enumerate(centres):
        light += (20.0 if k % 2 else 80.0) * np.exp(-((columns - x) ** 2 + (rows - y) ** 2) / 4.5)
    frame = np.random.default_rng(3).poisson(light).astype(np.float32)
    found = ClipDetector(roi="none", detector="spot").detect(frame)
    points = np.column_stack((found["x"], found["y"]))
    rows_found, cols = match_frame(points, np.array(centres), 2.0)
    assert rows_found.size == len(centres)
    faint = (cols % 2).astype(bool)
    ep = found["ep"][rows_found]
    assert ep[faint].min() > 2 * ep[~faint].max()


def test_the_blob_estimate_grows_with_the_noise():
    rows, columns = np.mgrid[0:120, 0:160]
    disc = np.where((columns - 70.3) ** 2 + (rows - 59.6) ** 2 <= 16, 60.0, 200.0)
    estimates = []
    for noise in (2.0, 8.0):
        frame = np.clip(disc + np.random.default_rng(1).normal(0, noise, disc.shape), 0, 255).astype(np.uint8)
        found = detect_blobs(frame, BlobOptions(polarity="dark"))
        assert len(found["x"]) == 1
        estimates.append(found["ep"][0])
    assert 0 < estimates[0] < estimates[1] < 0.5


def _noise_line(motion: str) -> float:
    return float(re.search(r"noise ([0-9.]+) px/frame", motion).group(1))


def test_a_points_table_with_ep_floors_the_motion_noise_it_is_linked_with():
    # PSMG points lie exactly on smooth paths: the fitted noise is the least there is; given
    # positions known to 0.5 px, it is at least what that error puts on a velocity change.
    frames, _ = generate_psmg(PSMGSpec(trajectories=15, frames=12, random_seed=3))
    points = pd.DataFrame([(k, x, y) for k, f in enumerate(frames) for x, y in f], columns=["frame", "x", "y"])
    plain = seedtrack.link(points)
    floored = seedtrack.link(points.assign(ep=0.5))
    assert _noise_line(plain.attrs["motion"]) < 0.2
    assert _noise_line(floored.attrs["motion"]) >= round(np.sqrt(6) * 0.5, 2)
    assert plain["track_id"].nunique() == floored["track_id"].nunique() == 15
    assert (floored["ep"] == 0.5).all()
    # --verbose says where the floor came from.
    said: list[str] = []
    table = {name: points[name].to_numpy() for name in points.columns} | {"ep": np.full(len(points), 0.5)}
    link_points(group_points(table, "points"), LinkSettings(), say=said.append, verbose=True)
    assert "  localisation error of the points 0.500 px per axis: the noise is never fitted below sqrt(6) x that, 1.22 px/frame" in said


def test_the_ep_column_goes_from_detect_through_track(tmp_path):
    write_dish_clip(DishSpec(seeds=12, frames=6, width=240, height=180), tmp_path)
    command = [sys.executable, "-m", "seedtrack"]
    detected = subprocess.run([*command, "detect", tmp_path / "clip.mp4", "--out", tmp_path / "detections.csv"], capture_output=True, text=True)
    assert detected.returncode == 0, detected.stderr
    detections = read_table(tmp_path / "detections.csv", others_as_text=True)
    ep = detections["ep"].astype(float)
    assert np.isfinite(ep).all() and (ep > 0).all() and (ep < 0.2).all()
    tracked = subprocess.run([*command, "track", tmp_path / "detections.csv", "--out", tmp_path / "tracks.csv"], capture_output=True, text=True)
    assert tracked.returncode == 0, tracked.stderr
    tracks = read_table(tmp_path / "tracks.csv", others_as_text=True)
    # Each measured row carries its detection's ep, as written.
    by_point = {(f, x, y): e for f, x, y, e in zip(detections["frame"], detections["x"], detections["y"], detections["ep"])}
    measured = tracks["interpolated"] == 0
    assert measured.sum() == len(by_point)
    assert all(by_point[key] == e for key, e in zip(zip(tracks["frame"][measured], tracks["x"][measured], tracks["y"][measured]), tracks["ep"][measured]))


def test_a_bad_ep_is_one_line_exit_2(tmp_path, capsys):
    (tmp_path / "points.csv").write_text("frame,x,y,ep\n0,1,1,0.1\n1,2,1,abc\n2,3,1,\n")
    assert main(["track", str(tmp_path / "points.csv"), "--out", str(tmp_path / "tracks.csv")]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and "points.csv: line 3: column ep holds 'abc', not a number" in error, error
    assert not (tmp_path / "tracks.csv").exists()


def test_blank_nan_and_negative_ep_are_points_without_an_estimate():
    # trackpy writes NaN, and negative values where a spot's mass is below its background.
    table = {"frame": np.array([0, 1, 2, 3]), "x": np.arange(4.0), "y": np.zeros(4), "ep": np.array(["0.2", "", "-0.4", "nan"])}
    assert group_points(table, "points").localisation == 0.2
