"""Tests of data.video: H.264 MP4 writing and probing."""

from __future__ import annotations

import av
import numpy as np
import pytest

from seedtrack.data.errors import DataError
from seedtrack.data.video import probe_video, write_video


def gradient_frames(count: int, width: int = 64, height: int = 48, gray: bool = False) -> list[np.ndarray]:
    """Smooth frames (compress well, so decoded pixels stay close) that differ per frame."""
    y, x = np.mgrid[0:height, 0:width]
    frames = []
    for index in range(count):
        grey = (2 * x + y + 5 * index) % 200 + 20
        frame = grey.astype(np.uint8)
        frames.append(frame if gray else np.dstack([frame, frame // 2 + 40, 255 - frame]))
    return frames


def decode_all(path) -> list[np.ndarray]:
    with av.open(str(path)) as container:
        return [frame.to_ndarray(format="bgr24") for frame in container.decode(video=0)]


def test_round_trip_gives_h264_yuv420p_with_frame_count_size_and_rate(tmp_path):
    path = tmp_path / "clip.mp4"
    frames = gradient_frames(12)

    assert write_video(path, frames, 25.0) == 12

    with av.open(str(path)) as container:
        stream = container.streams.video[0]
        assert stream.codec_context.name == "h264"
        assert stream.format.name == "yuv420p"
        assert next(container.decode(stream)).format.name == "yuv420p"
    info = probe_video(path)
    assert (info.frame_count, info.exact, info.size, info.codec) == (12, True, (64, 48), "h264")
    assert info.fps == pytest.approx(25.0)
    decoded = decode_all(path)
    assert len(decoded) == 12
    error = np.abs(np.stack(decoded).astype(int) - np.stack(frames).astype(int))
    assert error.mean() < 3


def test_fractional_frame_rate_survives(tmp_path):
    path = tmp_path / "ntsc.mp4"
    write_video(path, gradient_frames(3), 30000 / 1001)
    assert probe_video(path).fps == pytest.approx(29.97, abs=1e-3)


def test_gray_frames_are_written_as_colour_video(tmp_path):
    path = tmp_path / "gray.mp4"
    frames = gradient_frames(4, gray=True)
    write_video(path, frames, 25.0)
    decoded = decode_all(path)
    assert decoded[0].shape == (48, 64, 3)
    assert np.abs(decoded[2][..., 1].astype(int) - frames[2]).mean() < 3


def test_odd_size_is_padded_on_the_right_and_bottom(tmp_path):
    path = tmp_path / "odd.mp4"
    frames = gradient_frames(3, width=63, height=47)
    write_video(path, frames, 25.0)
    assert probe_video(path).size == (64, 48)
    decoded = decode_all(path)[1]
    assert np.abs(decoded[:47, :63].astype(int) - frames[1]).mean() < 3


def test_same_frames_give_the_same_bytes(tmp_path):
    rng = np.random.default_rng(3)
    frames = [rng.integers(0, 256, (48, 64, 3), dtype=np.uint8) for _ in range(10)]
    write_video(tmp_path / "a.mp4", frames, 25.0)
    write_video(tmp_path / "b.mp4", frames, 25.0)
    assert (tmp_path / "a.mp4").read_bytes() == (tmp_path / "b.mp4").read_bytes()


def test_failed_write_leaves_nothing_behind(tmp_path):
    def frames_then_failure():
        yield from gradient_frames(3)
        raise RuntimeError("camera unplugged")

    with pytest.raises(RuntimeError):
        write_video(tmp_path / "clip.mp4", frames_then_failure(), 25.0)
    assert list(tmp_path.iterdir()) == []


def test_existing_file_is_kept_when_a_write_fails(tmp_path):
    path = tmp_path / "clip.mp4"
    write_video(path, gradient_frames(2), 25.0)
    before = path.read_bytes()
    with pytest.raises(ValueError):
        write_video(path, [gradient_frames(1)[0], np.zeros((10, 10, 3), np.uint8)], 25.0)
    assert path.read_bytes() == before
    assert [entry.name for entry in tmp_path.iterdir()] == ["clip.mp4"]


class Counter:
    def __init__(self) -> None:
        self.n = 0

    def update(self, n: int) -> None:
        self.n += n


def test_progress_is_ticked_once_per_frame(tmp_path):
    counter = Counter()
    write_video(tmp_path / "a.mp4", gradient_frames(5), 25.0, progress=counter)
    assert counter.n == 5
    ticks = []
    write_video(tmp_path / "b.mp4", gradient_frames(4), 25.0, progress=ticks.append)
    assert ticks == [1, 1, 1, 1]


@pytest.mark.parametrize(
    "frames, fps, crf",
    [
        ([], 25.0, 18),
        (gradient_frames(2), 0.0, 18),
        (gradient_frames(2), 25.0, 60),
        ([np.zeros((8, 8, 3), np.float32)], 25.0, 18),
        ([np.zeros((8, 8, 4), np.uint8)], 25.0, 18),
    ],
)
def test_bad_arguments_raise_value_error(tmp_path, frames, fps, crf):
    with pytest.raises(ValueError):
        write_video(tmp_path / "clip.mp4", frames, fps, crf=crf)
    assert list(tmp_path.iterdir()) == []


def test_missing_output_folder_is_a_data_error(tmp_path):
    with pytest.raises(DataError, match="does not exist"):
        write_video(tmp_path / "nowhere" / "clip.mp4", gradient_frames(2), 25.0)


def test_probe_rejects_missing_and_non_video_files(tmp_path):
    with pytest.raises(DataError, match="no such file"):
        probe_video(tmp_path / "missing.mp4")
    text = tmp_path / "notes.mp4"
    text.write_text("not a video\n" * 100)
    with pytest.raises(DataError, match="not a video"):
        probe_video(text)


def test_the_preview_preset_is_the_one_x264_writes_into_the_file(tmp_path):
    # x264 records its settings in the stream: ultrafast turns CABAC off, veryfast keeps it.
    from seedtrack.data.video import PREVIEW_PRESET

    frames = [np.full((32, 48, 3), 40 * k, np.uint8) for k in range(3)]
    write_video(tmp_path / "preview.mp4", frames, 25.0, preset=PREVIEW_PRESET)
    write_video(tmp_path / "default.mp4", frames, 25.0)
    assert b"cabac=0" in (tmp_path / "preview.mp4").read_bytes()
    assert b"cabac=1" in (tmp_path / "default.mp4").read_bytes()
