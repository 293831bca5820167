"""Spots on structured background (blotches, compression blocks), the --snr knob, bad frames, and
the spot detector's defaults against the bulk-water beads marked by looking."""

import io

import av
import cv2
import numpy as np
import pandas as pd
import pytest

from seedtrack.cli import main
from seedtrack.data.csvio import read_table
from seedtrack.data.frames import open_frames
from seedtrack.detection.blobs import to_gray
from seedtrack.detection.choice import describe
from seedtrack.detection.clip import ClipDetector, detect_frames
from seedtrack.detection.spots import SpotSettings, detect_spots, fit_spot_settings
from seedtrack.detection.structure import background_of
from seedtrack.tracking.metrics import match_frame

from footage import BEADS, needs_beads

TRUTH = __import__("pathlib").Path(__file__).parent / "data" / "bulk_water_beads" / "truth.csv"


def structured_scene(seed, beads=60, size=(240, 320)):
    """Dark beads (depth 20, sigma 1.6 px) on a light field with blotches (blurred noise, 1.2 grey
    levels) and 8 px blocks (0.6 grey levels) far above its pixel noise (0.3), as compressed
    bright-field footage has them; 8-bit."""
    rng = np.random.default_rng(seed)
    height, width = size
    blotches = cv2.GaussianBlur(rng.normal(0, 1, size).astype(np.float32), (0, 0), 2.5)
    blotches *= 1.2 / blotches.std()
    blocks = np.kron(rng.normal(0, 0.6, (height // 8, width // 8)), np.ones((8, 8))).astype(np.float32)
    image = 130 + blotches + blocks + rng.normal(0, 0.3, size)
    rows, columns = np.mgrid[0:height, 0:width]
    centres = rng.uniform(10, [width - 10, height - 10], (beads, 2))
    for x, y in centres:
        image -= 20 * np.exp(-((columns - x) ** 2 + (rows - y) ** 2) / (2 * 1.6**2))
    return np.clip(np.round(image), 0, 255).astype(np.uint8), centres


def test_two_modes_of_mass_give_a_valley_between_them_and_one_mode_none():
    rng = np.random.default_rng(1)
    background = rng.lognormal(np.log(20), 0.4, 600)
    found = background_of(np.concatenate([background, rng.lognormal(np.log(200), 0.2, 400)]), 3.0)
    assert found.structured and 15 < found.mass < 30 and 60 < found.valley < 150
    alone = background_of(background, 3.0)
    assert alone.structured and alone.valley == 0
    # White noise's own maxima: not structured, whatever lies above them.
    assert not background_of(np.concatenate([background, rng.lognormal(np.log(200), 0.2, 400)]), 15.0).structured


def test_beads_on_structured_background_are_found_and_the_background_is_not():
    for seed in range(3):
        image, centres = structured_scene(seed)
        settings = fit_spot_settings(image, "dark")
        found = detect_spots(image, settings)
        points = np.column_stack((found["x"], found["y"]))
        rows, _ = match_frame(points, centres, 2.0)
        assert rows.size / len(points) >= 0.95 and rows.size / len(centres) >= 0.9, (seed, len(points), rows.size)
        # The background's maxima, which a least mass a fifth as high takes, outnumber the beads.
        assert len(detect_spots(image, SpotSettings(settings.diameter, settings.min_mass / 5, "dark", settings.floor))["x"]) > 3 * len(centres)
        assert settings.unusual == ""


def test_snr_sets_the_least_mass_as_a_multiple_of_the_background_maxima():
    image, _ = structured_scene(0)
    counts = []
    for snr in (3.0, 5.0, 8.0):
        settings = fit_spot_settings(image, "dark", snr=snr)
        assert settings.min_mass == pytest.approx(snr * settings.background_mass)
        assert f"snr {snr:.3g} x background maxima" in describe(settings)
        counts.append(len(detect_spots(image, settings)["x"]))
    assert counts[0] > counts[1] > counts[2]
    # A ratio that takes the background for spots covers the frame with them, and is said.
    assert "spots would cover" in fit_spot_settings(image, "dark", snr=0.2).unusual


def test_structured_background_without_objects_is_said():
    image, _ = structured_scene(5, beads=0)
    unusual = fit_spot_settings(image, "dark").unusual
    assert "show no valley" in unusual and "raise the signal-to-background ratio (--snr)" in unusual


def test_snr_option_is_taken_checked_and_said(tmp_path, capsys):
    folder = tmp_path / "frames"
    folder.mkdir()
    for seed in range(2):
        cv2.imwrite(str(folder / f"{seed}.png"), structured_scene(seed)[0])
    counts = {}
    for snr in ("3", "8"):
        assert main(["detect", str(folder), "--out", str(tmp_path / "d.csv"), "--roi", "none", "--snr", snr]) == 0
        assert f"= snr {snr} x background maxima" in capsys.readouterr().out.splitlines()[0]
        counts[snr] = len(read_table(tmp_path / "d.csv")["frame"])
    assert counts["3"] > counts["8"] > 0
    assert main(["detect", str(folder), "--out", str(tmp_path / "e.csv"), "--snr", "0"]) == 2
    assert capsys.readouterr().err.strip().endswith("--snr must be a finite number > 0, got 0")
    assert not (tmp_path / "e.csv").exists()


def test_the_stderr_line_when_the_background_is_as_heavy_as_the_objects(tmp_path, capsys):
    folder = tmp_path / "frames"
    folder.mkdir()
    cv2.imwrite(str(folder / "0.png"), structured_scene(5, beads=0)[0])
    assert main(["detect", str(folder), "--out", str(tmp_path / "d.csv"), "--roi", "none", "--detector", "spot"]) == 0
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "warning" in err and "show no valley below heavier objects" in err


def float_pages(nan_page):
    rng = np.random.default_rng(0)
    pages = []
    for k in range(4):
        page = (0.2 + rng.normal(0, 0.01, (64, 80))).astype(np.float32)
        page[20:23, 30:33] = 0.9
        if k == nan_page:
            page[5:8, 5:8] = np.nan
        pages.append(page)
    return pages


def test_a_float_tiff_with_nan_pixels_is_one_line(tmp_path, capsys):
    later, first = tmp_path / "later.tif", tmp_path / "first.tif"
    cv2.imwritemulti(str(later), float_pages(2))
    cv2.imwritemulti(str(first), float_pages(0))
    assert main(["detect", str(later), "--out", str(tmp_path / "d.csv")]) == 0
    assert "stopped at frame 2: page 2 holds NaN or infinite pixels; keeping the 2 frames before it" in capsys.readouterr().err
    assert sorted(set(read_table(tmp_path / "d.csv")["frame"].astype(int))) == [0, 1]
    assert main(["detect", str(first), "--out", str(tmp_path / "e.csv")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.endswith("page 0 holds NaN or infinite pixels") and "Traceback" not in err
    with pytest.raises(ValueError, match="NaN or infinite pixels"):
        ClipDetector(roi="none").detect(float_pages(0)[0])


def stream(width, height, frames):
    """MPEG-TS bytes of dark squares on grey, ``width`` x ``height``."""
    buffer = io.BytesIO()
    with av.open(buffer, "w", format="mpegts") as container:
        video = container.add_stream("mpeg2video", rate=24)
        video.width, video.height, video.pix_fmt = width, height, "yuv420p"
        for k in range(frames):
            image = np.full((height, width, 3), 200, np.uint8)
            image[20 + k : 25 + k, 30:35] = 40
            for packet in video.encode(av.VideoFrame.from_ndarray(image, format="bgr24")):
                container.mux(packet)
        for packet in video.encode():
            container.mux(packet)
    return buffer.getvalue()


def test_a_video_whose_frame_size_changes_keeps_the_frames_before(tmp_path, capsys):
    # Two recordings joined: MPEG-TS streams may change size part way.
    clip = tmp_path / "joined.ts"
    clip.write_bytes(stream(160, 120, 6) + stream(96, 64, 6))
    assert main(["detect", str(clip), "--out", str(tmp_path / "d.csv"), "--roi", "50,50,40"]) == 0
    err = capsys.readouterr().err
    assert "frame 5 is 96x64, the first frames 160x120; keeping the 5 frames before it" in err and "Traceback" not in err


@needs_beads
def test_bulk_water_defaults_find_the_beads_marked_by_looking():
    # The six reporting frames (see tests/data/bulk_water_beads/README.md), crops 100 px square.
    truth = pd.read_csv(TRUTH)
    truth = truth[~truth["frame"].isin((12, 84, 156, 228))]
    wanted = set(truth["frame"])
    with open_frames(BEADS, end=max(wanted) + 1) as source:
        frames = [(index, to_gray(image)) for index, image in source if index == 0 or index in wanted]
    found = detect_frames(frames, ClipDetector())
    columns = {int(index): found.frame(k) for k, index in enumerate(found.frame_indices)}
    corners = {"A": (20, 300), "B": (480, 30), "C": (400, 300)}
    matched_found = kept = matched_true = 0
    for (index, crop), marks in truth.groupby(["frame", "crop"]):
        true = marks[["x", "y"]].to_numpy()
        points = np.column_stack((columns[index]["x"], columns[index]["y"]))
        # Found points 3 px or more inside the crop count; a bead cut by its edge may match one.
        corner = np.array(corners[crop])
        inside = np.all((points >= corner + 3) & (points <= corner + 96), axis=1)
        rows, cols = match_frame(points, true, 3.0)
        kept += int(inside.sum())
        matched_found += int(inside[rows].sum())
        matched_true += cols.size
    precision, recall = matched_found / kept, matched_true / len(truth)
    assert precision >= 0.9 and recall >= 0.88, (precision, recall)
