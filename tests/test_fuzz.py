"""Fuzzing every command: generated points files, track files and option values, in process.

Each run must end in a valid result (exit 0, outputs that read back) or in the one-line error
with exit status 2 (argparse's own usage errors included); never a traceback, never another
status, and never a half-written file: an output named in the error does not exist, and no
temporary file is left behind. Most generated inputs are nearly valid, so that the trackers,
the readers' checks and the writers all run; the rest are corrupted in one way each.

In CI the examples are derandomised (tests/conftest.py); ``SEEDTRACK_FUZZ_EXAMPLES=N`` shares N
examples among the tests by their weight, for the longer run of tests/benchmarks/fuzz_long.py.
"""

from __future__ import annotations

import contextlib
import io
import os
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from seedtrack.cli import main
from seedtrack.data.dish import DishSpec, write_dish_clip
from seedtrack.data.trackfile import read_tracks

# Examples per test in CI, which also weigh the tests' shares of a longer run.
WEIGHTS = {
    "track": 50,
    "evaluate": 30,
    "correct": 25,
    "synth": 12,
    "render": 10,
    "compare": 6,
    "review": 6,
    "detect": 6,
    "run": 2,
    "demo": 2,
    "experiment": 1,
}
_TOTAL = int(os.environ.get("SEEDTRACK_FUZZ_EXAMPLES", "0"))


def fuzz(command: str):
    examples = max(1, _TOTAL * WEIGHTS[command] // sum(WEIGHTS.values())) if _TOTAL else WEIGHTS[command]
    return settings(
        max_examples=examples,
        deadline=None,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.filter_too_much],
    )


WIDTH, HEIGHT, FRAMES = 160, 120, 6


@pytest.fixture(scope="module")
def clip(tmp_path_factory):
    folder = tmp_path_factory.mktemp("fuzzclip")
    write_dish_clip(DishSpec(seeds=6, frames=FRAMES, width=WIDTH, height=HEIGHT, rim_speed=4.0, random_seed=1), folder)
    return folder / "clip.mp4"


def outcome(args: list, outputs: list[Path], folder: Path) -> int:
    """Run ``seedtrack ARGS``; check the outcome is a result or the one-line error; returns the status."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            status = main([str(a) for a in args])
        except SystemExit as stop:  # argparse: --help, or an option of the wrong type
            status = stop.code
    errors = [line for line in err.getvalue().splitlines() if ": error:" in line]
    assert "Traceback" not in err.getvalue()
    left = [p for p in folder.rglob(".*")]
    assert not left, f"temporary files left: {left}"
    if status == 0:
        assert not errors
        return 0
    assert status == 2, (status, err.getvalue())
    assert len(errors) == 1 and err.getvalue().rstrip("\n").splitlines()[-1] == errors[0], err.getvalue()
    for path in outputs:
        if path.name in errors[0]:
            assert not path.exists(), f"{path} was written despite {errors[0]}"
    return 2


# --- values: mostly sensible, sometimes not ------------------------------------------------------

ODD_NUMBERS = st.sampled_from(["", "abc", "nan", "inf", "-inf", "1e300", "-1e155", "1e-320", " 3 ", "-0", "0x10", "1,5", "2.5e6"])
POSITIONS = st.one_of(st.floats(-5, WIDTH + 5, allow_nan=False).map(lambda v: f"{v:.3f}"), ODD_NUMBERS)
# Frames far apart but within range cost memory in proportion to their span; a few such spans are drawn.
FRAME_NUMBERS = st.one_of(st.integers(0, FRAMES - 1).map(str), st.sampled_from(["-1", "-3", "999", "100000", "1000001", "100000000"]), ODD_NUMBERS)


@st.composite
def points_text(draw) -> str:
    """A points file: frame,x,y[,area] rows, mostly of moving points, some corruption."""
    n_points, n_frames = draw(st.integers(0, 6)), draw(st.integers(1, FRAMES))
    start = draw(st.lists(st.tuples(st.floats(5, WIDTH - 5), st.floats(5, HEIGHT - 5)), min_size=n_points, max_size=n_points))
    velocity = draw(st.lists(st.tuples(st.floats(-4, 4), st.floats(-4, 4)), min_size=n_points, max_size=n_points))
    rows = [[str(k), f"{x + k * vx:.3f}", f"{y + k * vy:.3f}", "5"] for k in range(n_frames) for (x, y), (vx, vy) in zip(start, velocity)]
    rows = draw(st.permutations(rows)) if rows else rows
    header = ["frame", "x", "y", "area"]
    corruption = draw(st.sampled_from(["none"] * 6 + ["value", "header", "fields", "duplicate", "blank", "bytes", "empty"]))
    if corruption == "value" and rows:
        row, column = draw(st.integers(0, len(rows) - 1)), draw(st.integers(0, 3))
        rows[row][column] = draw(FRAME_NUMBERS if column == 0 else POSITIONS)
    elif corruption == "header":
        header = draw(st.sampled_from([["x", "y", "frame", "area"], ["frame", "x", "x", "area"], ["frame", "x", "z", "area"], ["frame", " x", "y ", "area"], ["", "x", "y", "area"]]))
    elif corruption == "fields" and rows:
        row = draw(st.integers(0, len(rows) - 1))
        rows[row] = rows[row][: draw(st.integers(0, 3))] if draw(st.booleans()) else rows[row] + ["7"]
    elif corruption == "duplicate" and rows:
        rows.append(list(rows[draw(st.integers(0, len(rows) - 1))]))
    elif corruption == "blank":
        rows.insert(draw(st.integers(0, len(rows))), [""])
    text = ",".join(header) + "\n" + "".join(",".join(row) + "\n" for row in rows)
    if corruption == "bytes":
        return text + "\udce9"  # written with surrogateescape: a lone 0xE9 byte, not UTF-8
    if corruption == "empty":
        return draw(st.sampled_from(["", "\n", "frame,x,y\n"]))
    return text


# Uniform choice, and shrinking towards False: a rare corruption stays rare.
RARELY = st.sampled_from([False] * 7 + [True])


@st.composite
def tracks_file(draw) -> tuple[str, str]:
    """(file name, text) of a track set in one of the formats, mostly valid."""
    n_tracks = draw(st.integers(0, 4))
    rows = []
    for track in range(n_tracks):
        first = draw(st.integers(0, FRAMES - 2))
        length = draw(st.integers(1, FRAMES - first))
        x, y = draw(st.floats(5, WIDTH - 5)), draw(st.floats(5, HEIGHT - 5))
        vx, vy = draw(st.floats(-3, 3)), draw(st.floats(-3, 3))
        rows.extend([track * 3, k, f"{x + (k - first) * vx:.3f}", f"{y + (k - first) * vy:.3f}"] for k in range(first, first + length))
    if rows and draw(RARELY):
        row, column = draw(st.integers(0, len(rows) - 1)), draw(st.integers(0, 3))
        rows[row][column] = draw(FRAME_NUMBERS if column < 2 else POSITIONS)
    if rows and draw(RARELY):
        rows.append(list(rows[0]))  # a second point of a track in one frame
    kind = draw(st.sampled_from(["csv", "csv", "trackpy", "mot", "trackmate", "isbi", "other"]))
    if kind == "csv":
        return "tracks.csv", "track_id,frame,x,y,interpolated\n" + "".join(f"{t},{f},{x},{y},0\n" for t, f, x, y in rows)
    if kind == "trackpy":
        return "tracks.csv", "frame,particle,x,y\n" + "".join(f"{f},{t},{x},{y}\n" for t, f, x, y in rows)
    if kind == "mot":
        return "tracks.txt", "".join(f"{_plus_one(f)},{t},{x},{y},0,0,1,-1,-1,-1\n" for t, f, x, y in rows)
    if kind == "trackmate":
        return "tracks.xml", _trackmate(rows)
    if kind == "isbi":
        return "tracks.xml", _isbi(rows)
    return draw(st.sampled_from(["tracks.dat", "tracks.csv", "tracks.xml", "tracks.txt"])), draw(st.sampled_from(["", "<a>", "<root/>", "1,2\n", "x\n"]))


def _plus_one(frame: str) -> str:
    try:
        return str(int(frame) + 1)
    except ValueError:
        return frame


def _trackmate(rows) -> str:
    spots = "".join(f'<Spot ID="{i}" FRAME="{f}" POSITION_X="{x}" POSITION_Y="{y}"/>' for i, (t, f, x, y) in enumerate(rows))
    tracks = {}
    for i, (t, f, x, y) in enumerate(rows):
        tracks.setdefault(t, []).append(i)
    edges = "".join(
        f'<Track TRACK_ID="{t}">' + "".join(f'<Edge SPOT_SOURCE_ID="{a}" SPOT_TARGET_ID="{b}"/>' for a, b in zip(ids[:-1], ids[1:])) + "</Track>"
        for t, ids in tracks.items()
    )
    return f'<?xml version="1.0"?><TrackMate><Model><AllSpots><SpotsInFrame>{spots}</SpotsInFrame></AllSpots><AllTracks>{edges}</AllTracks></Model></TrackMate>\n'


def _isbi(rows) -> str:
    particles = {}
    for t, f, x, y in rows:
        particles.setdefault(t, []).append(f'<detection t="{f}" x="{x}" y="{y}" z="0"/>')
    body = "".join(f"<particle>{''.join(d)}</particle>" for d in particles.values())
    return f'<?xml version="1.0"?><root><TrackContestISBI2012>{body}</TrackContestISBI2012></root>\n'


def write(folder: Path, name: str, text: str) -> Path:
    path = folder / name
    path.write_bytes(text.encode("utf-8", "surrogateescape"))
    return path


FLOATS = st.one_of(st.floats(-2, 50, allow_nan=False).map(lambda v: f"{v:.3g}"), ODD_NUMBERS)
INTS = st.one_of(st.integers(-2, 12).map(str), st.sampled_from(["x", "1.5", "99999999999"]))


def options(table: dict) -> st.SearchStrategy[list[str]]:
    """Some of the options of ``table`` (name -> strategy of its value, or None for a flag)."""

    @st.composite
    def chosen(draw):
        args = []
        for name in draw(st.lists(st.sampled_from(sorted(table)), unique=True, max_size=4)):
            value = table[name]
            args += [name] if value is None else [name, draw(value)]
        return args

    return chosen()


TRACKER_OPTIONS = {
    "--max-speed": FLOATS,
    "--phi-max": st.one_of(st.floats(0, 1.5).map(lambda v: f"{v:.3g}"), ODD_NUMBERS),
    "--max-gap": INTS,
    "--min-length": INTS,
    "--motion": st.sampled_from(["auto", "smooth", "random", "fast"]),
    "--fixed-count": None,
}
TRACK_OPTIONS = {
    **TRACKER_OPTIONS,
    "--algorithm": st.sampled_from(["goa", "goa-updown", "goa-updown-fixed", "nn", "ss", "rs", "ipan", "knn"]),
    "--min-speed": FLOATS,
    "--individual-model": st.sampled_from(["im1", "im2", "im3"]),
    "--combined-model": st.sampled_from(["cm1", "cm2"]),
    "--first-links": st.sampled_from(["lookahead", "nearest", "paper"]),
}
VIEW_OPTIONS = {
    "--start": INTS,
    "--end": INTS,
    "--step": INTS,
    "--trail": INTS,
    "--scale": st.one_of(st.floats(0.05, 3).map(lambda v: f"{v:.3g}"), ODD_NUMBERS),
    "--fps": FLOATS,
    "--crop": st.sampled_from(["0,0,80,60", "10,10,5,5", "0,0,1000,1000", "a,b,c,d", "-5,0,40,40"]),
    "--no-labels": None,
}
DETECT_OPTIONS = {
    "--threshold": st.sampled_from(["otsu", "adaptive", "10", "0", "-5", "nan", "x"]),
    "--min-area": FLOATS,
    "--max-area": FLOATS,
    "--roi": st.sampled_from(["auto", "none", "80,60,40", "5000,5000,3", "1,2", "80,60,-1", "mask.png", "nan,1,2"]),
    "--background": st.sampled_from(["local", "none", "temporal"]),
    "--background-size": FLOATS,
    "--polarity": st.sampled_from(["auto", "dark", "light"]),
    "--detector": st.sampled_from(["blob", "log"]),
    "--start": INTS,
    "--end": INTS,
    "--step": INTS,
    "--no-split": None,
}


# --- the commands ---------------------------------------------------------------------------------


@fuzz("track")
@given(text=points_text(), extra=options(TRACK_OPTIONS), out=st.sampled_from(["t.csv", "t.txt", "t.xml", "t.dat", "sub/t.csv", "t.csv/"]))
def test_track(text, extra, out):
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        points = write(folder, "points.csv", text)
        target = folder / out
        if outcome(["track", points, "--out", str(target) + ("/" if out.endswith("/") else ""), *extra], [target], folder) == 0:
            read_tracks(target)


@fuzz("evaluate")
@given(result=tracks_file(), truth=tracks_file(), tol=FLOATS, out=st.booleans())
def test_evaluate(result, truth, tol, out):
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        (folder / "a").mkdir(), (folder / "b").mkdir()
        a, b = write(folder / "a", *result), write(folder / "b", *truth)
        extra = ["--out", folder / "ev"] if out else []
        if outcome(["evaluate", a, "--truth", b, "--tol", tol, *extra], [folder / "ev" / "evaluation.json"], folder) == 0 and out:
            assert {p.name for p in (folder / "ev").iterdir()} == {"evaluation.json", "wrong_tracks.csv", "errors.png", "manifest.json"}


EDIT = st.one_of(
    st.tuples(st.sampled_from(["join", "swap"]), st.integers(-1, 10), st.integers(-1, 10), st.integers(-1, 8)).map(lambda t: " ".join(map(str, t))),
    st.tuples(st.just("split"), st.integers(-1, 10), st.integers(-1, 8)).map(lambda t: " ".join(map(str, t))),
    st.tuples(st.just("delete"), st.integers(-1, 10)).map(lambda t: " ".join(map(str, t))),
    st.tuples(st.sampled_from(["move", "add"]), st.integers(-1, 10), st.integers(-1, 8), POSITIONS, POSITIONS).map(lambda t: " ".join(map(str, t))),
    st.sampled_from(["# note", "", "jump 1 2", "move 1", "delete x"]),
)


@fuzz("correct")
@given(tracks=tracks_file(), edits=st.lists(EDIT, max_size=5), out=st.sampled_from(["c.csv", "c.txt", "c.xml", "c.png"]))
def test_correct(tracks, edits, out):
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        source = write(folder, *tracks)
        edits_file = write(folder, "edits.txt", "\n".join(edits) + "\n")
        if outcome(["correct", source, edits_file, "--out", folder / out], [folder / out], folder) == 0:
            read_tracks(folder / out)


SYNTH_OPTIONS = {
    "--tracks": INTS,
    "--frames": INTS,
    "--size": st.one_of(st.sampled_from(["50", "200", "1e7"]), ODD_NUMBERS),
    "--mean-speed": FLOATS,
    "--speed-sigma": FLOATS,
    "--angle-step-sigma": FLOATS,
    "--occlusion": st.sampled_from(["0", "0.2", "1", "-0.1", "nan"]),
    "--max-speed": FLOATS,
    "--max-gap": INTS,
    "--entry-exit": None,
    "--seed": INTS,
}


@fuzz("synth")
@given(extra=options(SYNTH_OPTIONS))
def test_synth(extra):
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        out = folder / "syn"
        if outcome(["synth", "psmg", "--out", out, *extra], [out / "points.csv", out / "truth.csv"], folder) == 0:
            read_tracks(out / "truth.csv")
        else:
            assert not out.exists() or sorted(p.name for p in out.iterdir()) in ([], ["points.csv"])


@fuzz("render")
@given(tracks=tracks_file(), extra=options({**VIEW_OPTIONS, "--frame": INTS}), kind=st.sampled_from(["r.png", "r.gif", "r.mp4", "frames", "r.jpg"]), detections=st.one_of(st.none(), points_text()))
def test_render(clip, tracks, extra, kind, detections):
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        source = write(folder, *tracks)
        more = ["--detections", write(folder, "detections.csv", detections)] if detections is not None else []
        outcome(["render", clip, source, "--out", folder / kind, *extra, *more], [folder / kind], folder)


@fuzz("compare")
@given(a=tracks_file(), b=tracks_file(), extra=options({**VIEW_OPTIONS, "--tol": FLOATS, "--overlay": None}))
def test_compare(clip, a, b, extra):
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        (folder / "a").mkdir(), (folder / "b").mkdir()
        outcome(["compare", clip, write(folder / "a", *a), write(folder / "b", *b), "--out", folder / "c.gif", *extra], [folder / "c.gif"], folder)


@fuzz("review")
@given(tracks=tracks_file(), every=INTS)
def test_review(clip, tracks, every):
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        if outcome(["review", clip, write(folder, *tracks), "--out", folder / "pages", "--every", every], [], folder) == 2:
            assert not (folder / "pages").exists() or any((folder / "pages").iterdir())


@fuzz("detect")
@given(extra=options(DETECT_OPTIONS), out=st.sampled_from(["d.csv", "d.txt", "sub/d.csv"]))
def test_detect(clip, extra, out):
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        if outcome(["detect", clip, "--out", folder / out, *extra], [folder / out], folder) == 0:
            assert (folder / out).read_text().startswith("frame,x,y,area")


@fuzz("run")
@given(extra=options({**DETECT_OPTIONS, **TRACKER_OPTIONS}))
def test_run(clip, extra):
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        if outcome(["run", clip, "--out", folder / "out", *extra], [], folder) == 0:
            assert {p.name for p in (folder / "out").iterdir()} == {"detections.csv", "tracks.csv", "overlay.mp4", "manifest.json"}


@fuzz("demo")
@given(extra=options({"--seeds": INTS, "--frames": INTS, "--rim-speed": FLOATS, "--hidden-probability": FLOATS, "--tol": FLOATS, "--random-seed": INTS}))
def test_demo(extra):
    # Small scenes: the default 80 seeds over 10 frames of 640 x 480 would take seconds each.
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        outcome(["demo", "--out", folder / "demo", "--seeds", "4", "--frames", "4", *extra], [], folder)


@fuzz("experiment")
@given(name=st.sampled_from(["occlusion", "velocity", "nothing"]), runs=st.sampled_from(["1", "0", "-1", "x"]), jobs=st.sampled_from(["1", "0"]))
def test_experiment(name, runs, jobs):
    with tempfile.TemporaryDirectory() as folder_name:
        folder = Path(folder_name)
        outcome(["experiment", name, "--tiny", "--out", folder / "exp", "--runs", runs, "--jobs", jobs], [], folder)
