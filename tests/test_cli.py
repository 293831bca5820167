"""End-to-end: the real ``seedtrack`` command on small generated clips."""

import subprocess
import sys

import av
import numpy as np
import pytest

from seedtrack.cli import main
from seedtrack.data.csvio import read_table
from seedtrack.data.dish import DishSpec, write_dish_clip


def seedtrack(*args):
    return subprocess.run([sys.executable, "-m", "seedtrack", *map(str, args)], capture_output=True, text=True)


@pytest.fixture(scope="module")
def small_clip(tmp_path_factory):
    folder = tmp_path_factory.mktemp("clip")
    write_dish_clip(DishSpec(seeds=30, frames=6, width=320, height=240, rim_speed=20.0, random_seed=5), folder)
    return folder


def test_demo_tracks_every_seed(tmp_path):
    result = seedtrack("demo", "--out", tmp_path / "demo")
    assert result.returncode == 0, result.stderr
    assert "80 of 80 seeds tracked correctly over all 10 frames (track error 0.000" in result.stdout


def test_run_writes_detections_tracks_and_an_overlay(small_clip, tmp_path):
    out = tmp_path / "out"
    result = seedtrack("run", small_clip / "clip.mp4", "--out", out)
    assert result.returncode == 0, result.stderr
    detections = read_table(out / "detections.csv", required=("frame", "x", "y", "area"))
    tracks = read_table(out / "tracks.csv", required=("track_id", "frame", "x", "y", "interpolated"))
    assert sorted(set(detections["frame"])) == list(range(6))
    assert len(set(tracks["track_id"])) == 30
    with av.open(str(out / "overlay.mp4")) as container:
        stream = container.streams.video[0]
        assert stream.codec_context.name == "h264"
        frames = list(container.decode(video=0))
    assert len(frames) == 6
    assert frames[0].format.name == "yuv420p"


def test_run_is_repeatable_byte_for_byte(small_clip, tmp_path):
    for name in ("a", "b"):
        assert main(["run", str(small_clip / "clip.mp4"), "--out", str(tmp_path / name)]) == 0
    for file in ("detections.csv", "tracks.csv", "overlay.mp4"):
        assert (tmp_path / "a" / file).read_bytes() == (tmp_path / "b" / file).read_bytes()


def test_max_speed_option_reaches_the_tracker(small_clip, tmp_path):
    # A limit far below the seeds' speeds leaves the fast seeds without links: no track steps
    # faster than it, so the seeds' tracks fall apart.
    assert main(["run", str(small_clip / "clip.mp4"), "--out", str(tmp_path / "slow"), "--max-speed", "2"]) == 0
    tracks = read_table(tmp_path / "slow" / "tracks.csv")
    order = np.lexsort((tracks["frame"], tracks["track_id"]))
    track, frame = tracks["track_id"][order], tracks["frame"][order]
    same = track[1:] == track[:-1]
    step = np.hypot(np.diff(tracks["x"][order]), np.diff(tracks["y"][order]))[same] / np.diff(frame)[same]
    assert (step <= 2.0 + 1e-6).all() and len(set(tracks["track_id"])) > 30


@pytest.mark.parametrize(
    "make_input, message",
    [
        (lambda tmp: tmp / "missing.mp4", "no such file"),
        (lambda tmp: _write(tmp / "notes.mp4", b"this is not a video"), "notes.mp4"),
        (lambda tmp: _folder(tmp / "empty"), "no images"),
    ],
)
def test_bad_input_is_one_line_exit_2_and_no_outputs(tmp_path, make_input, message):
    clip = make_input(tmp_path)
    out = tmp_path / "out" / "sub"
    result = seedtrack("run", clip, "--out", out)
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1 and "Traceback" not in result.stderr
    assert message in result.stderr
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("stage", ["detect_clip", "track_frames"])
def test_ctrl_c_leaves_no_part_of_a_set_and_no_empty_folder(small_clip, tmp_path, capsys, monkeypatch, stage):
    import seedtrack.pipeline

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(seedtrack.pipeline, stage, interrupted)
    out = tmp_path / "out"
    assert main(["run", str(small_clip / "clip.mp4"), "--out", str(out)]) == 130
    assert "interrupted" in capsys.readouterr().err
    # run's files are one set (see test_faults): the detections finished alone are not kept.
    assert not out.exists()


def test_unwritable_output_folder(small_clip, tmp_path):
    blocker = _write(tmp_path / "file", b"")
    result = seedtrack("run", small_clip / "clip.mp4", "--out", blocker / "sub")
    assert result.returncode == 2
    assert "Traceback" not in result.stderr and str(blocker / "sub") in result.stderr


def test_nonsense_option_is_exit_2(small_clip, tmp_path):
    result = seedtrack("run", small_clip / "clip.mp4", "--out", tmp_path, "--phi-max", "-1")
    assert result.returncode == 2
    assert "--phi-max must be a positive finite number, got -1" in result.stderr and "Traceback" not in result.stderr


def _write(path, content):
    path.write_bytes(content)
    return path


def _folder(path):
    path.mkdir()
    return path


def test_output_piped_into_a_closed_reader_is_not_a_traceback(tmp_path):
    tracks = _write(tmp_path / "tracks.csv", b"track_id,frame,x,y,interpolated\n0,0,1,1,0\n0,1,2,2,0\n1,0,9,9,0\n1,1,8,8,0\n")
    process = subprocess.Popen(
        [sys.executable, "-m", "seedtrack", "evaluate", tracks, "--truth", tracks],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    process.stdout.close()  # the reader is gone before the table is printed, as with `| head -0`
    stderr = process.stderr.read()
    assert process.wait() == 141
    assert "Traceback" not in stderr


def test_version_is_the_installed_package_version():
    from importlib.metadata import version

    result = seedtrack("--version")
    assert result.returncode == 0 and result.stdout.strip() == f"seedtrack {version('seedtrack')}"


def test_run_starts_the_fork_server_before_its_imports_only_for_more_than_one_worker():
    from seedtrack.cli import _workers_asked

    assert _workers_asked(["run", "clip.mp4", "--out", "out", "--workers", "2"]) == 2
    assert _workers_asked(["run", "clip.mp4", "--workers=3", "--out", "out"]) == 3
    assert _workers_asked(["run", "clip.mp4", "--out", "out", "--workers", "1"]) == 1
    assert _workers_asked(["run", "--help"]) == 1
    assert _workers_asked(["run", "clip.mp4", "--out", "out", "--workers", "two"]) == 1


@pytest.mark.parametrize("command", ["run", "detect", "render", "batch", "compare", "annotate", "review"])
def test_help_names_every_kind_of_clip_input(command, capsys):
    with pytest.raises(SystemExit):
        main([command, "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for kind in ("video file", "TIFF stack", "image folder", "glob pattern"):
        assert kind in text, f"{command} --help does not name {kind}"
