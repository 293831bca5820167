"""Point and track tables as other tools' users save them."""

import pandas as pd

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
