import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from detection.blobs import BlobOptions, detect_blobs
from data.dish import DishSpec, make_dish_scene


def nearest_errors(found_x, found_y, truth_xy):
    distance = np.hypot(found_x[:, None] - truth_xy[None, :, 0], found_y[:, None] - truth_xy[None, :, 1])
    rows, cols = linear_sum_assignment(distance)
    return distance[rows, cols]


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_every_generated_seed_found_within_half_a_pixel(seed):
    scene = make_dish_scene(DishSpec(random_seed=seed, frames=3))
    for k in range(3):
        table = detect_blobs(scene.render(k))
        truth = scene.truth.xy[:, k]
        assert len(table["x"]) == len(truth)
        errors = nearest_errors(table["x"], table["y"], truth)
        assert errors.max() < 0.5


def test_light_blobs_on_dark_background():
    image = np.full((40, 60), 20, np.uint8)
    image[10:13, 20:23] = 200
    image[30:32, 50:54] = 220
    table = detect_blobs(image, BlobOptions(polarity="light"))
    np.testing.assert_allclose(np.column_stack((table["x"], table["y"])), [[21, 11], [51.5, 30.5]], atol=0.05)
    np.testing.assert_array_equal(table["area"], [9, 8])


def test_area_limits_drop_small_and_large_blobs():
    image = np.full((50, 50), 230, np.uint8)
    image[5, 5] = 10  # one pixel: dust
    image[20:24, 20:24] = 10  # 16 pixels: a seed
    image[30:45, 30:45] = 10  # 225 pixels: too large
    table = detect_blobs(image, BlobOptions(min_area_px=4, max_area_px=100, threshold=128))
    assert table["area"].tolist() == [16]


def test_empty_frame_gives_no_detections():
    table = detect_blobs(np.full((30, 30, 3), 200, np.uint8))
    assert all(len(column) == 0 for column in table.values())


def test_min_area_above_max_area_is_refused():
    with pytest.raises(ValueError, match="exceeds max area"):
        BlobOptions(min_area_px=50, max_area_px=10)
