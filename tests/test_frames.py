"""Tests of data.frames: streaming frames from videos, image folders, patterns and TIFF stacks."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from seedtrack.data.errors import DataError
from seedtrack.data.depth import to_bgr8
from seedtrack.data.frames import open_frames
from seedtrack.data.video import write_video


def flat_frames(count: int, width: int = 64, height: int = 48) -> list[np.ndarray]:
    """Frames of one grey level each (10, 30, 50, ...), recognisable after compression."""
    return [np.full((height, width, 3), 10 + 20 * index, np.uint8) for index in range(count)]


def level(image: np.ndarray) -> int:
    return int(round(float(image.mean())))


@pytest.fixture
def clip(tmp_path):
    path = tmp_path / "clip.mp4"
    write_video(path, flat_frames(10), 25.0)
    return path


def test_video_yields_every_frame_with_its_index(clip):
    with open_frames(clip) as source:
        assert (source.fps, source.frame_count, source.size, source.path) == (25.0, 10, (64, 48), clip)
        frames = list(source)
        assert source.stopped_early is None
    assert [index for index, _ in frames] == list(range(10))
    assert all(image.shape == (48, 64, 3) and image.dtype == np.uint8 for _, image in frames)
    assert [level(image) for _, image in frames] == pytest.approx([10 + 20 * i for i in range(10)], abs=2)


def test_start_end_step_select_original_indices(clip):
    source = open_frames(clip, start=2, end=9, step=3)
    assert source.frame_count == 3
    frames = list(source)
    assert [index for index, _ in frames] == [2, 5, 8]
    assert [level(image) for _, image in frames] == pytest.approx([50, 110, 170], abs=2)


def test_end_past_the_clip_means_the_end(clip):
    source = open_frames(clip, start=7, end=100)
    assert source.frame_count == 3
    assert [index for index, _ in source] == [7, 8, 9]


def test_iterating_twice_gives_the_same_frames(clip):
    with open_frames(clip, step=4) as source:
        first = [(index, image.copy()) for index, image in source]
        second = list(source)
    assert [i for i, _ in first] == [i for i, _ in second] == [0, 4, 8]
    assert all(np.array_equal(a, b) for (_, a), (_, b) in zip(first, second))


def test_truncated_video_yields_what_decodes_and_records_where_it_stopped(tmp_path):
    # Noise makes every frame take a similar share of the file, so half a file is half a clip.
    rng = np.random.default_rng(0)
    clip = tmp_path / "clip.mp4"
    write_video(clip, (rng.integers(0, 256, (48, 64, 3), dtype=np.uint8) for _ in range(10)), 25.0)
    data = clip.read_bytes()
    cut = tmp_path / "cut.mp4"
    cut.write_bytes(data[: len(data) // 2])
    source = open_frames(cut)
    frames = list(source)
    assert 0 < len(frames) < 10
    assert [index for index, _ in frames] == list(range(len(frames)))
    assert source.stopped_early.startswith(f"decoding stopped at frame {len(frames)}: ")


def write_images(folder, names, levels, dtype=np.uint8, channels=1):
    folder.mkdir(exist_ok=True)
    for name, value in zip(names, levels):
        shape = (20, 30) if channels == 1 else (20, 30, channels)
        cv2.imwrite(str(folder / name), np.full(shape, value, dtype))


def test_folder_is_read_in_natural_order(tmp_path):
    folder = tmp_path / "frames"
    write_images(folder, ["img10.png", "img2.png", "img1.png", "IMG3.PNG"], [100, 20, 10, 30])
    (folder / "notes.txt").write_text("ignored")
    source = open_frames(folder)
    assert (source.fps, source.frame_count, source.size) == (25.0, 4, (30, 20))
    frames = list(source)
    assert [index for index, _ in frames] == [0, 1, 2, 3]
    assert [level(image) for _, image in frames] == [10, 20, 30, 100]
    assert frames[0][1].shape == (20, 30, 3) and frames[0][1].dtype == np.uint8


@pytest.fixture(scope="module")
def seven_images(tmp_path_factory):
    folder = tmp_path_factory.mktemp("seven")
    write_images(folder, [f"f{i}.png" for i in range(7)], [10 * i for i in range(7)])
    return folder


@settings(max_examples=40, deadline=None)
@given(start=st.integers(0, 6), length=st.one_of(st.none(), st.integers(1, 10)), step=st.integers(1, 8))
def test_any_sensible_range_yields_the_matching_indices(seven_images, start, length, step):
    end = None if length is None else start + length
    expected = list(range(start, 7 if end is None else min(end, 7), step))
    source = open_frames(seven_images, start=start, end=end, step=step)
    assert source.frame_count == len(expected)
    assert [(index, level(image)) for index, image in source] == [(i, 10 * i) for i in expected]


def test_glob_pattern_selects_matching_images(tmp_path):
    folder = tmp_path / "frames"
    write_images(folder, ["b2.png", "b10.png", "a1.png", "b1.jpg"], [20, 100, 5, 60])
    frames = list(open_frames(str(folder / "b*.png"), start=1))
    assert [(index, level(image)) for index, image in frames] == [(1, 100)]


def test_colour_and_alpha_images_become_bgr(tmp_path):
    folder = tmp_path / "frames"
    folder.mkdir()
    bgra = np.zeros((20, 30, 4), np.uint8)
    bgra[..., 0], bgra[..., 2], bgra[..., 3] = 200, 50, 255
    cv2.imwrite(str(folder / "0.png"), bgra)
    (_, image), = open_frames(folder)
    assert image.shape == (20, 30, 3)
    assert tuple(image[0, 0]) == (200, 0, 50)


def test_sixteen_bit_images_come_as_stored_and_are_shown_by_the_range_of_their_data(tmp_path):
    folder = tmp_path / "frames"
    folder.mkdir()
    # 12-bit data (brightest 3000 < 4096) in 16-bit words: 0..4095 is black to white, whatever
    # the first frame's own darkest and brightest pixels; later frames keep that map.
    first = np.full((20, 30), 1000, np.uint16)
    first[0, :] = 3000
    cv2.imwrite(str(folder / "f1.tif"), first)
    cv2.imwrite(str(folder / "f2.png"), np.full((20, 30), 2000, np.uint16))
    cv2.imwrite(str(folder / "f3.tif"), np.full((20, 30), 5000, np.uint16))
    source = open_frames(folder)
    images = [image for _, image in source]
    assert [(image.dtype, image.shape) for image in images] == [(np.uint16, (20, 30))] * 3
    np.testing.assert_array_equal(images[0], first)
    assert source.span == (0.0, 4095.0)
    shown = [to_bgr8(image, source.span) for image in images]
    assert all(picture.dtype == np.uint8 and picture.shape == (20, 30, 3) for picture in shown)
    assert shown[0][0, 0, 0] == round(3000 * 255 / 4095) and shown[0][5, 5, 0] == round(1000 * 255 / 4095)
    assert shown[1][5, 5, 0] == round(2000 * 255 / 4095)
    assert shown[2][5, 5, 0] == 255


def test_float_and_deep_colour_images_keep_their_values_and_lose_only_alpha(tmp_path):
    stack = tmp_path / "float.tif"
    pages = [np.linspace(0, value, 600, dtype=np.float32).reshape(20, 30) for value in (0.5, 1.0)]
    assert cv2.imwritemulti(str(stack), pages)
    source = open_frames(stack)
    read = [image for _, image in source]
    assert source.span == (0.0, 1.0)
    for got, written in zip(read, pages):
        assert got.dtype == np.float32
        np.testing.assert_array_equal(got, written)
    bgra = np.zeros((20, 30, 4), np.uint16)
    bgra[..., 0], bgra[..., 2], bgra[..., 3] = 40000, 300, 65535
    cv2.imwrite(str(tmp_path / "colour.png"), bgra)
    (_, image), = open_frames(tmp_path / "colour.png")
    assert image.dtype == np.uint16 and image.shape == (20, 30, 3)
    assert tuple(image[0, 0]) == (40000, 0, 300)


def test_a_frame_of_another_depth_stops_the_clip_there(tmp_path):
    folder = tmp_path / "frames"
    folder.mkdir()
    cv2.imwrite(str(folder / "1.png"), np.full((20, 30), 3000, np.uint16))
    cv2.imwrite(str(folder / "2.png"), np.full((20, 30), 30, np.uint8))
    source = open_frames(folder)
    assert [index for index, _ in source] == [0]
    assert source.stopped_early == "decoding stopped at frame 1: 2.png holds uint8 data, the first frame uint16"


def test_multi_page_tiff_is_read_page_by_page(tmp_path):
    path = tmp_path / "stack.tif"
    pages = [np.full((20, 30), value, np.uint8) for value in (10, 20, 30, 40)]
    assert cv2.imwritemulti(str(path), pages)
    source = open_frames(path, start=1, step=2)
    assert (source.frame_count, source.size) == (2, (30, 20))
    assert [(index, level(image)) for index, image in source] == [(1, 20), (3, 40)]


def test_unreadable_image_mid_folder_stops_early(tmp_path):
    folder = tmp_path / "frames"
    write_images(folder, ["1.png", "2.png", "4.png"], [10, 20, 40])
    (folder / "3.png").write_bytes(b"not a png")
    source = open_frames(folder)
    assert [index for index, _ in source] == [0, 1]
    assert source.stopped_early == "decoding stopped at frame 2: cannot read 3.png"


@pytest.mark.parametrize("name", ["missing.mp4", "missing_folder", "frames/*.png"])
def test_missing_path_is_a_data_error(tmp_path, name):
    with pytest.raises(DataError, match="no such file or folder|no images"):
        open_frames(str(tmp_path / name))


def test_folder_without_images_is_a_data_error(tmp_path):
    (tmp_path / "notes.txt").write_text("hello")
    with pytest.raises(DataError, match=r"no images \(png, jpg, tif\) in folder"):
        open_frames(tmp_path)


def test_file_that_is_not_a_video_is_a_data_error(tmp_path):
    path = tmp_path / "clip.mp4"
    path.write_text("definitely not a video\n" * 50)
    with pytest.raises(DataError, match="not a video") as caught:
        open_frames(path)
    assert "\n" not in str(caught.value)


@pytest.mark.parametrize(
    "start, end, step, message",
    [
        (-1, None, 1, "start"),
        (1.5, None, 1, "start"),
        (5, 5, 1, "end"),
        (5, 2, 1, "end"),
        (0, None, 0, "step"),
        (0, None, True, "step"),
        (10, None, 1, "past the last frame"),
    ],
)
def test_nonsense_range_is_a_data_error(clip, start, end, step, message):
    with pytest.raises(DataError, match=message):
        open_frames(clip, start=start, end=end, step=step)
