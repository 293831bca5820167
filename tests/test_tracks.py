"""The track set: held as points, dense views on demand, one meaning per field."""

import numpy as np
import pytest

from seedtrack.data.trackfile import read_tracks, write_tracks
from seedtrack.tracking.lifecycle import drop_short
from seedtrack.tracking.tracks import NO_MEASUREMENT, Tracks, link_speed_limit, tracks_from_assignment, tracks_from_links


def _frames(n_frames, per_frame=2):
    return [np.column_stack((np.arange(per_frame) * 10.0, np.full(per_frame, float(k)))) for k in range(n_frames)]


def test_memory_grows_with_the_points_held_not_tracks_times_frames():
    # 1,000 two-point tracks spread over 2,000 frames: dense (track, frame) arrays would hold
    # 2 million cells; the points are 2,000.
    n_frames = 2_000
    frames = _frames(n_frames, per_frame=1)
    links = np.array([[k, 0, k + 1, 0] for k in range(0, n_frames, 2)])
    tracks = tracks_from_links(frames, links)
    assert tracks.n_tracks == 1_000 and tracks.n_frames == n_frames
    held = sum(getattr(tracks, name).nbytes for name in ("point_track", "point_column", "point_xy", "point_measurement", "point_interpolated"))
    assert held <= 2_000 * 41
    # A dense view is built only when asked for.
    assert "xy" not in vars(tracks)


def test_bound_slaves_are_interpolated_points_and_measured_points_keep_their_index():
    frames = _frames(5)
    assignment = np.array([[1, -1, -1, 0, -1], [-1, 0, 1, -1, -1]])
    tracks = tracks_from_assignment(frames, assignment, first_frame=7)
    np.testing.assert_array_equal(tracks.point_track, [0, 0, 0, 0, 1, 1])
    np.testing.assert_array_equal(tracks.point_column, [0, 1, 2, 3, 1, 2])
    np.testing.assert_array_equal(tracks.point_measurement, [1, -1, -1, 0, 0, 1])
    np.testing.assert_array_equal(tracks.point_interpolated, [False, True, True, False, False, False])
    # From (10, 0) to (0, 3) in three frames: one third of the way per frame.
    np.testing.assert_allclose(tracks.point_xy[1:3], [[10 - 10 / 3, 1.0], [10 - 20 / 3, 2.0]])
    # The dense views agree with the points.
    assert tracks.xy.shape == (2, 5, 2) and np.isnan(tracks.xy[0, 4]).all() and np.isnan(tracks.xy[1, 0]).all()
    np.testing.assert_array_equal(tracks.measurement[0], [1, -1, -1, 0, -1])
    np.testing.assert_array_equal(tracks.interpolated[0], [False, True, True, False, False])
    rows = tracks.to_rows()
    np.testing.assert_array_equal(rows["frame"], [7, 8, 9, 10, 8, 9])
    np.testing.assert_array_equal(rows["interpolated"], [0, 1, 1, 0, 0, 0])


def test_tracks_read_from_a_file_say_interpolated_apart_and_hold_no_measurement_index(tmp_path):
    tracks = tracks_from_assignment(_frames(4), np.array([[1, -1, 0, 1]]), first_frame=2)
    write_tracks(tmp_path / "t.csv", tracks)
    back = read_tracks(tmp_path / "t.csv")
    np.testing.assert_array_equal(back.point_interpolated, tracks.point_interpolated)
    assert (back.point_measurement == NO_MEASUREMENT).all()
    np.testing.assert_allclose(back.point_xy, tracks.point_xy, atol=1e-4)
    # What counts as measured does not change with where the tracks came from.
    assert link_speed_limit(back) == pytest.approx(link_speed_limit(tracks), rel=1e-4)


def test_from_rows_sorts_points_and_refuses_a_second_row_for_a_frame():
    tracks = Tracks.from_rows(np.array([9, 4, 9]), np.array([6, 5, 5]), np.array([1.0, 2.0, 3.0]), np.array([0.0, 0.0, 0.0]))
    np.testing.assert_array_equal(tracks.track_ids, [4, 9])
    np.testing.assert_array_equal(tracks.to_rows()["x"], [2.0, 3.0, 1.0])
    with pytest.raises(ValueError, match="two rows"):
        Tracks.from_rows(np.array([1, 1]), np.array([3, 3]), np.zeros(2), np.zeros(2))


def test_drop_short_keeps_ids_and_drops_tracks_with_no_point():
    assignment = np.array([[0, 0, 0, -1], [-1, -1, -1, -1], [-1, -1, 1, 1]])
    tracks = tracks_from_assignment(_frames(4), assignment)
    kept = drop_short(tracks, 3)
    np.testing.assert_array_equal(kept.track_ids, [0])
    np.testing.assert_array_equal(drop_short(tracks, 0).track_ids, [0, 2])
    np.testing.assert_array_equal(drop_short(tracks, 0).point_track, [0, 0, 0, 1, 1])
