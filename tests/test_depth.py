"""Frames deeper than 8 bits: files are read at their own depth, so that the API on arrays, the
API on files and the commands find the same objects, and 12-bit camera data is not lost."""

from __future__ import annotations

import cv2
import numpy as np
import pandas as pd
import pytest

import seedtrack
from seedtrack.annotate.frames import FrameCache
from seedtrack.cli import main
from seedtrack.data.dish import DishSpec, make_dish_scene
from seedtrack.data.spotfield import SpotFieldSpec, make_spot_field
from seedtrack.detection.blobs import to_gray
from seedtrack.tracking.metrics import match_frame

FIELD_SEEDS = (11, 12, 13)


def spot_fields():
    """Three frames of light spots on dark (a touching pair and an out-of-focus ring in each)."""
    return [make_spot_field(SpotFieldSpec(width=128, height=96, spots=12, touching_pairs=1, rings=1, snr=6.0, random_seed=s)) for s in FIELD_SEEDS]


def at_depth(units: list[np.ndarray], depth: str) -> list[np.ndarray]:
    """Frames of values in 0..1 as 8-bit, 12-bit in 16-bit words (as cameras write) or float data."""
    if depth == "uint8":
        return [np.round(u * 255).astype(np.uint8) for u in units]
    if depth == "uint16":
        return [np.round(u * 4095).astype(np.uint16) for u in units]
    return [u.astype(np.float32) for u in units]


@pytest.fixture(scope="module")
def fields():
    found = spot_fields()
    brightest = max(float(f.image.max()) for f in found)
    return found, [np.clip(f.image, 0, None) / brightest for f in found]


def command_detections(capsys, path, out) -> pd.DataFrame:
    capsys.readouterr()
    assert main(["detect", str(path), "--out", str(out)]) == 0, capsys.readouterr().err
    return pd.read_csv(out)


@pytest.mark.parametrize("depth", ["uint8", "uint16", "float32"])
def test_arrays_tiff_stack_and_command_give_the_same_detections_at_each_depth(fields, depth, tmp_path, capsys):
    frames = at_depth(fields[1], depth)
    stack = tmp_path / "stack.tif"
    assert cv2.imwritemulti(str(stack), frames)
    on_arrays = seedtrack.detect(frames)
    assert len(on_arrays) >= 30
    pd.testing.assert_frame_equal(seedtrack.detect(stack), on_arrays)
    # The CSV holds positions to four decimals.
    pd.testing.assert_frame_equal(command_detections(capsys, stack, tmp_path / "d.csv"), on_arrays.round(4), check_dtype=False, atol=1e-9)


@pytest.mark.parametrize("depth", ["uint8", "uint16"])
def test_a_png_folder_gives_the_detections_of_its_arrays(fields, depth, tmp_path, capsys):
    frames = at_depth(fields[1], depth)
    folder = tmp_path / "frames"
    folder.mkdir()
    for k, frame in enumerate(frames):
        assert cv2.imwrite(str(folder / f"f{k}.png"), frame)
    on_arrays = seedtrack.detect(frames)
    pd.testing.assert_frame_equal(seedtrack.detect(folder), on_arrays)
    pd.testing.assert_frame_equal(command_detections(capsys, folder, tmp_path / "d.csv"), on_arrays.round(4), check_dtype=False, atol=1e-9)


def test_run_on_a_16_bit_stack_detects_as_detect_does_and_every_picture_shows_its_range(fields, tmp_path, capsys):
    stack = tmp_path / "stack.tif"
    assert cv2.imwritemulti(str(stack), at_depth(fields[1], "uint16"))
    command_detections(capsys, stack, tmp_path / "d.csv")
    run = tmp_path / "run"
    assert main(["run", str(stack), "--out", str(run)]) == 0, capsys.readouterr().err
    assert (run / "detections.csv").read_bytes() == (tmp_path / "d.csv").read_bytes()
    assert main(["render", str(stack), str(run / "tracks.csv"), "--out", str(tmp_path / "r.png"), "--frame", "1", "--summary", str(tmp_path / "s.png")]) == 0
    assert main(["compare", str(stack), str(run / "tracks.csv"), str(run / "tracks.csv"), "--out", str(tmp_path / "c.png"), "--frame", "1"]) == 0
    assert main(["review", str(stack), str(run / "tracks.csv"), "--out", str(tmp_path / "review")]) == 0
    assert main(["detect", str(stack), "--out", str(tmp_path / "p.csv"), "--preview", str(tmp_path / "p.png")]) == 0
    with seedtrack.open_frames(run / "overlay.mp4") as overlay:
        (_, first), *_ = overlay
    cache = FrameCache(stack)
    page = cv2.imdecode(np.frombuffer(cache.jpeg(2), np.uint8), cv2.IMREAD_UNCHANGED)
    cache.close()
    pictures = [first, page] + [cv2.imread(str(name)) for name in (tmp_path / "r.png", tmp_path / "s.png", tmp_path / "c.png", tmp_path / "p.png", *sorted((tmp_path / "review").glob("*.png")))]
    # Much of each picture is the noisy background at its grey level shown from the 12-bit range
    # (from the 16-bit words' whole range it would be crushed 16 times darker) under the drawings.
    level = np.median(at_depth(fields[1], "uint8")[0])
    assert len(pictures) >= 8 and level >= 20
    assert [picture.dtype for picture in pictures] == [np.uint8] * len(pictures)
    shares = [float(np.mean(np.abs(picture.astype(int) - level) <= 4)) for picture in pictures]
    # (At least 9% of each picture lies within 4 levels of it; crushed, none would.)
    assert min(shares) > 0.05, shares


def recall(tables: pd.DataFrame, fields) -> float:
    matched = 0
    for k, field in enumerate(fields):
        rows = tables[tables["frame"] == k]
        matched += len(match_frame(rows[["x", "y"]].to_numpy(), field.xy, 1.0)[0])
    return matched / sum(len(field.xy) for field in fields)


def test_12_bit_data_in_a_16_bit_tiff_is_found_as_its_8_bit_version(fields, tmp_path):
    truth, units = fields
    paths = {}
    for depth in ("uint8", "uint16"):
        paths[depth] = tmp_path / f"{depth}.tif"
        assert cv2.imwritemulti(str(paths[depth]), at_depth(units, depth))
    eight, twelve = (recall(seedtrack.detect(paths[depth]), truth) for depth in ("uint8", "uint16"))
    assert eight >= 0.9 and twelve >= eight, (eight, twelve)


def test_dark_seeds_in_12_bits_give_the_blobs_of_their_8_bit_frames(tmp_path):
    greys = [to_gray(frame) for frame in make_dish_scene(DishSpec(seeds=15, frames=3, width=200, height=150, random_seed=4)).frames()]
    # 4095 / 255 apart: mapped back from the 12-bit range, each level is its 8-bit one again.
    deep = [np.round(grey * (4095 / 255)).astype(np.uint16) for grey in greys]
    stack = tmp_path / "seeds.tif"
    assert cv2.imwritemulti(str(stack), deep)
    eight = seedtrack.detect(greys, detector="blob")
    assert len(eight) >= 40
    pd.testing.assert_frame_equal(seedtrack.detect(stack, detector="blob"), eight)


def test_16_bit_grey_video_keeps_its_depth_and_its_detections(fields, tmp_path):
    import av

    frames = at_depth(fields[1], "uint16")
    path = tmp_path / "deep.mkv"
    with av.open(str(path), "w") as container:
        # FFV1 keeps 16-bit grey losslessly: the video holds exactly the arrays' values.
        stream = container.add_stream("ffv1", rate=25)
        stream.width, stream.height, stream.pix_fmt = 128, 96, "gray16le"
        for frame in frames:
            container.mux(stream.encode(av.VideoFrame.from_ndarray(frame, format="gray16le")))
        container.mux(stream.encode())
    with seedtrack.open_frames(path) as source:
        read = [image for _, image in source]
        assert source.span == (0.0, 65535.0)
    for got, written in zip(read, frames, strict=True):
        np.testing.assert_array_equal(got, written)
    pd.testing.assert_frame_equal(seedtrack.detect(path), seedtrack.detect(frames))
