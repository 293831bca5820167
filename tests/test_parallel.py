"""Work over frames in several threads: the same results, in the same order, as one."""

import threading
import time

import numpy as np
import pytest

from seedtrack.cli import main
from seedtrack.data.dish import DishSpec, write_dish_clip
from seedtrack.parallel import VideoEncoder, default_workers, read_ahead, threaded_map


def _square_or_fail(value: int) -> int:
    if value == 7:
        raise ValueError("seven")
    return value * value


def test_threaded_map_keeps_the_order_of_the_items():
    items = range(40)
    assert list(threaded_map(_square_or_fail, (i for i in items if i != 7), workers=2)) == [i * i for i in items if i != 7]


def test_an_error_in_a_worker_is_raised_at_its_item():
    results = threaded_map(_square_or_fail, range(10), workers=2)
    assert [next(results) for _ in range(7)] == [i * i for i in range(7)]
    with pytest.raises(ValueError, match="seven"):
        next(results)


def _count_then_fail(taken: list):
    for value in range(5):
        taken.append(value)
        yield value
    raise ValueError("five")


def test_read_ahead_keeps_the_order_and_raises_the_readers_error_at_its_item():
    taken = []
    with read_ahead(_count_then_fail(taken), depth=2) as items:
        assert [next(items) for _ in range(5)] == [0, 1, 2, 3, 4]
        with pytest.raises(ValueError, match="five"):
            next(items)


def test_leaving_read_ahead_early_stops_its_thread():
    taken = []
    with read_ahead(_count_then_fail(taken), depth=1) as items:
        assert next(items) == 0
    # At most the item handed over, one queued and one waiting to be queued were taken.
    assert len(taken) <= 3
    assert not any(thread.name == "read-ahead" for thread in threading.enumerate())


def test_threads_take_a_function_no_process_could_be_sent():
    offset = 3
    assert list(threaded_map(lambda value: value + offset, range(20), workers=2)) == list(range(3, 23))
    assert not any(thread.name.startswith("worker") for thread in threading.enumerate())


def test_an_encoder_left_without_frames_stops_and_leaves_no_file(tmp_path):
    # As when tracking fails after the encoder's process was started beside it.
    with VideoEncoder(tmp_path / "overlay.mp4", 25.0, workers=2) as encoder:
        process = encoder._encoder
        assert process.is_alive()
    assert not process.is_alive() and list(tmp_path.iterdir()) == []


def test_an_encoder_started_early_writes_what_one_in_this_process_writes(tmp_path):
    frames = [np.full((32, 48, 3), value, np.uint8) for value in (0, 90, 200)]
    for workers in (1, 2):
        with VideoEncoder(tmp_path / f"{workers}.mp4", 25.0, workers) as encoder:
            assert encoder.write(iter(frames)) == 3
    assert (tmp_path / "1.mp4").read_bytes() == (tmp_path / "2.mp4").read_bytes()


def test_default_workers_is_the_usable_cores():
    assert 1 <= default_workers()


def test_run_gives_the_same_bytes_with_one_two_and_three_workers(tmp_path):
    # With two and three frames are detected and drawn in threads, and encoded in a process.
    write_dish_clip(DishSpec(seeds=20, frames=12, width=256, height=192, rim_speed=12.0, random_seed=3), tmp_path / "clip")
    for workers in ("1", "2", "3"):
        assert main(["run", str(tmp_path / "clip" / "clip.mp4"), "--out", str(tmp_path / workers), "--workers", workers]) == 0
    for name in ("detections.csv", "tracks.csv", "overlay.mp4"):
        for workers in ("2", "3"):
            assert (tmp_path / "1" / name).read_bytes() == (tmp_path / workers / name).read_bytes(), (name, workers)


class _Counted:
    """A frame source that counts the frames taken from it."""

    def __init__(self, source):
        self.source, self.taken = source, 0

    def __getattr__(self, name):
        return getattr(self.source, name)

    def __enter__(self):
        self.source.__enter__()
        return self

    def __exit__(self, *exc_info):
        return self.source.__exit__(*exc_info)

    def __iter__(self):
        for item in self.source:
            self.taken += 1
            yield item


@pytest.mark.parametrize("workers", [1, 2])
def test_with_two_workers_the_overlay_takes_the_frames_detection_decoded(tmp_path, monkeypatch, workers):
    # With one, the overlay decodes them again, a few ahead, so that memory does not grow with
    # the clip.
    from seedtrack import pipeline

    write_dish_clip(DishSpec(seeds=20, frames=40, width=256, height=192, rim_speed=12.0, random_seed=3), tmp_path / "clip")
    sources, seen = [], []
    opened, track = pipeline.open_frames, pipeline.track_frames

    def counted(*args, **kwargs):
        sources.append(_Counted(opened(*args, **kwargs)))
        return sources[-1]

    def tracking(*args, **kwargs):
        time.sleep(0.3)
        seen.append(sources[-1].taken)
        return track(*args, **kwargs)

    monkeypatch.setattr(pipeline, "open_frames", counted)
    monkeypatch.setattr(pipeline, "track_frames", tracking)
    pipeline.run_pipeline(tmp_path / "clip" / "clip.mp4", tmp_path / "out", workers=workers)
    assert sources[0].taken == 40
    assert sources[-1].taken == (0 if workers > 1 else 40)
    assert seen == [0] if workers > 1 else 0 < seen[0] <= 5


def test_the_overlay_decodes_again_only_the_frames_before_those_kept(tmp_path, monkeypatch):
    from seedtrack import pipeline

    write_dish_clip(DishSpec(seeds=20, frames=40, width=256, height=192, rim_speed=12.0, random_seed=3), tmp_path / "clip")
    clip = tmp_path / "clip" / "clip.mp4"
    # Room for the last 10 of the 40 frames (256 x 192 BGR).
    monkeypatch.setattr(pipeline, "_KEPT_FOR_OVERLAY_BYTES", 10 * 256 * 192 * 3)
    sources = []
    opened = pipeline.open_frames

    def counted(*args, **kwargs):
        sources.append(_Counted(opened(*args, **kwargs)))
        return sources[-1]

    monkeypatch.setattr(pipeline, "open_frames", counted)
    pipeline.run_pipeline(clip, tmp_path / "two", workers=2)
    # The first 30 frames, and the first kept one, seen and left.
    assert sources[-1].taken == 31
    monkeypatch.setattr(pipeline, "open_frames", opened)
    pipeline.run_pipeline(clip, tmp_path / "one", workers=1)
    for name in ("detections.csv", "tracks.csv", "overlay.mp4"):
        assert (tmp_path / "one" / name).read_bytes() == (tmp_path / "two" / name).read_bytes(), name


def test_workers_below_one_is_refused(tmp_path, capsys):
    assert main(["run", str(tmp_path / "none.mp4"), "--out", str(tmp_path / "out"), "--workers", "0"]) == 2
    assert "--workers must be a whole number >= 1" in capsys.readouterr().err
