import cv2
import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from seedtrack.data.dish import DishSpec, make_dish_scene
from seedtrack.detection.blobs import BlobOptions, choose_polarity, detect_blobs, to_gray
from seedtrack.detection.roi import dish_mask, find_dish
from seedtrack.tracking.metrics import match_frame


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
    with pytest.raises(ValueError, match="exceeds max_area_px"):
        BlobOptions(min_area_px=50, max_area_px=10)


def test_polarity_auto_finds_dark_and_light_objects():
    for objects, field in ((30, 200), (220, 40)):
        image = np.full((60, 80), field, np.uint8)
        image[10:14, 10:14] = objects
        image[40:45, 50:54] = objects
        auto = detect_blobs(image)
        assert len(auto["x"]) == 2
        assert choose_polarity(image, np.full_like(image, field)) == ("dark" if objects < field else "light")


def test_uneven_light_does_not_decide_what_is_an_object():
    # A gradient of 120 grey levels across the frame, dark seeds 60 levels below the local field:
    # a global threshold cannot separate them, the local background can.
    rows, columns = np.mgrid[0:200, 0:300]
    field = 100 + 120 * columns / 299.0
    image = field.copy()
    centres = [(20 + 40 * i, 50 + 50 * (i % 3)) for i in range(7)]
    for x, y in centres:
        image[(columns - x) ** 2 + (rows - y) ** 2 <= 9] -= 60
    table = detect_blobs(np.clip(image, 0, 255).astype(np.uint8))
    found = np.column_stack((table["x"], table["y"]))
    assert len(found) == len(centres)
    assert nearest_errors(table["x"], table["y"], np.array(centres, float)).max() < 0.1
    # The same frame without background correction: the threshold follows the gradient.
    assert len(detect_blobs(np.clip(image, 0, 255).astype(np.uint8), BlobOptions(background="none"))["x"]) != len(centres)


def test_noise_alone_gives_no_detections():
    rng = np.random.default_rng(4)
    image = np.clip(rng.normal(150, 3, (240, 320)), 0, 255).astype(np.uint8)
    assert len(detect_blobs(image)["x"]) == 0


def test_region_of_interest_limits_where_blobs_are_found():
    image = np.full((50, 50), 230, np.uint8)
    image[10:14, 10:14] = 20
    image[35:39, 35:39] = 20
    roi = np.zeros((50, 50), np.uint8)
    roi[25:, 25:] = 255
    table = detect_blobs(image, roi=roi)
    np.testing.assert_allclose(np.column_stack((table["x"], table["y"])), [[36.5, 36.5]])
    with pytest.raises(ValueError, match="region of interest is 40x50"):
        detect_blobs(image, roi=np.zeros((50, 40), np.uint8))


def test_eccentricity_of_round_and_elongated_blobs():
    image = np.full((200, 200), 230, np.uint8)
    image[10:19, 10:19] = 20  # a square: round to second order
    image[40:43, 20:50] = 20  # a bar ten times as long as it is wide
    table = detect_blobs(image)
    square, bar = table["eccentricity"]
    assert square == pytest.approx(0.0, abs=1e-9)
    # Variances along and across a 30 x 3 bar of pixel centres: (30**2 - 1) / 12 and (3**2 - 1) / 12.
    assert bar == pytest.approx(np.sqrt(1 - 8 / 899), abs=1e-9)


@pytest.mark.parametrize("seed", [0, 1])
def test_cluttered_dish_recall_precision_and_position_error(seed):
    # Touching pairs, a rim and its shadow, strong uneven light, glare and dust, found with
    # the default options and the automatic dish.
    spec = DishSpec(frames=3, seeds=80, touching_pairs=12, rim=True, glare_spots=6, dust_specks=30, illumination=60, random_seed=seed)
    scene = make_dish_scene(spec)
    roi, dish = dish_mask(to_gray(scene.render(0)))
    assert dish is not None and np.hypot(dish.x - scene.centre[0], dish.y - scene.centre[1]) < 1
    matched, found, errors = 0, 0, []
    for k in range(spec.frames):
        table = detect_blobs(scene.render(k), roi=roi)
        truth = scene.truth.xy[scene.visible[:, k], k]
        rows, cols = match_frame(np.column_stack((table["x"], table["y"])), truth, 2.0)
        distance = np.hypot(table["x"][rows] - truth[cols, 0], table["y"][rows] - truth[cols, 1])
        matched += len(rows)
        found += len(table["x"])
        errors.extend(distance)
    true_points = spec.frames * spec.seeds
    assert matched / true_points >= 0.995
    assert matched / found >= 0.995
    assert np.sqrt(np.mean(np.square(errors))) <= 0.2


def test_touching_pair_is_split_in_two():
    spec = DishSpec(frames=1, seeds=40, touching_pairs=8, random_seed=3)
    scene = make_dish_scene(spec)
    table = detect_blobs(scene.render(0))
    assert len(table["x"]) == 40
    assert len(detect_blobs(scene.render(0), BlobOptions(split=False))["x"]) == 32


def test_dish_is_found_only_when_the_frame_clearly_shows_one():
    scene = make_dish_scene(DishSpec(frames=1, rim=True, illumination=60))
    dish = find_dish(to_gray(scene.render(0)))
    assert dish is not None
    assert np.hypot(dish.x - scene.centre[0], dish.y - scene.centre[1]) < 0.5 and abs(dish.r - scene.radius) < 1.5
    rng = np.random.default_rng(0)
    light_field = np.clip(rng.normal(180, 20, (240, 320)), 0, 255).astype(np.uint8)
    cut_disc = np.full((240, 320), 40, np.uint8)
    cv2.circle(cut_disc, (300, 120), 100, 220, -1)  # runs off the frame
    square = np.full((240, 320), 40, np.uint8)
    square[40:200, 80:240] = 220
    for image in (light_field, cut_disc, square):
        assert find_dish(image) is None
        assert dish_mask(image) == (None, None)
