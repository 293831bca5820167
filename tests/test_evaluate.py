"""``seedtrack evaluate`` and ``seedtrack review`` on small constructed and generated inputs."""

import json
import subprocess
import sys

import cv2
import numpy as np
import pytest

from seedtrack.cli import main
from seedtrack.data.dish import DishSpec, write_dish_clip
from seedtrack.data.trackfile import read_tracks, write_tracks
from seedtrack.tracking.diagnosis import first_errors
from seedtrack.tracking.tracks import Tracks


def seedtrack(*args):
    return subprocess.run([sys.executable, "-m", "seedtrack", *map(str, args)], capture_output=True, text=True)


def _lines(n_frames=6):
    """Three true tracks moving right on separate rows y = 0, 100, 200."""
    frame = np.arange(n_frames, dtype=float)
    xy = np.stack([np.stack([10 * frame, np.full(n_frames, 100.0 * row)], axis=1) for row in range(3)])
    return Tracks.from_dense(xy=xy, measurement=np.zeros(xy.shape[:2], dtype=np.int64), track_ids=np.array([10, 20, 30]))


def _swapped():
    """Result: tracks 1 and 2 exchange rows from frame 3; track 3 is lost after frame 3."""
    truth = _lines()
    xy = truth.xy.copy()
    xy[[0, 1], 3:] = xy[[1, 0], 3:]
    xy[2, 4:] = np.nan
    return Tracks.from_dense(xy=xy, measurement=np.zeros(xy.shape[:2], dtype=np.int64), track_ids=np.array([1, 2, 3]))


def test_first_errors_say_where_and_to_what():
    wrong = first_errors(_swapped(), _lines(), 1.0)
    assert list(wrong["truth_track"]) == [10, 20, 30]
    assert list(wrong["frame"]) == [3, 3, 4]
    assert list(wrong["result_track"]) == [1, 2, 3]
    assert list(wrong["taken_over_by"]) == [2, 1, -1]
    assert list(wrong["jumped_to_truth"]) == [20, 10, -1]
    assert wrong["what"][2] == "its result track ends"


def test_evaluate_writes_json_csv_and_plot_repeatably(tmp_path):
    write_tracks(tmp_path / "result.txt", _swapped())  # MOTChallenge result against our CSV truth
    write_tracks(tmp_path / "truth.csv", _lines())
    for name in ("a", "b"):
        assert main(["evaluate", str(tmp_path / "result.txt"), "--truth", str(tmp_path / "truth.csv"), "--tol", "1", "--out", str(tmp_path / name)]) == 0
    for file in ("evaluation.json", "wrong_tracks.csv", "errors.png"):
        assert (tmp_path / "a" / file).read_bytes() == (tmp_path / "b" / file).read_bytes()
    report = json.loads((tmp_path / "a" / "evaluation.json").read_text())
    assert report["true_tracks"] == 3 and report["correct_tracks"] == 0
    assert report["id_switches"] == 2 and report["misses"] == 2 and report["false_positives"] == 0
    assert report["mota"] == pytest.approx(1 - 4 / 18)
    assert report["link_error"] == pytest.approx(4 / 15)  # 2 at the swap, 2 after track 3 ends
    assert report["relaxed_merit"] == 0.0
    image = cv2.imread(str(tmp_path / "a" / "errors.png"))
    assert image.shape == (420, 960, 3) and (image < 200).any()


def test_evaluate_prints_a_table_without_out(tmp_path, capsys):
    write_tracks(tmp_path / "truth.csv", _lines())
    assert main(["evaluate", str(tmp_path / "truth.csv"), "--truth", str(tmp_path / "truth.csv")]) == 0
    table = capsys.readouterr().out
    assert "mota             1.000000" in table and "track_error      0.000000" in table


@pytest.mark.parametrize(
    "name, text, message",
    [
        ("truth.xml", '<root><TrackContestISBI2012>\n<particle>\n<detection t="0" x="1" y="1" z="0">\n</root>', "truth.xml: line 4, column 3: malformed XML"),
        ("truth.csv", "track_id,frame,x,y\n10,0,0,0\n10,0,1,1\n", "truth.csv: line 3: track 10 has a second point in frame 0"),
    ],
)
def test_evaluate_bad_truth_is_one_line_exit_2_nothing_written(tmp_path, name, text, message):
    write_tracks(tmp_path / "result.csv", _lines())
    (tmp_path / name).write_text(text)
    result = seedtrack("evaluate", tmp_path / "result.csv", "--truth", tmp_path / name, "--out", tmp_path / "out")
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1 and "Traceback" not in result.stderr
    assert message in result.stderr
    assert not (tmp_path / "out").exists()


def test_review_pages_show_every_track(tmp_path):
    clip = tmp_path / "clip"
    write_dish_clip(DishSpec(seeds=8, frames=7, width=200, height=160, rim_speed=8.0, random_seed=1), clip)
    assert main(["review", str(clip / "clip.mp4"), str(clip / "truth.csv"), "--out", str(tmp_path / "pages"), "--every", "3"]) == 0
    pages = sorted(p.name for p in (tmp_path / "pages").glob("*.png"))
    assert pages == ["review_000000.png", "review_000003.png", "review_000006.png"]
    page = cv2.imread(str(tmp_path / "pages" / pages[0]))
    assert page.shape == (160 * 4, 200 * 4, 3)  # small frames are enlarged for legibility
    # The clip is grey, so colour is drawing: each seed has its id in colour up and to the right.
    coloured = np.ptp(page.astype(int), axis=2) > 60
    truth = read_tracks(clip / "truth.csv")
    for x, y in np.round(truth.xy[:, 0] * 4 + 1.5).astype(int):
        assert coloured[y - 30 : y, x + 5 : x + 40].sum() > 20


def test_evaluate_an_empty_result(tmp_path):
    write_tracks(tmp_path / "truth.csv", _lines())
    (tmp_path / "empty.csv").write_text("track_id,frame,x,y\n")
    assert main(["evaluate", str(tmp_path / "empty.csv"), "--truth", str(tmp_path / "truth.csv"), "--out", str(tmp_path / "out")]) == 0
    report = json.loads((tmp_path / "out" / "evaluation.json").read_text())
    assert (report["track_error"], report["mota"], report["idf1"], report["misses"], report["motp_px"]) == (1.0, 0.0, 0.0, 18, None)
    assert len((tmp_path / "out" / "wrong_tracks.csv").read_text().splitlines()) == 4


def test_truth_follows_tracks_as_compare_takes_its_inputs_and_the_option_still_works(tmp_path, capsys):
    write_tracks(tmp_path / "result.csv", _swapped())
    write_tracks(tmp_path / "truth.csv", _lines())
    printed = []
    for form in (["truth.csv"], ["--truth", "truth.csv"]):
        assert main(["evaluate", str(tmp_path / "result.csv"), *(str(tmp_path / w) if w.endswith(".csv") else w for w in form)]) == 0
        printed.append(capsys.readouterr().out)
    assert printed[0] == printed[1] and "correct_tracks   0" in printed[0]
    for form in ([], [str(tmp_path / "truth.csv"), "--truth", str(tmp_path / "truth.csv")]):
        assert main(["evaluate", str(tmp_path / "result.csv"), *form]) == 2
        assert "error: give TRUTH once: after TRACKS (or as --truth TRUTH)" in capsys.readouterr().err
