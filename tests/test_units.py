"""Physical units: calibrated TrackMate files read and written in their units, and the unit
options of ``seedtrack analyze``."""

import numpy as np
import pandas as pd
import pytest

from seedtrack.cli import main
from seedtrack.data.calibration import Calibration
from seedtrack.data.errors import DataError
from seedtrack.data.trackfile import read_calibration, read_tracks, write_tracks
from seedtrack.tracking.tracks import Tracks


def _fake_tracks(pixel_width: float, with_settings: bool = True) -> str:
    """A TrackMate 7 file shaped as its FakeTracks example: positions in microns, times in
    seconds, the image's calibration under Settings/ImageData; two tracks of 5 spots moving
    right and down by 2 pixels a frame."""
    spots, edges = [], {0: [], 1: []}
    for frame in range(5):
        spots.append(f'<SpotsInFrame frame="{frame}">')
        for track in range(2):
            spot_id = 10 * track + frame
            x, y = (10 + 2 * frame) * pixel_width, (20 + 30 * track + 2 * frame) * pixel_width
            spots.append(
                f'<Spot ID="{spot_id}" name="ID{spot_id}" QUALITY="1.0" POSITION_X="{x}" POSITION_Y="{y}" POSITION_Z="0.0" '
                f'POSITION_T="{2.0 * frame}" FRAME="{frame}" RADIUS="2.5" VISIBILITY="1" />'
            )
            if frame:
                edges[track].append(f'<Edge SPOT_SOURCE_ID="{spot_id - 1}" SPOT_TARGET_ID="{spot_id}" LINK_COST="4.0" EDGE_TIME="{2.0 * frame - 1}" />')
        spots.append("</SpotsInFrame>")
    tracks = "".join(f'<Track name="Track_{t}" TRACK_ID="{t}" NUMBER_SPOTS="5">{"".join(e)}</Track>' for t, e in edges.items())
    settings = (
        f'<Settings><ImageData filename="FakeTracks.tif" folder="" width="128" height="128" nslices="1" nframes="5" '
        f'pixelwidth="{pixel_width}" pixelheight="{pixel_width}" voxeldepth="1.0" timeinterval="2.0" /></Settings>'
        if with_settings
        else ""
    )
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n<TrackMate version="7.6.0">\n<Log>TrackMate v7.6.0</Log>\n'
        '<Model spatialunits="micron" timeunits="sec">\n'
        f'<AllSpots nspots="10">{"".join(spots)}</AllSpots>\n<AllTracks>{tracks}</AllTracks>\n'
        '<FilteredTracks><TrackID TRACK_ID="0" /><TrackID TRACK_ID="1" /></FilteredTracks>\n</Model>\n'
        f"{settings}\n</TrackMate>\n"
    )


def _pixel_tracks():
    frame = np.tile(np.arange(5), 2)
    track = np.repeat([0, 1], 5)
    return Tracks.from_rows(track, frame, 10.0 + 2 * frame, 20.0 + 30 * track + 2 * frame)


@pytest.mark.parametrize("pixel_width", [1.0, 0.25])
def test_faketracks_calibrated_in_microns_is_accepted_as_truth(tmp_path, capsys, pixel_width):
    (tmp_path / "FakeTracks.xml").write_text(_fake_tracks(pixel_width))
    write_tracks(tmp_path / "result.csv", _pixel_tracks())
    assert main(["evaluate", str(tmp_path / "result.csv"), "--truth", str(tmp_path / "FakeTracks.xml"), "--tol", "0.5"]) == 0
    table = dict(line.split(maxsplit=1) for line in capsys.readouterr().out.splitlines())
    assert (table["true_tracks"], table["correct_tracks"], table["link_error"], table["hota"]) == ("2", "2", "0.000000", "1.000000")
    assert read_calibration(tmp_path / "FakeTracks.xml") == Calibration(pixel_width, "micron", 2.0, "sec")


def test_calibrated_trackmate_without_pixel_size_is_refused_in_one_line(tmp_path):
    (tmp_path / "t.xml").write_text(_fake_tracks(1.0, with_settings=False))
    with pytest.raises(DataError, match=r"t\.xml: line 4: TrackMate's positions are in micron, but the file gives no pixel size"):
        read_tracks(tmp_path / "t.xml")


def test_trackmate_written_in_its_units_reads_back_in_pixels(tmp_path):
    units = Calibration(0.5, "micron", 0.1, "sec")
    write_tracks(tmp_path / "t.xml", _pixel_tracks(), units=units)
    text = (tmp_path / "t.xml").read_text()
    assert 'spatialunits="micron"' in text and 'POSITION_X="5.0000"' in text and 'POSITION_T="0.4"' in text
    back = read_tracks(tmp_path / "t.xml")
    np.testing.assert_allclose(back.point_xy, _pixel_tracks().point_xy)
    assert read_calibration(tmp_path / "t.xml") == units
    # Without units: pixels and frames, as before.
    write_tracks(tmp_path / "p.xml", _pixel_tracks())
    assert 'spatialunits="pixel" timeunits="frame"' in (tmp_path / "p.xml").read_text()
    assert read_calibration(tmp_path / "p.xml") == Calibration()


def test_analyze_uses_the_files_calibration_unless_told_otherwise(tmp_path, capsys):
    (tmp_path / "FakeTracks.xml").write_text(_fake_tracks(0.25))
    assert main(["analyze", str(tmp_path / "FakeTracks.xml"), "--out", str(tmp_path / "a")]) == 0
    msd = pd.read_csv(tmp_path / "a" / "msd.csv")
    # Steps of (2, 2) pixels a frame: MSD = 8 lag^2 px^2 = 0.5 lag^2 um^2, at lag times of 2 s.
    assert msd["lag_time"].tolist()[:2] == [2.0, 4.0]
    np.testing.assert_allclose(msd["msd"], 0.5 * msd["lag"] ** 2)
    assert "micron^2/sec" in capsys.readouterr().out
    assert main(["analyze", str(tmp_path / "FakeTracks.xml"), "--out", str(tmp_path / "b"), "--pixel-size", "1", "--space-unit", "px", "--frame-interval", "1", "--time-unit", "frame"]) == 0
    np.testing.assert_allclose(pd.read_csv(tmp_path / "b" / "msd.csv")["msd"], 8.0 * msd["lag"] ** 2)
    for name in ("msd", "speed", "drift"):
        for suffix in (".png", ".svg"):
            assert (tmp_path / "a" / f"{name}{suffix}").stat().st_size > 1000
    velocity = pd.read_csv(tmp_path / "a" / "velocity.csv")
    np.testing.assert_allclose(velocity["mean_speed"], np.hypot(0.5, 0.5) / 2.0)
    # The same input makes the same bytes, plots included.
    assert main(["analyze", str(tmp_path / "FakeTracks.xml"), "--out", str(tmp_path / "c")]) == 0
    names = sorted(p.name for p in (tmp_path / "a").iterdir())
    plots = {f"{n}{s}" for n in ("msd", "speed", "drift") for s in (".png", ".svg")}
    assert set(names) == plots | {"drift.csv", "msd.csv", "msd_per_track.csv", "velocity.csv"}
    for name in names:
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "c" / name).read_bytes(), name


def test_track_writes_trackmate_in_the_units_given(tmp_path, capsys):
    tracks = _pixel_tracks()
    pd.DataFrame({"frame": tracks.point_column, "x": tracks.point_xy[:, 0], "y": tracks.point_xy[:, 1]}).to_csv(tmp_path / "points.csv", index=False)
    assert main(["track", str(tmp_path / "points.csv"), "--out", str(tmp_path / "t.xml"), "--pixel-size", "0.5", "--frame-interval", "0.1"]) == 0
    assert main(["track", str(tmp_path / "points.csv"), "--out", str(tmp_path / "t.csv")]) == 0
    assert read_calibration(tmp_path / "t.xml") == Calibration(0.5, "um", 0.1, "s")
    in_pixels, calibrated = read_tracks(tmp_path / "t.csv"), read_tracks(tmp_path / "t.xml")
    np.testing.assert_allclose(calibrated.point_xy, in_pixels.point_xy)
    assert main(["track", str(tmp_path / "points.csv"), "--out", str(tmp_path / "u.xml"), "--pixel-size", "-1"]) == 2
    assert "--pixel-size must be a positive number" in capsys.readouterr().err
    assert not (tmp_path / "u.xml").exists()


def _imagej_tiff(path, pixel_size=0.25):
    import tifffile

    frames = np.full((3, 120, 160), 40, np.uint8)
    tifffile.imwrite(path, frames, imagej=True, resolution=(1 / pixel_size, 1 / pixel_size), metadata={"unit": "\\u00B5m", "finterval": 0.5, "axes": "TYX"})


def test_tiff_resolution_tags_give_the_clips_units(tmp_path):
    import tifffile

    from seedtrack.data.clip_units import tiff_calibration

    _imagej_tiff(tmp_path / "ij.tif")
    assert tiff_calibration(tmp_path / "ij.tif") == Calibration(0.25, "µm", 0.5, "s")
    tifffile.imwrite(tmp_path / "cm.tif", np.zeros((8, 8), np.uint8), resolution=(20000, 20000), resolutionunit=3)
    assert tiff_calibration(tmp_path / "cm.tif") == Calibration(0.5, "um")
    # Dots per inch are a print size, not a calibration.
    tifffile.imwrite(tmp_path / "dpi.tif", np.zeros((8, 8), np.uint8), resolution=(72, 72), resolutionunit=2)
    assert tiff_calibration(tmp_path / "dpi.tif") == Calibration()


def test_render_of_a_calibrated_tiff_has_a_scale_bar(tmp_path):
    import cv2

    _imagej_tiff(tmp_path / "clip.tif")
    write_tracks(tmp_path / "t.csv", Tracks.from_rows([0, 0, 0], [0, 1, 2], [10.0, 20.0, 30.0], [50.0, 50.0, 50.0]))
    assert main(["render", str(tmp_path / "clip.tif"), str(tmp_path / "t.csv"), "--out", str(tmp_path / "bar.png"), "--scale", "2"]) == 0
    assert main(["render", str(tmp_path / "clip.tif"), str(tmp_path / "t.csv"), "--out", str(tmp_path / "none.png"), "--scale", "2", "--space-unit", "pixel", "--pixel-size", "1"]) == 0
    bar, none = cv2.imread(str(tmp_path / "bar.png")), cv2.imread(str(tmp_path / "none.png"))
    # 20% of 320 drawn pixels is 8 um at 0.25 um a pixel, enlarged twice: a 5 um bar, 40 pixels long.
    # The bar spans columns 268-308 of rows 224-228; column 266 is outside it.
    corner = (slice(-16, -12), slice(-52, -12))
    assert (bar[corner] == 255).all() and not (bar[-16:-12, -54] == 255).all(axis=1).any()
    assert not (none[corner] == 255).all(axis=2).any()


def test_a_videos_frame_rate_gives_the_frame_interval(tmp_path):
    from seedtrack.data.clip_units import clip_calibration
    from seedtrack.data.video import write_video

    write_video(tmp_path / "clip.mp4", (np.full((32, 32, 3), 60, np.uint8) for _ in range(3)), fps=20.0)
    assert clip_calibration(tmp_path / "clip.mp4") == Calibration(1.0, "pixel", 0.05, "s")
    _imagej_tiff(tmp_path / "clip.tif")
    assert clip_calibration(tmp_path / "clip.tif") == Calibration(0.25, "µm", 0.5, "s")


def test_sizes_no_clip_has_are_refused_in_one_line(tmp_path, capsys):
    write_tracks(tmp_path / "t.csv", _pixel_tracks())
    assert main(["analyze", str(tmp_path / "t.csv"), "--out", str(tmp_path / "a"), "--pixel-size", "1e300"]) == 2
    assert "--pixel-size must be a positive number from 1e-12 to 1e+12" in capsys.readouterr().err
    assert not (tmp_path / "a").exists()
    (tmp_path / "tiny.xml").write_text(_fake_tracks(1.0).replace('pixelwidth="1.0"', 'pixelwidth="1e-20"'))
    with pytest.raises(DataError, match=r"tiny\.xml: line 4: pixel_size must be a positive number"):
        read_calibration(tmp_path / "tiny.xml")
