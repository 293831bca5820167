"""Tests of data.dish: the synthetic rotating-dish clip and its ground truth."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from seedtrack.data.csvio import read_table
from seedtrack.data.dish import DishSpec, make_dish_scene, write_dish_clip
from seedtrack.data.frames import open_frames
from seedtrack.tracking.tracks import Tracks

# Between the dimmest dish (215) and the seed bodies (40-60): a seed's blurred rim is still
# captured by a one-pixel dilation.
SEED_THRESHOLD = 200


@pytest.fixture(scope="module")
def scene():
    return make_dish_scene(DishSpec(frames=4))


def seed_centroids(image: np.ndarray, background: np.ndarray, centre, radius: float) -> np.ndarray:
    """Darkness-weighted centroids (x, y) of dark blobs on the dish, in pixels.

    Weights are the darkening below the empty dish, which is linear in how much of a pixel a
    seed covers, so the centroid is unbiased by the threshold.
    """
    grey = image[..., 0].astype(float)
    rows, columns = np.mgrid[0 : grey.shape[0], 0 : grey.shape[1]]
    on_dish = np.hypot(columns - centre[0], rows - centre[1]) < radius - 3
    mask = cv2.dilate(((grey < SEED_THRESHOLD) & on_dish).astype(np.uint8), np.ones((3, 3), np.uint8))
    count, labels = cv2.connectedComponents(mask, connectivity=8)
    weight = np.clip(background - grey, 0, None) * (labels > 0)
    total = np.bincount(labels.ravel(), weight.ravel(), count)[1:]
    x = np.bincount(labels.ravel(), (weight * columns).ravel(), count)[1:] / total
    y = np.bincount(labels.ravel(), (weight * rows).ravel(), count)[1:] / total
    return np.column_stack([x, y])


def nearest_distance(truth: np.ndarray, found: np.ndarray) -> np.ndarray:
    """For each truth position, the distance to the nearest found centroid."""
    return np.linalg.norm(truth[:, None] - found[None], axis=2).min(axis=1)


def test_rendered_seed_centroids_match_truth_to_a_tenth_of_a_pixel(scene):
    for frame in range(scene.spec.frames):
        found = seed_centroids(scene.render(frame), scene.background, scene.centre, scene.radius)
        assert len(found) == scene.spec.seeds
        assert nearest_distance(scene.truth.xy[:, frame], found).max() < 0.1


def test_centroids_survive_the_mp4_round_trip(tmp_path):
    spec = DishSpec(frames=3, random_seed=5)
    scene = write_dish_clip(spec, tmp_path / "out")
    with open_frames(tmp_path / "out" / "clip.mp4") as source:
        assert (source.frame_count, source.size, source.fps) == (3, (640, 480), 25.0)
        for frame, image in source:
            found = seed_centroids(image, scene.background, scene.centre, scene.radius)
            assert nearest_distance(scene.truth.xy[:, frame], found).max() < 0.3


def test_truth_csv_holds_every_seed_in_every_frame(tmp_path):
    spec = DishSpec(seeds=12, frames=3, hidden_probability=0.3, width=200, height=160)
    scene = write_dish_clip(spec, tmp_path)
    table = read_table(tmp_path / "truth.csv", required=("track_id", "frame", "x", "y", "interpolated"))
    back = Tracks.from_rows(**table)
    np.testing.assert_allclose(back.xy, scene.truth.xy, atol=1e-4)
    np.testing.assert_array_equal(back.interpolated, ~scene.visible)


def test_truth_layout(scene):
    spec = scene.spec
    assert scene.truth.xy.shape == (spec.seeds, spec.frames, 2)
    assert scene.truth.present.all()
    np.testing.assert_array_equal(scene.truth.measurement, np.arange(spec.seeds)[:, None].repeat(spec.frames, 1))
    assert scene.visible.shape == (spec.seeds, spec.frames) and scene.visible.all()
    assert scene.centre == (319.5, 239.5)
    assert scene.radius == pytest.approx(0.46 * 480)


def test_seeds_keep_apart_and_on_the_dish(scene):
    xy = scene.truth.xy[:, 0]
    distance = np.linalg.norm(xy[:, None] - xy[None], axis=2) + np.eye(len(xy)) * 1e9
    assert distance.min() >= 2.5 * scene.spec.seed_length
    assert np.linalg.norm(xy - scene.centre, axis=1).max() <= 0.95 * scene.radius


def test_dish_turns_rigidly_at_the_rim_speed(scene):
    xy, centre = scene.truth.xy, np.array(scene.centre)
    radius_of_each = np.linalg.norm(xy - centre, axis=2)
    np.testing.assert_allclose(radius_of_each, radius_of_each[:, :1].repeat(xy.shape[1], 1), atol=1e-9)
    speed = np.linalg.norm(np.diff(xy, axis=1), axis=2)
    rim_speed = scene.spec.rim_speed
    assert 0.85 * rim_speed < speed.max() < 0.95 * rim_speed * 1.03
    assert speed.min() < 5
    # One dish: every seed turns by the same angle in a frame.
    angle = np.arctan2(*(xy - centre)[..., ::-1].transpose(2, 0, 1))
    turn = np.angle(np.exp(1j * np.diff(angle, axis=1)))
    np.testing.assert_allclose(turn, turn[:1].repeat(len(turn), 0), atol=1e-9)
    np.testing.assert_allclose(turn[0], rim_speed / scene.radius, rtol=0.03)


def test_hidden_seeds_are_not_drawn():
    scene = make_dish_scene(DishSpec(frames=3, hidden_probability=0.3, random_seed=2))
    assert 0 < (~scene.visible).sum() < scene.visible.size
    assert (~scene.visible[:, 0]).any()
    for frame in range(3):
        image = scene.render(frame)
        found = seed_centroids(image, scene.background, scene.centre, scene.radius)
        shown = scene.visible[:, frame]
        assert len(found) == shown.sum()
        distance = nearest_distance(scene.truth.xy[:, frame], found)
        assert distance[shown].max() < 0.1
        assert distance[~shown].min() > 10
    np.testing.assert_array_equal(scene.truth.interpolated, ~scene.visible)


def test_scene_looks_like_a_lit_dish_on_a_dark_background(scene):
    image = scene.render(0)
    assert image.shape == (480, 640, 3) and image.dtype == np.uint8
    assert np.array_equal(image[..., 0], image[..., 2])
    grey = image[..., 0].astype(float)
    assert 70 <= grey[:20, :20].mean() <= 90
    rows, columns = np.mgrid[0:480, 0:640]
    dish = scene.background[np.hypot(columns - scene.centre[0], rows - scene.centre[1]) < scene.radius - 2]
    assert 213 <= dish.min() and dish.max() <= 236 and dish.max() - dish.min() > 10
    seeds = np.rint(scene.truth.xy[:, 0]).astype(int)
    assert grey[seeds[:, 1], seeds[:, 0]].max() < 100


def test_same_spec_gives_the_same_frames_and_another_seed_does_not(scene):
    again = make_dish_scene(DishSpec(frames=4))
    for frame in range(4):
        assert np.array_equal(scene.render(frame), again.render(frame))
    other = make_dish_scene(DishSpec(frames=4, random_seed=1))
    assert not np.allclose(other.truth.xy, scene.truth.xy)


def test_written_clip_is_reproducible(tmp_path):
    spec = DishSpec(seeds=10, frames=3, width=160, height=120)
    write_dish_clip(spec, tmp_path / "a")
    write_dish_clip(spec, tmp_path / "b")
    for name in ("clip.mp4", "truth.csv"):
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes()


def test_render_rejects_frames_outside_the_clip(scene):
    with pytest.raises(IndexError):
        scene.render(scene.spec.frames)
    with pytest.raises(IndexError):
        scene.render(-1)


@pytest.mark.parametrize(
    "changes",
    [
        {"seeds": -1},
        {"frames": 0},
        {"width": 8},
        {"rim_speed": -1.0},
        {"hidden_probability": 1.5},
        {"fps": 0.0},
        {"seed_width": 8.0},
        {"noise_sigma": -1.0},
        {"seeds": 2.5},
    ],
)
def test_nonsense_spec_is_a_value_error(changes):
    with pytest.raises(ValueError, match="bad DishSpec"):
        DishSpec(**changes)


def test_too_many_seeds_for_the_dish_is_a_value_error():
    with pytest.raises(ValueError, match="fit on the dish"):
        make_dish_scene(DishSpec(seeds=500, width=160, height=120))
