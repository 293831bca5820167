"""End-to-end: ``seedtrack detect`` and the detection options of ``seedtrack run``."""

import subprocess
import sys

import cv2
import numpy as np
import pytest

import seedtrack as seedtrack_api
from seedtrack.cli import main
from seedtrack.commands.detect import preview_caption
from seedtrack.detection.choice import choose_detector
from seedtrack.pipeline import DetectSettings, detect_clip
from seedtrack.data.csvio import read_table
from seedtrack.data.dish import DishSpec, make_dish_scene, write_dish_clip
from seedtrack.data.video import write_video
from seedtrack.tracking.metrics import match_frame

COLUMNS = ["frame", "x", "y", "area", "mean_intensity", "eccentricity", "ep"]
SPEC = DishSpec(seeds=30, frames=4, width=320, height=240, rim_speed=15.0, random_seed=7, touching_pairs=3, rim=True, glare_spots=2, dust_specks=8)


def seedtrack(*args):
    return subprocess.run([sys.executable, "-m", "seedtrack", *map(str, args)], capture_output=True, text=True)


@pytest.fixture(scope="module")
def dish(tmp_path_factory):
    folder = tmp_path_factory.mktemp("dish")
    scene = write_dish_clip(SPEC, folder)
    return folder / "clip.mp4", scene


def header(path):
    return path.read_text().splitlines()[0].split(",")


def test_detect_finds_every_seed_and_draws_a_preview(dish, tmp_path):
    clip, scene = dish
    out, preview = tmp_path / "detections.csv", tmp_path / "preview.png"
    result = seedtrack("detect", clip, "--out", out, "--preview", preview, "--preview-frame", 2)
    assert result.returncode == 0, result.stderr
    assert header(out) == COLUMNS
    table = read_table(out, required=("frame", "x", "y"))
    for k in range(SPEC.frames):
        here = table["frame"] == k
        found = np.column_stack((table["x"][here], table["y"][here]))
        rows, _ = match_frame(found, scene.truth.xy[:, k], 1.0)
        assert len(rows) == len(found) == SPEC.seeds
    page = cv2.imread(str(preview))
    # Enlarged to at least 1280 pixels wide; red rings for the seeds, a green circle for the dish.
    assert page.shape[1] >= 1280
    red = (page[..., 2] > 200) & (page[..., 1] < 60) & (page[..., 0] < 60)
    green = (page[..., 1] > 150) & (page[..., 2] < 60) & (page[..., 0] < 60)
    assert red.sum() > 30 * SPEC.seeds and green.sum() > 1000


def test_run_takes_the_same_detection_options(dish, tmp_path):
    clip, _ = dish
    options = ["--threshold", "60", "--polarity", "dark", "--no-split", "--min-area", "6", "--roi", "160,120,60"]
    assert main(["detect", str(clip), "--out", str(tmp_path / "d.csv"), *options]) == 0
    assert main(["run", str(clip), "--out", str(tmp_path / "run"), *options]) == 0
    assert (tmp_path / "d.csv").read_bytes() == (tmp_path / "run" / "detections.csv").read_bytes()
    table = read_table(tmp_path / "d.csv")
    assert 0 < len(table["x"]) and np.hypot(table["x"] - 160, table["y"] - 120).max() <= 60


def test_frame_range_and_step(dish, tmp_path):
    clip, _ = dish
    assert main(["detect", str(clip), "--out", str(tmp_path / "d.csv"), "--start", "1", "--step", "2"]) == 0
    assert sorted(set(read_table(tmp_path / "d.csv")["frame"])) == [1, 3]


def test_mask_image_limits_the_search(dish, tmp_path):
    clip, _ = dish
    mask = np.zeros((SPEC.height, SPEC.width), np.uint8)
    mask[:, : SPEC.width // 2] = 255
    cv2.imwrite(str(tmp_path / "mask.png"), mask)
    assert main(["detect", str(clip), "--out", str(tmp_path / "d.csv"), "--roi", str(tmp_path / "mask.png")]) == 0
    table = read_table(tmp_path / "d.csv")
    assert len(table["x"]) > 0 and table["x"].max() < SPEC.width / 2


@pytest.mark.parametrize(
    "options, message",
    [
        (["--min-area", "50", "--max-area", "10"], "--min-area 50 exceeds --max-area 10"),
        (["--min-area", "-5"], "--min-area must not be negative, got -5"),
        (["--background-size", "1"], "--background-size must lie in 3..2000 px"),
        (["--roi", "{mask}"], "mask is 20x10, the frames 320x240"),
        (["--roi", "{junk}"], "not a mask image"),
        (["--threshold", "bright"], "--threshold must be otsu, adaptive or a number"),
        (["--threshold", "300"], "--threshold must lie in 0..255"),
        (["--roi", "10,10,-3"], "radius > 0"),
        (["--roi", "10,10"], "--roi takes auto, none, a circle X,Y,R in pixels, or a mask image file; '10,10' is none"),
        (["--roi", "{folder}/missing.png"], "missing.png: no such mask image file"),
        (["--detector", "spot", "--threshold", "adaptive"], "adaptive works with --detector blob only"),
        (["--diameter", "4"], "--diameter must be an odd number of pixels >= 3, got 4"),
        (["--min-mass", "-1"], "--min-mass must be a finite number >= 0, got -1"),
        (["--min-mass", "inf"], "--min-mass must be a finite number >= 0, got inf"),
        (["--preview", "{folder}/p.png", "--preview-frame", "99"], "preview frame 99 is not among the frames processed (0..3)"),
        (["--preview", "{folder}/p.txt"], "name an image file"),
    ],
)
def test_nonsense_options_are_one_line_exit_2_and_nothing_written(dish, tmp_path, capsys, options, message):
    clip, _ = dish
    cv2.imwrite(str(tmp_path / "small.png"), np.full((10, 20), 255, np.uint8))
    (tmp_path / "junk.png").write_bytes(b"not an image")
    paths = {"mask": tmp_path / "small.png", "junk": tmp_path / "junk.png", "folder": tmp_path}
    options = [option.format(**paths) for option in options]
    assert main(["detect", str(clip), "--out", str(tmp_path / "d.csv"), *options]) == 2
    stderr = capsys.readouterr().err
    assert stderr.count("\n") == 1 and message in stderr
    assert not (tmp_path / "d.csv").exists() and not (tmp_path / "p.png").exists()


def test_truncated_video_keeps_the_decoded_frames_and_says_where_it_stopped(tmp_path):
    scene = make_dish_scene(DishSpec(seeds=20, frames=12, width=160, height=120, random_seed=2, noise_sigma=30))
    clip = tmp_path / "clip.mp4"
    write_video(clip, scene.frames(), 25.0)
    cut = tmp_path / "cut.mp4"
    cut.write_bytes(clip.read_bytes()[: clip.stat().st_size // 2])
    result = seedtrack("detect", cut, "--out", tmp_path / "d.csv", "--threshold", "100")
    assert result.returncode == 0, result.stderr
    frames = sorted(set(read_table(tmp_path / "d.csv")["frame"]))
    assert 0 < len(frames) < 12 and frames == list(range(len(frames)))
    assert result.stderr.count("\n") == 1
    assert f"decoding stopped at frame {len(frames)}" in result.stderr and str(cut) in result.stderr


def test_empty_frame_gives_no_detections(tmp_path):
    scene = make_dish_scene(DishSpec(seeds=15, frames=3, width=160, height=120, random_seed=4))
    folder = tmp_path / "frames"
    folder.mkdir()
    for k in range(3):
        cv2.imwrite(str(folder / f"{k}.png"), scene.render(k))
    cv2.imwrite(str(folder / "3.png"), np.full((120, 160, 3), 128, np.uint8))
    assert main(["detect", str(folder), "--out", str(tmp_path / "d.csv")]) == 0
    frames = read_table(tmp_path / "d.csv")["frame"]
    assert [int(np.sum(frames == k)) for k in range(4)] == [15, 15, 15, 0]


def test_temporal_background_ignores_what_never_moves(tmp_path):
    # Dark specks fixed on the sensor and a bead moving across: against the median over time the
    # specks are background, against the local median they are objects.
    rng = np.random.default_rng(3)
    folder = tmp_path / "frames"
    folder.mkdir()
    field = np.full((80, 120), 200.0)
    for x, y in ((20, 20), (90, 60), (60, 15)):
        cv2.circle(field, (x, y), 2, 90, -1)
    for k in range(9):
        image = field.copy()
        cv2.circle(image, (10 + 12 * k, 40), 3, 40, -1)
        cv2.imwrite(str(folder / f"{k}.png"), np.clip(image + rng.normal(0, 2, image.shape), 0, 255).astype(np.uint8))
    for background, per_frame in (("local", 4), ("temporal", 1)):
        assert main(["detect", str(folder), "--out", str(tmp_path / "d.csv"), "--background", background]) == 0
        table = read_table(tmp_path / "d.csv")
        assert np.array_equal(np.bincount(table["frame"].astype(int)), np.full(9, per_frame)), background
    np.testing.assert_allclose(table["y"], 40, atol=0.1)
    np.testing.assert_allclose(table["x"], 10 + 12 * np.arange(9), atol=0.1)


def write_spot_frames(folder, peaks=(90.0,) * 15, centres=None):
    """Two PNG frames of round bright spots of these peaks (grey levels) on 20, noise of 2, at
    these centres (x, y), pixels (random ones by default), moving right 1 px a frame."""
    rng = np.random.default_rng(4)
    rows, columns = np.mgrid[0:120, 0:160]
    folder.mkdir()
    centres = rng.uniform(12, 108, (len(peaks), 2)) if centres is None else centres
    for k in range(2):
        image = 20 + sum(peak * np.exp(-((columns - x - k) ** 2 + (rows - y) ** 2) / 4.5) for peak, (x, y) in zip(peaks, centres))
        cv2.imwrite(str(folder / f"{k}.png"), np.clip(image + rng.normal(0, 2, image.shape), 0, 255).astype(np.uint8))
    return folder


def test_preview_says_which_detector_ran_with_its_size_and_threshold(tmp_path, capsys):
    # Round bright spots: the spot detector, whose diameter and least mass the caption gives.
    folder = write_spot_frames(tmp_path / "frames")
    assert main(["detect", str(folder), "--out", str(tmp_path / "d.csv"), "--preview", str(tmp_path / "p.png")]) == 0
    first = capsys.readouterr().out.splitlines()[0]
    assert first.startswith("detector: small round spots") and "diameter 9 px" in first
    found = detect_clip(folder, say=lambda line: None)
    assert preview_caption(found.choice, DetectSettings()).startswith("spot detector: diameter 9 px, least mass")
    assert preview_caption(choose_detector(np.zeros((8, 8)), "dark", detector="blob"), DetectSettings()) == (
        "blob detector: threshold otsu, area 4 px and up"
    )
    assert cv2.imread(str(tmp_path / "p.png")) is not None


def test_min_mass_overrides_the_least_mass_in_the_command_and_the_api(tmp_path, capsys):
    # Five faint spots (peak 25) among ten bright ones (peak 90), 25 px apart: masses (band-passed,
    # over the disc) of about 190 and 690.
    grid = np.column_stack((np.tile(np.arange(5) * 25 + 25.0, 3), np.repeat(np.arange(3) * 25 + 30.0, 5)))
    folder = write_spot_frames(tmp_path / "frames", peaks=(90.0,) * 10 + (25.0,) * 5, centres=grid)
    counts = {}
    for mass in (None, 400.0, 1e6):
        options = [] if mass is None else ["--min-mass", f"{mass:g}"]
        assert main(["detect", str(folder), "--out", str(tmp_path / "d.csv"), *options]) == 0
        first = capsys.readouterr().out.splitlines()[0]
        assert mass is None or f"least mass {mass:.3g} " in first
        counts[mass] = np.bincount(read_table(tmp_path / "d.csv")["frame"].astype(int), minlength=2).tolist()
        if mass is not None:
            frames = [cv2.imread(str(folder / f"{k}.png"), cv2.IMREAD_GRAYSCALE) for k in range(2)]
            assert seedtrack_api.detect(frames, min_mass=mass).groupby("frame").size().reindex([0, 1], fill_value=0).tolist() == counts[mass]
    assert counts == {None: [15, 15], 400.0: [10, 10], 1e6: [0, 0]}


def test_options_of_the_detector_that_did_not_run_are_said_on_the_first_line(tmp_path, capsys):
    folder = write_spot_frames(tmp_path / "frames")
    for options, said in (
        (["--threshold", "30", "--min-area", "8"], "; --threshold, --min-area apply to the blob detector only (not used)"),
        (["--detector", "spot", "--no-split"], "; --no-split applies to the blob detector only (not used)"),
        (["--detector", "blob", "--min-mass", "500"], "; --min-mass applies to the spot detector only (not used)"),
        (["--detector", "spot"], ""),
    ):
        assert main(["detect", str(folder), "--out", str(tmp_path / "d.csv"), *options]) == 0
        first = capsys.readouterr().out.splitlines()[0]
        assert first.startswith("detector: ") and ("not used" not in first if not said else first.endswith(said)), (options, first)
