"""The Python API gives the command's answers: same detections, same tracks, same scores."""

from __future__ import annotations

import dataclasses
import doctest
import importlib
import inspect
import subprocess
import sys
import textwrap
import warnings
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
import pytest

import seedtrack
import seedtrack.api
from seedtrack.cli import build_parser, main
from seedtrack.commands import settings_of
from seedtrack.data.csvio import TRACK_COLUMNS, write_table
from seedtrack.data.dish import DishSpec, write_dish_clip
from seedtrack.data.frames import open_frames
from seedtrack.data.psmg import PSMGSpec, generate_psmg
from seedtrack.data.trackfile import write_tracks
from seedtrack.data.walkers import WalkerSpec, generate_walkers
from seedtrack.errors import OptionError
from seedtrack.pipeline import DetectSettings
from seedtrack.settings import EvaluateSettings, LinkSettings, RenderSettings


def command(capsys, *argv) -> str:
    """Run ``seedtrack ARGV`` in this process; its standard output."""
    capsys.readouterr()
    status = main([str(a) for a in argv])
    out = capsys.readouterr()
    assert status == 0, out.err
    return out.out


def read_csv(path) -> pd.DataFrame:
    return pd.read_csv(path)


def as_file(tmp_path, name: str, columns: dict) -> bytes:
    """The bytes the command's CSV writer makes of these columns."""
    write_table(tmp_path / name, {c: np.asarray(v) for c, v in columns.items()})
    return (tmp_path / name).read_bytes()


def scores_printed(text: str) -> dict:
    measures = {}
    for line in text.splitlines():
        name, value = line.split(maxsplit=1)
        measures[name] = value
    return measures


def assert_same_scores(api: seedtrack.Scores, printed: str) -> None:
    table = scores_printed(printed)
    for name, value in dataclasses.asdict(api).items():
        if isinstance(value, float):
            # The command prints six decimals of numbers computed from positions rounded to four.
            assert float(table[name]) == pytest.approx(value, abs=2e-5 if name in ("motp_px", "isbi_rmse_px", "loc_a") else 1e-6), name
        else:
            assert table[name] == str(value), name


@pytest.fixture(scope="module")
def dish(tmp_path_factory):
    folder = tmp_path_factory.mktemp("dish")
    scene = write_dish_clip(DishSpec(seeds=30, frames=8, width=320, height=240, rim_speed=15.0, random_seed=3, hidden_probability=0.05), folder)
    write_tracks(folder / "truth.csv", scene.truth)
    return folder


def test_dish_clip_detections_tracks_scores_and_picture_match_the_command(dish, tmp_path, capsys):
    clip = dish / "clip.mp4"
    command(capsys, "run", clip, "--out", tmp_path / "run")
    points = seedtrack.detect(clip)
    assert as_file(tmp_path, "d.csv", points) == (tmp_path / "run" / "detections.csv").read_bytes()
    with open_frames(clip) as source:
        frames = [image for _, image in source]
    pd.testing.assert_frame_equal(seedtrack.detect(frames), points)
    tracks = seedtrack.link(points)
    assert tracks.attrs["motion"].startswith("motion: ")
    written = {c: tracks[c] for c in TRACK_COLUMNS}
    assert as_file(tmp_path, "t.csv", written) == (tmp_path / "run" / "tracks.csv").read_bytes()
    printed = command(capsys, "evaluate", tmp_path / "run" / "tracks.csv", "--truth", dish / "truth.csv")
    assert_same_scores(seedtrack.evaluate(tracks, read_csv(dish / "truth.csv")), printed)
    command(capsys, "render", clip, tmp_path / "run" / "tracks.csv", "--out", tmp_path / "command.png")
    message = seedtrack.render(clip, read_csv(tmp_path / "run" / "tracks.csv"), tmp_path / "api.png")
    assert message.startswith(f"wrote {tmp_path / 'api.png'}: 1 frame of ")
    assert (tmp_path / "api.png").read_bytes() == (tmp_path / "command.png").read_bytes()


def test_detection_options_reach_the_detector_as_the_command_gives_them(dish, tmp_path, capsys):
    clip = dish / "clip.mp4"
    options = ["--roi", "160,120,90", "--threshold", "25", "--start", "1", "--step", "2", "--background", "temporal"]
    command(capsys, "detect", clip, "--out", tmp_path / "d.csv", *options)
    points = seedtrack.detect(clip, roi=(160, 120, 90), threshold=25, start=1, step=2, background="temporal")
    assert as_file(tmp_path, "api.csv", points) == (tmp_path / "d.csv").read_bytes()
    with open_frames(clip) as source:
        in_memory = seedtrack.detect((image for _, image in source), roi=(160, 120, 90), threshold=25, start=1, step=2, background="temporal")
    pd.testing.assert_frame_equal(in_memory, points)
    mask = np.zeros((240, 320), np.uint8)
    mask[40:200, 60:260] = 255
    cv2.imwrite(str(tmp_path / "mask.png"), mask)
    command(capsys, "detect", clip, "--out", tmp_path / "masked.csv", "--roi", tmp_path / "mask.png")
    with open_frames(clip) as source:
        masked = seedtrack.detect((image for _, image in source), roi=tmp_path / "mask.png")
    assert as_file(tmp_path, "api-masked.csv", masked) == (tmp_path / "masked.csv").read_bytes()


def points_file(tmp_path, frames: list[np.ndarray]) -> pd.DataFrame:
    """The points as the command reads them from a CSV file, with each point's row number."""
    counts = [len(f) for f in frames]
    xy = np.concatenate(frames)
    write_table(tmp_path / "points.csv", {"frame": np.repeat(np.arange(len(frames)), counts), "x": xy[:, 0], "y": xy[:, 1], "row": np.arange(len(xy))})
    return read_csv(tmp_path / "points.csv")


def partition(tracks: pd.DataFrame) -> set[frozenset]:
    measured = tracks[tracks.interpolated == 0]
    return {frozenset(rows.astype(int)) for _, rows in measured.groupby("track_id")["row"]}


@pytest.mark.parametrize(
    "scene, options",
    [
        (generate_walkers(WalkerSpec(walkers=150, frames=12, size=300.0, drift=(1.0, 0.5), missed=0.03, random_seed=7)), {}),
        (generate_psmg(PSMGSpec(trajectories=40, frames=15, mean_speed=4.0, occlusion=0.05, max_gap=2, random_seed=4)), {"max_speed": 8.0, "max_gap": 3}),
        (generate_psmg(PSMGSpec(trajectories=30, frames=12, random_seed=2)), {"algorithm": "goa-updown-fixed"}),
        (generate_walkers(WalkerSpec(walkers=60, frames=8, size=200.0, random_seed=1)), {"algorithm": "nn", "max_speed": 6.0, "min_length": 3}),
    ],
    ids=["walkers", "psmg", "psmg-fixed", "walkers-nn"],
)
def test_points_link_and_score_as_the_command_does(scene, options, tmp_path, capsys):
    frames, truth = scene
    table = points_file(tmp_path, frames)
    argv = [f"--{name.replace('_', '-')}={value}" for name, value in options.items()]
    said = command(capsys, "track", tmp_path / "points.csv", "--out", tmp_path / "tracks.csv", *argv)
    tracks = seedtrack.link(table, **options)
    from_command = read_csv(tmp_path / "tracks.csv")
    assert partition(tracks) == partition(from_command)
    assert as_file(tmp_path, "t.csv", {c: tracks[c] for c in TRACK_COLUMNS}) == as_file(tmp_path, "c.csv", {c: from_command[c] for c in TRACK_COLUMNS})
    if tracks.attrs["motion"]:
        assert said.splitlines()[0] == tracks.attrs["motion"]
    # The input's other columns ride along on measured rows only, with no join on positions.
    measured = tracks.interpolated == 0
    assert np.array_equal(table["x"].to_numpy()[tracks["row"][measured].astype(int)], tracks["x"][measured])
    assert tracks["row"][~measured].isna().all()
    write_tracks(tmp_path / "truth.csv", truth)
    printed = command(capsys, "evaluate", tmp_path / "tracks.csv", "--truth", tmp_path / "truth.csv")
    assert_same_scores(seedtrack.evaluate(tracks, read_csv(tmp_path / "truth.csv")), printed)


def test_the_library_tracker_gives_the_command_answer_on_random_walkers():
    frames, truth = generate_walkers(WalkerSpec(walkers=150, frames=12, size=300.0, random_seed=11))
    table = pd.DataFrame({"frame": np.repeat(np.arange(len(frames)), [len(f) for f in frames]), "x": np.concatenate(frames)[:, 0], "y": np.concatenate(frames)[:, 1]})
    library = seedtrack.run_tracker("goa-updown", [f[np.lexsort((f[:, 1], f[:, 0]))] for f in frames])
    api = seedtrack.evaluate(table.pipe(seedtrack.link), truth)
    scores = seedtrack.evaluate(library, truth)
    assert scores == api
    assert scores.link_error < 0.02


def test_options_are_the_commands_and_mistakes_name_the_keyword():
    points = pd.DataFrame({"frame": [0, 0, 1, 1], "x": [0.0, 9.0, 1.0, 10.0], "y": [0.0, 0.0, 0.0, 0.0]})
    with pytest.raises(TypeError, match="max_sped"):
        seedtrack.link(points, max_sped=3.0)
    with pytest.raises(ValueError, match="^max_speed must be a positive"):
        seedtrack.link(points, max_speed=-1.0)
    with pytest.raises(ValueError, match="max_gap does not apply with fixed_count"):
        seedtrack.link(points, fixed_count=True, max_gap=2)
    with pytest.raises(ValueError, match="points: missing column.*y"):
        seedtrack.link(points.drop(columns="y"))
    with pytest.raises(ValueError, match="points: row 1: column x holds nan"):
        seedtrack.link(points.assign(x=[0.0, np.nan, 1.0, 10.0]))
    with pytest.raises(ValueError, match="points: all points are in frame 0"):
        seedtrack.link(points.assign(frame=0))
    with pytest.raises(ValueError, match="^tol must be a positive"):
        seedtrack.evaluate(points.assign(track_id=[0, 1, 0, 1]), points.assign(track_id=[0, 1, 0, 1]), tol=0)
    with pytest.raises(ValueError, match="frame 0 must be an .* array of uint8, uint16 or float"):
        seedtrack.detect([np.zeros((10, 10), np.int64)])
    with pytest.raises(ValueError, match="^threshold must be otsu"):
        seedtrack.detect([np.zeros((10, 10), np.uint8)], threshold="high")
    with pytest.raises(ValueError, match="frame 1 is 12x10, the first 10x10"):
        seedtrack.detect([np.zeros((10, 10), np.uint8), np.zeros((10, 12), np.uint8)])
    with pytest.raises(TypeError, match="preview"):
        seedtrack.detect([np.zeros((10, 10), np.uint8)], preview="p.png")
    with pytest.raises(OptionError, match="^algorithm must be one of") as raised:
        seedtrack.link(points, algorithm="knn")
    assert raised.value.names == ("algorithm",)
    with pytest.raises(ValueError, match="^phi_max, motion only apply to algorithm goa or goa-updown, not nn"):
        seedtrack.link(points, algorithm="nn", phi_max=0.2, motion="smooth")
    with pytest.raises(ValueError, match="^frame chooses the frame of a .png output"):
        seedtrack.render("clip.mp4", points, "out.gif", frame=2)


def test_the_library_loads_no_command_and_builds_no_parser(dish, tmp_path):
    code = textwrap.dedent(
        f"""
        import argparse, sys
        import seedtrack
        argparse.ArgumentParser.__init__ = None  # building a parser would fail
        clip = {str(dish / "clip.mp4")!r}
        tracks = seedtrack.link(seedtrack.detect(clip, end=4), max_gap=2)
        scores = seedtrack.evaluate(tracks, {str(dish / "truth.csv")!r}, tol=2.0)
        seedtrack.render(clip, tracks, {str(tmp_path / "last.png")!r}, trail=3)
        print(sorted(m for m in sys.modules if m.startswith(("seedtrack.commands", "seedtrack.cli"))))
        """
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines()[-1] == "[]"
    assert (tmp_path / "last.png").is_file()


@pytest.mark.parametrize(
    "function, settings, command, inputs",
    [
        (seedtrack.api.detect, DetectSettings, "detect", ["clip.mp4", "--out", "d.csv"]),
        (seedtrack.api.link, LinkSettings, "track", ["points.csv", "--out", "t.csv"]),
        (seedtrack.api.evaluate, EvaluateSettings, "evaluate", ["tracks.csv", "truth.csv"]),
        (seedtrack.api.render, RenderSettings, "render", ["clip.mp4", "tracks.csv", "--out", "o.mp4"]),
    ],
)
def test_signatures_name_the_commands_options_with_their_defaults(function, settings, command, inputs):
    keywords = {p.name: p.default for p in inspect.signature(function).parameters.values() if p.kind is p.KEYWORD_ONLY}
    defaults = {f.name: getattr(settings(), f.name) for f in dataclasses.fields(settings) if f.init}
    assert {name: keywords[name] for name in defaults} == defaults
    assert all(name in (function.__doc__ or "") for name in keywords)
    # The command's defaults are the same settings.
    assert settings_of(settings, build_parser(command).parse_args([command, *inputs])) == settings()


def test_evaluate_takes_trackpy_tables_and_warns_of_frames_numbered_from_one():
    truth = pd.DataFrame({"particle": [5, 5, 5, 6, 6, 6], "frame": [0, 1, 2, 0, 1, 2], "x": [0.0, 4, 8, 0, 4, 8], "y": [0.0, 0, 0, 20, 20, 20]})
    assert seedtrack.evaluate(truth, truth).correct_tracks == 2
    with pytest.warns(UserWarning, match="shifted by"):
        seedtrack.evaluate(truth, truth.assign(frame=truth.frame + 1))


def test_import_seedtrack_loads_nothing_until_used():
    code = "import sys, seedtrack; print(sorted(m for m in ('numpy', 'pandas', 'seedtrack.api') if m in sys.modules)); print(seedtrack.link.__module__)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["[]", "seedtrack.api"]
    assert {"detect", "link", "evaluate", "render", "Scores", "tracking"} <= set(dir(seedtrack))
    assert seedtrack.tracking.goa.GOAConfig is seedtrack.GOAConfig
    with pytest.raises(AttributeError):
        seedtrack.tracking.no_such_module


@pytest.mark.parametrize("module", ["seedtrack.api", "seedtrack.settings", "seedtrack.wording", "seedtrack.errors", "seedtrack.pipeline", "seedtrack.points", "seedtrack.tracking.linking", "seedtrack.tracking.evaluation", "seedtrack.detection.clip"])
def test_docstring_examples_run(module):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        result = doctest.testmod(importlib.import_module(module), optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0
    assert result.failed == 0


def test_the_readme_example_runs_as_written(tmp_path, monkeypatch, capsys):
    readme = (Path(__file__).parents[1] / "README.md").read_text(encoding="utf-8")
    example = readme.split("## Use from Python", 1)[1].split("```python\n", 1)[1].split("```", 1)[0]
    monkeypatch.chdir(tmp_path)
    exec(compile(example, "README.md", "exec"), {})
    printed = capsys.readouterr().out.splitlines()
    assert printed[0].startswith("motion: ")
    assert printed[1] == "80 of 80 seeds tracked correctly"
    assert printed[2] == "wrote dish/overlay.mp4: 10 frames of 80 tracks, 640x480"


def test_version_is_the_declared_one():
    import tomllib
    from pathlib import Path

    import seedtrack

    pyproject = Path(__file__).resolve().parent.parent / "pyproject.toml"
    declared = tomllib.loads(pyproject.read_text())["project"]["version"]
    assert seedtrack.__version__ == declared
