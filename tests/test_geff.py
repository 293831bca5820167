"""GEFF (through the geff package) and napari's tracks array, written and read back."""

import numpy as np
import pandas as pd
import pytest
from geff import validate_structure
from geff.core_io import read_to_memory, write_arrays
from geff_spec import Axis, GeffMetadata

from seedtrack.cli import main
from seedtrack.data.calibration import Calibration
from seedtrack.data.errors import DataError
from seedtrack.data.trackfile import read_calibration, read_tracks, write_tracks
from seedtrack.tracking.tracks import Tracks


def _tracks():
    """Track 5 with a gap (frame 2) and an interpolated point, track 9 from frame 2."""
    return Tracks.from_rows([5, 5, 5, 9, 9, 9], [0, 1, 3, 2, 3, 4], [1.0, 2.0, 3.5, 40.0, 41.0, 42.25], [6.0, 7.0, 8.0, 9.0, 10.0, 11.0], [0, 0, 1, 0, 0, 0])


def test_geff_round_trip_through_the_geff_package(tmp_path):
    units = Calibration(0.5, "um", 0.1, "s")
    write_tracks(tmp_path / "tracks.geff", _tracks(), units=units)
    validate_structure(str(tmp_path / "tracks.geff"))
    memory = read_to_memory(str(tmp_path / "tracks.geff"))
    axes = memory["metadata"].axes
    assert [(a.name, a.type, a.unit, a.scale, a.scaled_unit) for a in axes] == [
        ("t", "time", "frame", 0.1, "second"),
        ("y", "space", "pixel", 0.5, "micrometer"),
        ("x", "space", "pixel", 0.5, "micrometer"),
    ]
    props = {name: prop["values"] for name, prop in memory["node_props"].items()}
    assert props["track_id"].tolist() == [5, 5, 5, 9, 9, 9] and props["t"].tolist() == [0, 1, 3, 2, 3, 4]
    assert memory["node_ids"].size == 6 and memory["edge_ids"].tolist() == [[0, 1], [1, 2], [3, 4], [4, 5]]
    back = read_tracks(tmp_path / "tracks.geff")
    for name, values in _tracks().to_rows().items():
        np.testing.assert_array_equal(back.to_rows()[name], values, err_msg=name)
    assert read_calibration(tmp_path / "tracks.geff") == Calibration(0.5, "micrometer", 0.1, "second")
    # The same tracks make the same bytes, file for file.
    write_tracks(tmp_path / "again.geff", _tracks(), units=units)
    files = sorted(p.relative_to(tmp_path / "tracks.geff") for p in (tmp_path / "tracks.geff").rglob("*") if p.is_file())
    assert files == sorted(p.relative_to(tmp_path / "again.geff") for p in (tmp_path / "again.geff").rglob("*") if p.is_file())
    assert all((tmp_path / "tracks.geff" / f).read_bytes() == (tmp_path / "again.geff" / f).read_bytes() for f in files)


def test_geff_without_tracklets_is_read_as_the_graphs_unbranched_runs(tmp_path):
    # A cell at node 1 divides into 2 and 4; node 6 is on no edge.
    node_ids = np.array([0, 1, 2, 3, 4, 5, 6], dtype=np.uint64)
    edges = np.array([[0, 1], [1, 2], [2, 3], [1, 4], [4, 5]], dtype=np.uint64)
    t = np.array([0, 1, 2, 3, 2, 3, 0])
    axes = [Axis(name="t", type="time"), Axis(name="y", type="space"), Axis(name="x", type="space")]
    props = {"t": t, "y": np.arange(7.0), "x": 10 + np.arange(7.0)}
    write_arrays(str(tmp_path / "cells.geff"), node_ids, {k: {"values": v, "missing": None} for k, v in props.items()}, edges, None, GeffMetadata(directed=True, axes=axes, node_props_metadata={}, edge_props_metadata={}))
    rows = read_tracks(tmp_path / "cells.geff").to_rows()
    tracks = sorted(tuple(rows["x"][rows["track_id"] == i].astype(int)) for i in np.unique(rows["track_id"]))
    assert tracks == [(10, 11), (12, 13), (14, 15), (16,)]


def test_geff_through_the_commands_and_refused_over_an_existing_one(tmp_path, capsys):
    truth = _tracks()
    write_tracks(tmp_path / "truth.csv", truth)
    rows = truth.to_rows()
    pd.DataFrame({"frame": rows["frame"], "x": rows["x"], "y": rows["y"]}).to_csv(tmp_path / "points.csv", index=False)
    assert main(["track", str(tmp_path / "points.csv"), "--out", str(tmp_path / "t.geff")]) == 0
    assert main(["evaluate", str(tmp_path / "t.geff"), "--truth", str(tmp_path / "truth.csv")]) == 0
    table = dict(line.split(maxsplit=1) for line in capsys.readouterr().out.splitlines() if " " in line)
    assert table["true_points"] == "6"
    (tmp_path / "edits.txt").write_text("")
    assert main(["correct", str(tmp_path / "t.geff"), str(tmp_path / "edits.txt"), "--out", str(tmp_path / "c.geff")]) == 0
    assert read_tracks(tmp_path / "c.geff").n_tracks == read_tracks(tmp_path / "t.geff").n_tracks
    with pytest.raises(DataError, match="exists; a GEFF is a folder and is not replaced"):
        write_tracks(tmp_path / "c.geff", truth)
    with pytest.raises(DataError, match="no such GEFF folder"):
        read_tracks(tmp_path / "none.geff")


def test_napari_tracks_array_is_id_t_y_x(tmp_path):
    write_tracks(tmp_path / "tracks.npy", _tracks())
    data = np.load(tmp_path / "tracks.npy")
    assert data.shape == (6, 4)
    np.testing.assert_array_equal(data[0], [5, 0, 6.0, 1.0])
    back = read_tracks(tmp_path / "tracks.npy")
    np.testing.assert_array_equal(back.point_xy, _tracks().point_xy)
    np.save(tmp_path / "bad.npy", np.zeros((3, 3)))
    with pytest.raises(DataError, match=r"bad\.npy: napari tracks are an \(N, 4\) array"):
        read_tracks(tmp_path / "bad.npy")
