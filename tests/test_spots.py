"""The spot detector (Crocker and Grier) and the detector choice, on small exact scenes."""

import cv2
import numpy as np
import pytest

from seedtrack.data.depth import value_range
from seedtrack.data.dish import DishSpec, make_dish_scene
from seedtrack.data.sparsespots import SparseSpotSpec, make_sparse_spots
from seedtrack.data.spotfield import SpotFieldSpec, make_spot_field
from seedtrack.detection.blobs import to_gray
from seedtrack.detection.choice import choose_detector
from seedtrack.detection.roi import dish_mask
from seedtrack.detection.spots import SpotSettings, _valley, detect_spots, fit_spot_settings, pixel_noise, spot_shape
from seedtrack.tracking.metrics import match_frame

ROWS, COLUMNS = np.mgrid[0:80, 0:100].astype(np.float32)


def gaussians(centres, sigma=1.5, amplitude=80.0, background=20.0):
    image = np.full(ROWS.shape, background, np.float32)
    for x, y in centres:
        image += amplitude * np.exp(-((COLUMNS - x) ** 2 + (ROWS - y) ** 2) / (2 * sigma**2))
    return image


def test_one_spot_is_found_at_its_sub_pixel_centre():
    found = detect_spots(gaussians([(40.3, 30.7)]), SpotSettings(diameter=11, min_mass=10))
    assert len(found["x"]) == 1
    assert abs(found["x"][0] - 40.3) < 0.02 and abs(found["y"][0] - 30.7) < 0.02


def test_dark_spots_need_dark_polarity():
    image = 200 - gaussians([(20.0, 20.0), (70.0, 50.0)])
    assert len(detect_spots(image, SpotSettings(11, 10, "dark"))["x"]) == 2
    # Taken for light spots, dark ones are holes ringed by light: nothing at their centres.
    light = detect_spots(image, SpotSettings(11, 10, "light"))
    assert not any((np.hypot(light["x"] - x, light["y"] - y) <= 2).any() for x, y in ((20, 20), (70, 50)))


def test_a_blank_frame_and_a_frame_of_noise_give_no_spot():
    assert len(detect_spots(np.full((50, 60), 7, np.uint8), SpotSettings(7, 0))["x"]) == 0
    noise = np.random.default_rng(0).normal(100, 5, (256, 256)).astype(np.float32)
    assert len(detect_spots(noise, fit_spot_settings(noise, "light", diameter=7))["x"]) <= 3


def test_the_least_mass_drops_faint_spots():
    image = gaussians([(20.0, 20.0)], amplitude=80) + gaussians([(70.0, 50.0)], amplitude=8, background=0)
    masses = detect_spots(image, SpotSettings(11, 0, floor=1.0))["mass"]
    bar = float(np.mean(masses))
    kept = detect_spots(image, SpotSettings(11, bar, floor=1.0))
    assert len(masses) == 2 and list(kept["x"].round()) == [20.0]


def test_a_faint_bead_beside_a_bright_one_is_no_halo():
    # A bead a seventh as bright, 9 px from a bright one (within its diameter): the running mean
    # about it is no darker than the wide background, so its light is its own, not a halo's.
    noise = np.random.default_rng(4).normal(0, 2, ROWS.shape)
    frame = gaussians([(40.0, 40.0)]) + gaussians([(49.0, 40.0)], amplitude=12.0, background=0.0) + noise
    found = detect_spots(frame, fit_spot_settings(frame, "light", diameter=11))
    assert len(found["x"]) == 2
    np.testing.assert_allclose(np.sort(found["x"]), [40.0, 49.0], atol=0.5)


def test_touching_spots_stay_apart():
    found = detect_spots(gaussians([(40.0, 40.0), (46.0, 40.0)]), SpotSettings(diameter=11, min_mass=10))
    assert len(found["x"]) == 2
    np.testing.assert_allclose(np.sort(found["x"]), [40.0, 46.0], atol=0.35)


def test_a_wide_bead_is_centred_on_all_its_light_as_trackpy_centres_it():
    # An out-of-focus bead twice as wide as the clip's spots, its bright core 3 px off centre:
    # a window of the clip's spot size centres it on the core side, 0.57 px from trackpy's
    # flat-disc centroid; the bead's own size widens the window to all its light.
    trackpy = pytest.importorskip("trackpy")
    trackpy.quiet()
    frame = gaussians([(50.0, 40.0)], sigma=4.0, amplitude=30.0, background=10.0) + gaussians([(53.0, 40.0)], sigma=1.0, amplitude=30.0, background=0.0)
    found = detect_spots(frame, SpotSettings(diameter=11, min_mass=1))
    reference = trackpy.locate(frame, 11, minmass=0)
    assert len(found["x"]) == 1 and len(reference) == 1
    assert abs(found["x"][0] - reference["x"].iloc[0]) < 0.5
    assert abs(found["y"][0] - reference["y"].iloc[0]) < 0.05


def test_same_content_in_8_16_bit_and_float_gives_the_same_spots():
    image = np.clip(gaussians([(30.2, 20.6), (70.0, 55.0)]) + np.random.default_rng(1).normal(0, 3, ROWS.shape), 0, 255).astype(np.uint8)
    tables = []
    for frame in (image, image.astype(np.uint16) * 257, image.astype(np.float32) / 255):
        tables.append(detect_spots(frame, fit_spot_settings(frame, "light")))
    for table in tables[1:]:
        np.testing.assert_allclose(table["x"], tables[0]["x"], atol=1e-3)
    assert value_range(image.astype(np.uint16) * 257) == (0.0, 65535.0)


def test_pixel_noise_is_measured_not_assumed():
    rng = np.random.default_rng(2)
    assert pixel_noise(rng.normal(100, 4, (128, 128))) == pytest.approx(4, rel=0.05)
    steps = (np.arange(32 * 32).reshape(32, 32) % 2 + 9).astype(np.uint16) * 257
    assert pixel_noise(steps) >= 257 / np.sqrt(12)


def test_spot_size_is_estimated_from_the_image():
    assert spot_shape(gaussians([(30.0, 30.0), (70.0, 50.0)], sigma=1.0)).diameter == 7
    assert spot_shape(gaussians([(30.0, 30.0), (70.0, 50.0)], sigma=2.0)).diameter == 13


@pytest.mark.parametrize("sigma", [1.0, 1.5, 2.2, 3.0])
def test_spot_sigma_is_read_between_the_scales_of_the_grid(sigma):
    # Read on the grid of scales alone, 1.5 said 1.6, 2.2 said 2.5 and 3.0 said 3.2.
    field = make_spot_field(SpotFieldSpec(width=256, height=256, spots=30, touching_pairs=0, rings=0, sigma=sigma, snr=50.0, random_seed=3))
    assert spot_shape(field.image).sigma == pytest.approx(sigma, rel=0.05)


def test_faint_spots_are_sized_by_their_own_light_not_the_noise():
    # At SNR 2 pixel noise makes the largest scale-normalised responses, at the smallest scale:
    # taken as they are they said sigma 0.8 (diameter 5) for spots of 1.5, and kept 42% of them.
    field = make_spot_field(SpotFieldSpec(snr=2.0, random_seed=7))
    assert spot_shape(field.image).diameter in (9, 11)


def test_generated_spots_at_snr_4_are_found_with_few_false_ones():
    field = make_spot_field(SpotFieldSpec(width=256, height=256, spots=50, touching_pairs=0, rings=5, snr=4.0, random_seed=5))
    found = detect_spots(field.image, fit_spot_settings(field.image, "light"))
    rows, _ = match_frame(np.column_stack((found["x"], found["y"])), field.xy, 2.0)
    assert len(rows) >= 48 and len(found["x"]) <= 52


def test_the_choice_takes_spots_for_round_beads_and_blobs_for_seeds():
    field = make_spot_field(SpotFieldSpec(width=256, height=256, spots=40, touching_pairs=0, rings=0, snr=8.0, random_seed=3))
    assert choose_detector(field.image, "light").name == "spot"
    gray = to_gray(make_dish_scene(DishSpec(frames=1)).render(0))
    roi, _ = dish_mask(gray)
    choice = choose_detector(gray, "dark", roi=roi)
    assert choice.name == "blob" and "elongated" in choice.reason
    assert choose_detector(gray, "dark", detector="spot", roi=roi).name == "spot"


def test_few_spots_in_skewed_camera_noise_give_few_false_ones():
    # A few photons a pixel on a sloping background: noise skewed towards bright and strongest
    # on the bright side, whose excursions Gaussian noise of the frame's mean level would make
    # far more rarely (its least mass let 9 false spots through in these 12 frames of 4 spots).
    clip = make_sparse_spots(SparseSpotSpec(frames=12, random_seed=5))
    settings = fit_spot_settings(clip.frames[0], "light")
    found = [detect_spots(frame, settings) for frame in clip.frames]
    matched = sum(len(match_frame(np.column_stack((t["x"], t["y"])), xy, 2.0)[0]) for t, xy in zip(found, clip.xy))
    assert matched == 48 and sum(len(t["x"]) for t in found) <= 49


def test_bright_round_spots_outvote_weaker_elongated_marks():
    # Two round spots and a static elongated mark with two maxima, as in TrackMate's FakeTracks:
    # counted one each, the four are half elongated and the median between them says seeds.
    image = gaussians([(30.0, 40.0)], sigma=1.25, amplitude=200) + gaussians([(60.0, 60.0)], sigma=1.25, amplitude=110, background=0)
    for y in (20.0, 28.0):
        image += 130 * np.exp(-((COLUMNS - 75) ** 2 / (2 * 1.0**2) + (ROWS - y) ** 2 / (2 * 2.0**2)))
    assert spot_shape(image).elongation < 1.4 and choose_detector(image, "light").name == "spot"


def test_the_api_finds_spots_in_16_bit_and_float_frames_on_their_own_values():
    import seedtrack

    field = make_spot_field(SpotFieldSpec(width=128, height=128, spots=10, touching_pairs=0, rings=0, snr=8.0, random_seed=2))
    photons = np.clip(field.image, 0, None) * 100
    deep = seedtrack.detect([np.round(photons).astype(np.uint16)])
    floating = seedtrack.detect([photons.astype(np.float32)])
    rows, _ = match_frame(deep[["x", "y"]].to_numpy(), field.xy, 1.0)
    assert len(deep) == len(floating) and len(rows) == 10
    np.testing.assert_allclose(deep["x"], floating["x"], atol=1e-3)


def test_jpeg_blocks_do_not_pass_for_spots():
    # Bright spots on a dark frame of little noise (about 1.2 grey levels), saved as JPEG of
    # quality 75 or 50: the fine noise is gone (the pixel noise reads a third of it or less) and
    # the blocks make maxima heavier than noise of that level would. The least mass set from the
    # pixel noise alone let about 30 false spots a frame through (94 in the first at quality 75).
    spec = SparseSpotSpec(
        width=320, height=200, frames=3, spots=12, sigma_range=(1.5, 2.5), peak_range=(60.0, 120.0),
        background=(1.0, 1.0), gain=1.0, read_noise=0.5, offset=10.0, random_seed=7,
    )
    clip = make_sparse_spots(spec)
    for quality in (75, 50):
        jpeg = [cv2.imdecode(cv2.imencode(".jpg", frame, [cv2.IMWRITE_JPEG_QUALITY, quality])[1], cv2.IMREAD_GRAYSCALE) for frame in clip.frames]
        assert pixel_noise(jpeg[0]) < 0.5 * pixel_noise(clip.frames[0])
        settings = fit_spot_settings(jpeg[0], "light")
        found = [detect_spots(frame, settings) for frame in jpeg]
        matched = sum(len(match_frame(np.column_stack((t["x"], t["y"])), xy, 2.0)[0]) for t, xy in zip(found, clip.xy))
        assert matched >= 35 and sum(len(t["x"]) for t in found) <= matched + 1, quality


def test_the_valley_between_noise_and_spots_is_taken_only_where_there_is_one():
    rng = np.random.default_rng(0)
    noise = rng.gamma(4.0, 3.0, 500)
    # Spots far heavier than the noise's maxima: the least mass lies between them.
    valley = _valley(np.concatenate([noise, rng.uniform(600, 900, 12)]), 4.0)
    assert noise.max() < valley < 600
    # Masses that run on from the noise (faint spots among it, beads in and out of focus): none.
    assert _valley(np.concatenate([noise, np.geomspace(noise.max(), 900, 40)]), 4.0) == 0
    # A gap far above the noise's median (faint spots running on from the noise, then bright
    # ones) is no valley of noise: the faint ones are kept.
    assert _valley(np.concatenate([noise, np.geomspace(noise.max(), 300, 100), rng.uniform(2000, 2500, 10)]), 4.0) == 0


def test_large_objects_are_said_by_their_scale_not_the_spot_diameter():
    # Dark discs of radius 6 px (12 px across) on white: the spot diameter that would fit them
    # (6 sigma) is about twice their width, so the reason states the sigma, r / sqrt(2) = 4.2 px.
    image = np.full((96, 96), 230, np.uint8)
    for x, y in ((24, 24), (70, 30), (40, 70)):
        cv2.circle(image, (x, y), 6, 30, -1)
    choice = choose_detector(image, "dark")
    assert choice.name == "blob"
    sigma = float(choice.reason.split("sigma ")[1].split(" px")[0])
    assert 3.2 <= sigma <= 5.0 and "across" not in choice.reason
