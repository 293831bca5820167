"""Point and track tables as other tools' users save them."""

import os

import pandas as pd
import pytest

from seedtrack.cli import main
from seedtrack.data.csvio import read_table


def test_the_row_index_pandas_writes_first_is_no_column(tmp_path):
    # trackpy.locate's table saved with pandas' default to_csv: an unnamed index column first.
    points = pd.DataFrame({"y": [10.0, 10.5, 30.0, 30.5], "x": [5.0, 7.0, 50.0, 52.0], "mass": [9.0, 9.5, 8.0, 8.5], "frame": [0, 1, 0, 1]})
    points.to_csv(tmp_path / "points.csv")
    assert list(read_table(tmp_path / "points.csv")) == ["y", "x", "mass", "frame"]
    assert main(["track", str(tmp_path / "points.csv"), "--out", str(tmp_path / "tracks.csv")]) == 0
    tracks = pd.read_csv(tmp_path / "tracks.csv")
    assert list(tracks.columns) == ["track_id", "frame", "x", "y", "interpolated", "mass"]
    assert sorted(tracks.groupby("track_id").x.apply(tuple)) == [(5.0, 7.0), (50.0, 52.0)]


def test_an_output_inside_a_file_names_the_file(tmp_path, capsys):
    (tmp_path / "points.csv").write_text("frame,x,y\n0,1,2\n1,2,2\n")
    (tmp_path / "notes").write_text("a file, not a folder")
    assert main(["track", str(tmp_path / "points.csv"), "--out", str(tmp_path / "notes" / "tracks.csv")]) == 2
    assert capsys.readouterr().err.splitlines() == [f"seedtrack track: error: {tmp_path / 'notes' / 'tracks.csv'}: {tmp_path / 'notes'} is not a folder"]


_TRACKMATE_KEYS = "LABEL,ID,TRACK_ID,QUALITY,POSITION_X,POSITION_Y,POSITION_Z,POSITION_T,FRAME,RADIUS"
# TrackMate 7's CSV export of the spots table: under the keys, the names, short names and units.
_TRACKMATE_LABELS = (
    "Label,Spot ID,Track ID,Quality,X,Y,Z,T,Frame,Radius\n"
    "Label,Spot ID,Track ID,Quality,X,Y,Z,T,Frame,R\n"
    ",,,(quality),({unit}),({unit}),({unit}),(frame),,({unit})\n"
)
_TRACKMATE_SPOTS = "ID0,0,0,9.5,5.0,10.0,0.0,0.0,0,2.0\nID1,1,0,9.1,7.0,10.5,0.0,1.0,1,2.0\nID2,2,1,8.7,50.0,30.0,0.0,0.0,0,2.0\nID3,3,1,8.2,52.0,30.5,0.0,1.0,1,2.0\n"


@pytest.mark.parametrize("labels", [True, False], ids=["export with units", "keys only"])
def test_a_trackmate_spot_table_is_points(tmp_path, labels):
    spots = tmp_path / "spots.csv"
    spots.write_text(_TRACKMATE_KEYS + "\n" + (_TRACKMATE_LABELS.format(unit="pixel") if labels else "") + _TRACKMATE_SPOTS)
    assert main(["track", str(spots), "--out", str(tmp_path / "tracks.csv")]) == 0
    tracks = pd.read_csv(tmp_path / "tracks.csv")
    assert list(tracks.columns[:5]) == ["track_id", "frame", "x", "y", "interpolated"]
    assert "POSITION_X" not in tracks.columns and "LABEL" in tracks.columns
    assert sorted(tracks.groupby("track_id").LABEL.apply(tuple)) == [("ID0", "ID1"), ("ID2", "ID3")]


def test_a_trackmate_table_in_microns_or_with_a_bad_value_is_one_line_naming_its_line(tmp_path, capsys):
    spots = tmp_path / "spots.csv"
    spots.write_text(_TRACKMATE_KEYS + "\n" + _TRACKMATE_LABELS.format(unit="micron") + _TRACKMATE_SPOTS)
    assert main(["track", str(spots), "--out", str(tmp_path / "tracks.csv")]) == 2
    assert capsys.readouterr().err.startswith(f"seedtrack track: error: {spots}: line 4: TrackMate's positions are in micron, not pixels")
    spots.write_text(_TRACKMATE_KEYS + "\n" + _TRACKMATE_LABELS.format(unit="pixel") + _TRACKMATE_SPOTS.replace("7.0,10.5", "abc,10.5"))
    assert main(["track", str(spots), "--out", str(tmp_path / "tracks.csv")]) == 2
    assert capsys.readouterr().err == f"seedtrack track: error: {spots}: line 6: column POSITION_X holds 'abc', not a number\n"
    assert not (tmp_path / "tracks.csv").exists()


def test_a_table_separated_by_semicolons_says_so(tmp_path, capsys):
    (tmp_path / "points.csv").write_text("frame;x;y\n0;1,5;2\n1;2,5;2\n")
    assert main(["track", str(tmp_path / "points.csv"), "--out", str(tmp_path / "tracks.csv")]) == 2
    assert capsys.readouterr().err.endswith("found frame, x, y; its fields are separated by semicolons: save it with commas\n")


def test_a_table_separated_by_tabs_says_so(tmp_path, capsys):
    (tmp_path / "points.tsv").write_text("frame\tx\ty\n0\t1.5\t2\n1\t2.5\t2\n")
    assert main(["track", str(tmp_path / "points.tsv"), "--out", str(tmp_path / "tracks.csv")]) == 2
    assert capsys.readouterr().err.endswith("found frame, x, y; its fields are separated by tabs: save it with commas\n")


def test_a_pipe_given_for_a_file_is_named_as_one(tmp_path, capsys):
    # bash's <(command) passes a pipe; "no such file" sent the user looking for a missing file.
    os.mkfifo(tmp_path / "truth.csv")
    (tmp_path / "tracks.csv").write_text("track_id,frame,x,y\n0,0,1,1\n0,1,2,2\n")
    assert main(["evaluate", str(tmp_path / "tracks.csv"), "--truth", str(tmp_path / "truth.csv")]) == 2
    assert capsys.readouterr().err == f"seedtrack evaluate: error: {tmp_path / 'truth.csv'}: not a regular file (a pipe or a device); save it to a file first\n"
