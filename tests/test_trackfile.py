"""Track file formats: round trips, the conventions of each format, and one-line errors."""

import numpy as np
import pytest

from seedtrack.data.corrections import read_corrections
from seedtrack.data.errors import DataError, DataWarning
from seedtrack.data.trackfile import read_tracks, write_tracks
from seedtrack.tracking.tracks import Tracks


def _tracks(seed=0, n_tracks=12, n_frames=9, first_frame=2):
    rng = np.random.default_rng(seed)
    xy = np.round(rng.uniform(0, 500, (n_tracks, n_frames, 2)), 4)
    for row in range(n_tracks):  # different starts and ends, at least two points each
        begin = rng.integers(0, n_frames - 2)
        end = rng.integers(begin + 2, n_frames + 1)
        xy[row, :begin] = np.nan
        xy[row, end:] = np.nan
    measurement = np.zeros(xy.shape[:2], dtype=np.int64)
    ids = np.sort(rng.choice(1000, n_tracks, replace=False))
    return Tracks.from_dense(xy=xy, measurement=measurement, first_frame=first_frame, track_ids=ids)


def _same(a: Tracks, b: Tracks, ids=True):
    assert a.first_frame == b.first_frame
    np.testing.assert_array_equal(a.xy, b.xy)
    if ids:
        np.testing.assert_array_equal(a.track_ids, b.track_ids)


@pytest.mark.parametrize(
    "name, format",
    [("t.csv", None), ("t.csv", "trackpy"), ("t.txt", None), ("t.xml", None), ("t.xml", "isbi"), ("t.dat", "mot")],
)
def test_round_trip(tmp_path, name, format):
    tracks = _tracks()
    write_tracks(tmp_path / name, tracks, format=format)
    back = read_tracks(tmp_path / name, format=format if name.endswith(".dat") else None)
    # ISBI files carry no track ids: particles come back numbered in id order.
    _same(back, tracks, ids=format != "isbi")
    if format == "isbi":
        np.testing.assert_array_equal(back.track_ids, np.arange(tracks.n_tracks))


def test_our_csv_keeps_interpolated_points(tmp_path):
    tracks = _tracks()
    measurement = tracks.measurement.copy()
    measurement[0, 5] = -1
    marked = Tracks.from_dense(xy=tracks.xy, measurement=measurement, first_frame=tracks.first_frame, track_ids=tracks.track_ids)
    write_tracks(tmp_path / "t.csv", marked)
    np.testing.assert_array_equal(read_tracks(tmp_path / "t.csv").interpolated, marked.interpolated)


def test_write_maps_columns_to_clip_frames(tmp_path):
    tracks = _tracks(n_frames=3, first_frame=0)
    write_tracks(tmp_path / "t.txt", tracks, frame_indices=np.array([0, 10, 20]))
    frames = sorted({int(line.split(",")[0]) for line in (tmp_path / "t.txt").read_text().splitlines()})
    assert frames == [1, 11, 21]


def test_trackpy_table_with_extra_columns_is_recognised(tmp_path):
    (tmp_path / "tp.csv").write_text(",y,x,mass,frame,particle\n0,20.0,10.0,5,0,7\n1,21.0,11.5,5,1,7\n2,40.0,30.0,5,1,3\n")
    tracks = read_tracks(tmp_path / "tp.csv")
    assert list(tracks.track_ids) == [3, 7]
    np.testing.assert_array_equal(tracks.xy[1], [[10.0, 20.0], [11.5, 21.0]])


@pytest.mark.parametrize("header", ["track_id,frame,x,y", "particle,frame,x,y"])
def test_csv_saved_with_a_byte_order_mark_is_read(tmp_path, header):
    # Spreadsheet programs save "CSV UTF-8" with a byte order mark before the header.
    (tmp_path / "t.csv").write_text(header + "\n7,0,10.0,20.0\n7,1,11.5,21.0\n", encoding="utf-8-sig")
    tracks = read_tracks(tmp_path / "t.csv")
    assert list(tracks.track_ids) == [7]
    np.testing.assert_array_equal(tracks.xy[0], [[10.0, 20.0], [11.5, 21.0]])


def test_mot_frames_count_from_one_and_points_are_box_centres(tmp_path):
    (tmp_path / "gt.txt").write_text("1,4,10,20,6,8,1,-1,-1,-1\n2,4,12,20,6,8,1,-1,-1,-1\n2 5 100 50 0 0 0.5 -1 -1 -1\n")
    tracks = read_tracks(tmp_path / "gt.txt")
    assert tracks.first_frame == 0 and tracks.n_frames == 2
    np.testing.assert_array_equal(tracks.xy[0], [[13.0, 24.0], [15.0, 24.0]])
    np.testing.assert_array_equal(tracks.xy[1, 1], [100.0, 50.0])


TRACKMATE = """<?xml version="1.0" encoding="UTF-8"?>
<TrackMate version="7.11.1">
  <Model spatialunits="pixel" timeunits="frame">
    <AllSpots nspots="5">
      <SpotsInFrame frame="0">
        <Spot ID="100" name="ID100" FRAME="0" POSITION_X="1.5" POSITION_Y="2.5" POSITION_Z="0" />
        <Spot ID="200" name="ID200" FRAME="0" POSITION_X="50" POSITION_Y="60" POSITION_Z="0" />
        <Spot ID="300" name="ID300" FRAME="0" POSITION_X="90" POSITION_Y="90" POSITION_Z="0" />
      </SpotsInFrame>
      <SpotsInFrame frame="1">
        <Spot ID="101" name="ID101" FRAME="1" POSITION_X="3.5" POSITION_Y="4.5" POSITION_Z="0" />
        <Spot ID="201" name="ID201" FRAME="1" POSITION_X="52" POSITION_Y="61" POSITION_Z="0" />
      </SpotsInFrame>
    </AllSpots>
    <AllTracks>
      <Track name="Track_0" TRACK_ID="0"><Edge SPOT_SOURCE_ID="100" SPOT_TARGET_ID="101" /></Track>
      <Track name="Track_1" TRACK_ID="1"><Edge SPOT_SOURCE_ID="200" SPOT_TARGET_ID="201" /></Track>
    </AllTracks>
    <FilteredTracks><TrackID TRACK_ID="1" /></FilteredTracks>
  </Model>
</TrackMate>
"""


def test_trackmate_reads_filtered_tracks_from_edges(tmp_path):
    (tmp_path / "tm.xml").write_text(TRACKMATE)
    tracks = read_tracks(tmp_path / "tm.xml")
    assert list(tracks.track_ids) == [1]  # track 0 is filtered out; spot 300 is on no track
    np.testing.assert_array_equal(tracks.xy[0], [[50, 60], [52, 61]])


def test_isbi_particles_become_tracks(tmp_path):
    (tmp_path / "isbi.xml").write_text(
        '<root><TrackContestISBI2012 SNR="4" density="low" scenario="VESICLE">\n'
        '<particle><detection t="3" x="1" y="2" z="0"/><detection t="4" x="2" y="3" z="0"/></particle>\n'
        '<particle><detection t="4" x="9" y="9" z="0"/></particle>\n'
        "</TrackContestISBI2012></root>\n"
    )
    tracks = read_tracks(tmp_path / "isbi.xml")
    assert tracks.first_frame == 3 and list(tracks.track_ids) == [0, 1]
    np.testing.assert_array_equal(tracks.xy[1, 1], [9, 9])


@pytest.mark.parametrize(
    "name, text, message",
    [
        ("dup.csv", "track_id,frame,x,y\n1,0,1,1\n1,1,2,2\n1,1,3,3\n", "dup.csv: line 4: track 1 has a second point in frame 1 (first at line 3)"),
        ("dup.csv", "frame,particle,x,y\n0,5,1,1\n0,5,2,2\n", "dup.csv: line 3: track 5 has a second point in frame 0"),
        ("dup.txt", "1,1,0,0,0,0,1,-1,-1,-1\n\n1,1,5,5,0,0,1,-1,-1,-1\n", "dup.txt: line 3: track 1 has a second point in frame 0"),
        ("dup.xml", '<root><TrackContestISBI2012>\n<particle>\n<detection t="0" x="1" y="1" z="0"/>\n<detection t="0" x="2" y="2" z="0"/>\n</particle></TrackContestISBI2012></root>', "dup.xml: line 4: track 0 has a second point in frame 0"),
        ("bad.xml", '<root><TrackContestISBI2012>\n<particle>\n<detection t="0" x="1" y="1"\n</particle></TrackContestISBI2012></root>', "bad.xml: line 4, column 1: malformed XML"),
        ("bad.xml", TRACKMATE.replace('<Spot ID="201"', '<Spot ID="201" FRAME="0"'), "bad.xml: line 12, column"),
        ("t.xml", TRACKMATE.replace('POSITION_X="52"', 'POSITION_X="fifty"'), "t.xml: line 12: POSITION_X='fifty' is not a number"),
        ("um.xml", TRACKMATE.replace('spatialunits="pixel"', 'spatialunits="micron"'), "um.xml: line 3: TrackMate's positions are in micron, but the file gives no pixel size"),
        ("zero.txt", "0,1,0,0,0,0,1\n", "zero.txt: line 1: frame 0; MOTChallenge frames count from 1"),
        ("other.csv", "a,b\n1,2\n", "other.csv: line 1: a track CSV needs columns"),
        ("other.xml", "<svg></svg>", "other.xml: line 1: XML root <svg> is neither TrackMate"),
        ("t.json", "{}", "t.json: cannot tell the track format from the extension '.json'"),
    ],
)
def test_bad_files_raise_one_line_errors_naming_file_and_line(tmp_path, name, text, message):
    (tmp_path / name).write_text(text)
    with pytest.raises(DataError) as caught:
        read_tracks(tmp_path / name)
    assert message in str(caught.value)
    assert "\n" not in str(caught.value)


def test_trackmate_branching_track_is_read_as_its_branches(tmp_path):
    # Spot 201 of track 1 gets a second predecessor: two branches meet there.
    text = TRACKMATE.replace("<FilteredTracks><TrackID TRACK_ID=\"1\" /></FilteredTracks>", "").replace(
        '<Edge SPOT_SOURCE_ID="200" SPOT_TARGET_ID="201" />', '<Edge SPOT_SOURCE_ID="200" SPOT_TARGET_ID="201" /><Edge SPOT_SOURCE_ID="300" SPOT_TARGET_ID="201" />'
    )
    (tmp_path / "branch.xml").write_text(text)
    with pytest.warns(DataWarning, match="1 TrackMate track.s. split or merge"):
        tracks = read_tracks(tmp_path / "branch.xml")
    # Track 0 as it was; track 1 as three one-point branches in spot order: 200, 201 (frame 1), 300.
    assert list(tracks.track_ids) == [0, 1, 2, 3] and tracks.present.sum() == 5
    assert tracks.xy[1, 0].tolist() == [50, 60] and tracks.xy[2, 1].tolist() == [52, 61] and tracks.xy[3, 0].tolist() == [90, 90]


def test_unknown_format_name(tmp_path):
    with pytest.raises(DataError, match="unknown track format"):
        write_tracks(tmp_path / "t.csv", _tracks(), format="excel")


@pytest.mark.parametrize("name", ["tracks.csv", "tracks.txt"])
def test_a_file_in_another_encoding_is_a_one_line_error(tmp_path, name):
    # Excel's plain "CSV" is cp1252: the é of a label is byte 0xe9, not UTF-8.
    path = tmp_path / name
    path.write_bytes("track_id,frame,x,y,label\n0,0,1,1,café\n".encode("cp1252") if name.endswith(".csv") else b"1,1,\xe9,0,0,2,2\n")
    with pytest.raises(DataError, match="is not UTF-8 text"):
        read_tracks(path)


def test_a_corrections_file_in_another_encoding_is_a_one_line_error(tmp_path):
    path = tmp_path / "edits.txt"
    path.write_bytes("delete 1  # café\n".encode("cp1252"))
    with pytest.raises(DataError, match="edits.txt: is not UTF-8 text"):
        read_corrections(path)
