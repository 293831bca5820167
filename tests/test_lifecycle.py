"""Open GOA-updown: tracks that start, end and come back, on exact scenes, generated clips and random points."""

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from seedtrack.cli import main
from seedtrack.experiments import BASE
from seedtrack.data.csvio import read_table, write_table
from seedtrack.data.dish import DishSpec, make_dish_scene
from seedtrack.data.frames import open_frames
from seedtrack.data.psmg import generate_psmg
from seedtrack.detection.blobs import BlobOptions, detect_blobs
from seedtrack.tracking.gap_closing import extend_track_ends, join_track_ends
from seedtrack.tracking.goa import GOAConfig
from seedtrack.tracking.lifecycle import LifecycleConfig, drop_short, goa_updown_open
from seedtrack.tracking.linking import link_goa
from seedtrack.tracking.metrics import score_tracks
from seedtrack.tracking.trackers import run_tracker
from seedtrack.tracking.tracks import Tracks

from footage import BEADS, needs_beads

T = np.arange(12.0)
# Two points moving steadily in opposite directions, far apart.
RIGHT = np.column_stack((10 + 4 * T, 20 + 0 * T))
DOWN = np.column_stack((100 + 0 * T, 10 + 3 * T))


def frames_of(*paths, missing=()):
    """Frames of the given (n_frames, 2) paths (NaN rows absent), without the (path, frame) pairs in ``missing``."""
    return [
        np.array([p[k] for i, p in enumerate(paths) if (i, k) not in missing and not np.isnan(p[k, 0])]).reshape(-1, 2)
        for k in range(len(paths[0]))
    ]


def rows_by_track(tracks: Tracks) -> list[tuple[list[int], list[int]]]:
    """Per track, its frames and interpolated flags, sorted by first frame."""
    out = []
    for k in range(tracks.n_tracks):
        frames = np.flatnonzero(tracks.present[k])
        out.append((frames.tolist(), tracks.interpolated[k, frames].astype(int).tolist()))
    return sorted(out)


def test_a_gap_up_to_max_gap_is_filled_and_a_longer_one_ends_the_track():
    hidden = {(0, k) for k in range(4, 7)}  # RIGHT misses frames 4, 5 and 6
    frames = frames_of(RIGHT, DOWN, missing=hidden)
    joined = goa_updown_open(frames, lifecycle=LifecycleConfig(max_gap=3))
    assert rows_by_track(joined) == [(list(range(12)), [0] * 12), (list(range(12)), [0, 0, 0, 0, 1, 1, 1, 0, 0, 0, 0, 0])]
    assert np.allclose(joined.xy[0, 4:7], RIGHT[4:7])
    split = goa_updown_open(frames, lifecycle=LifecycleConfig(max_gap=2))
    assert rows_by_track(split) == [(list(range(4)), [0] * 4), (list(range(12)), [0] * 12), (list(range(7, 12)), [0] * 5)]


def test_max_slaves_ends_heads_early_and_gap_closing_still_joins_within_max_gap():
    hidden = {(0, k) for k in range(4, 7)}  # RIGHT misses frames 4, 5 and 6
    frames = frames_of(RIGHT, DOWN, missing=hidden)
    joined = goa_updown_open(frames, lifecycle=LifecycleConfig(max_gap=3, max_slaves=1))
    assert rows_by_track(joined) == [(list(range(12)), [0] * 12), (list(range(12)), [0, 0, 0, 0, 1, 1, 1, 0, 0, 0, 0, 0])]
    # Without gap closing, the head that ended after one slave leaves RIGHT in two tracks.
    split = goa_updown_open(frames, lifecycle=LifecycleConfig(max_gap=3, max_slaves=1, close_gaps=False))
    assert rows_by_track(split) == [(list(range(4)), [0] * 4), (list(range(12)), [0] * 12), (list(range(7, 12)), [0] * 5)]
    with pytest.raises(ValueError, match="max_slaves"):
        LifecycleConfig(max_slaves=-1)


def test_tracks_open_where_points_arrive_and_end_where_they_leave():
    late = RIGHT.copy()
    late[:3] = np.nan  # arrives in frame 3
    early = DOWN.copy()
    early[8:] = np.nan  # leaves after frame 7
    tracks = goa_updown_open(frames_of(late, early))
    assert rows_by_track(tracks) == [(list(range(8)), [0] * 8), (list(range(3, 12)), [0] * 9)]


def test_a_false_detection_opens_no_track():
    frames = frames_of(RIGHT, DOWN)
    frames[5] = np.vstack((frames[5], [60.0, 80.0]))
    tracks = goa_updown_open(frames)
    assert tracks.n_tracks == 2
    assert not (tracks.measurement[:, 5] == 2).any()


# Four points at the corners of a 100 x 100 view, drifting slowly: they mark the view's extent.
CORNERS = [np.array([[0.0, 0.0], [100.0, 0.0], [0.0, 100.0], [100.0, 100.0]]) + [0.2 * k, 0.1 * k] for k in range(12)]


def _with(frames, extra):
    """``frames`` with the points of ``extra`` ({frame: (x, y)}) added at the end of their frames."""
    return [np.vstack((f, [extra[k]])) if k in extra else f for k, f in enumerate(frames)]


def test_a_point_seen_twice_at_the_view_edge_is_a_two_point_track():
    frames = _with(CORNERS, {5: (1.0, 50.0), 6: (2.0, 50.5)})
    tracks = goa_updown_open(frames, GOAConfig(d_max=5.0))
    assert tracks.n_tracks == 5
    assert rows_by_track(tracks)[-1] == ([5, 6], [0, 0])


def test_a_pair_that_a_third_frame_should_have_shown_opens_no_track():
    # The same pair inside the view: its point would have been seen in frame 4 or 7.
    frames = _with(CORNERS, {5: (50.0, 50.0), 6: (51.0, 50.5)})
    tracks = goa_updown_open(frames, GOAConfig(d_max=5.0))
    assert tracks.n_tracks == 4


def test_a_pair_in_the_clips_last_frames_needs_only_its_first_point_at_the_edge():
    at_end = goa_updown_open(_with(CORNERS, {10: (1.0, 50.0), 11: (5.0, 50.5)}), GOAConfig(d_max=5.0))
    assert rows_by_track(at_end)[-1] == ([10, 11], [0, 0])
    inside = goa_updown_open(_with(CORNERS, {10: (50.0, 50.0), 11: (51.0, 50.5)}), GOAConfig(d_max=5.0))
    assert inside.n_tracks == 4


def test_gap_closing_joins_an_end_to_the_start_that_continues_its_motion():
    # RIGHT's two parts and a decoy start at the same frame, off RIGHT's line.
    decoy = RIGHT + [0.0, 12.0]
    frames = frames_of(RIGHT, decoy, missing={(0, k) for k in range(5, 8)} | {(1, k) for k in range(8)})
    before = np.full((3, 12), -1)
    before[0, :5] = 0  # RIGHT up to frame 4
    before[1, 8:] = 0  # RIGHT from frame 8 (listed first in each frame)
    before[2, 8:] = 1  # the decoy
    joined = join_track_ends(frames, before, GOAConfig(), max_gap=3)
    assert joined.tolist() == [np.concatenate((before[0, :8], before[1, 8:])).tolist(), before[2].tolist()]


def test_min_length_drops_short_tracks_only():
    tracks = goa_updown_open(frames_of(RIGHT, DOWN, missing={(0, k) for k in range(3, 12)}), lifecycle=LifecycleConfig(max_gap=0))
    lengths = sorted(len(frames) for frames, _ in rows_by_track(tracks))
    assert lengths == [3, 12]
    assert drop_short(tracks, 3).n_tracks == 2 and drop_short(tracks, 4).n_tracks == 1 and drop_short(tracks, 0).n_tracks == 2


@pytest.mark.parametrize("gap", [2, 5, 10])
def test_every_seed_hidden_by_a_hand_comes_back_with_its_own_id(gap):
    spec = DishSpec(seeds=40, frames=10 + gap + 8, rim_speed=5.0, hidden_seeds=10, hidden_frames=gap, random_seed=gap)
    scene = make_dish_scene(spec)
    frames = scene.visible_points()
    scores = score_tracks(goa_updown_open(frames), scene.truth, tolerance=0.5)
    assert scene.truth.interpolated.sum() == 10 * gap
    assert scores.correct_tracks == scores.true_tracks == 40


def test_seeds_added_and_removed_mid_clip_get_tracks_of_their_own():
    spec = DishSpec(seeds=40, frames=20, rim_speed=5.0, added_seeds=5, removed_seeds=5, random_seed=3)
    scene = make_dish_scene(spec)
    frames = scene.visible_points()
    tracks = goa_updown_open(frames)
    assert (~scene.truth.present).any(axis=1).sum() == 10
    assert score_tracks(tracks, scene.truth, tolerance=0.5).correct_tracks == 40
    assert np.array_equal(tracks.present.sum(axis=0), scene.truth.present.sum(axis=0))


def test_on_psmg_with_entry_exit_the_open_mode_is_at_least_ipan_and_fixed_count():
    merit = {"goa-updown": 0, "ipan": 0, "goa-updown-fixed": 0}
    for seed in range(2):
        spec = replace(BASE, frames=25, occlusion=0.05, max_gap=3, entry_exit=True, random_seed=seed)
        frames, truth = generate_psmg(spec)
        for name in merit:
            merit[name] += score_tracks(run_tracker(name, frames, spec.speed_limit), truth, 0.5).correct_tracks
    assert merit["goa-updown"] >= merit["ipan"] and merit["goa-updown"] >= merit["goa-updown-fixed"]


@st.composite
def random_points(draw):
    """A few frames of random points in a 60 x 60 square: trajectories that start, stop and jitter, and clutter."""
    n_frames = draw(st.integers(2, 9))
    seed = draw(st.integers(0, 2**16))
    rng = np.random.default_rng(seed)
    frames = []
    for _ in range(n_frames):
        count = draw(st.integers(0, 6))
        frames.append(rng.uniform(0, 60, size=(count, 2)).round(1))
    return frames


def _check_invariants(tracks: Tracks, frames: list[np.ndarray]) -> None:
    # A point belongs to at most one track.
    for k, points in enumerate(frames):
        held = tracks.measurement[:, k][tracks.measurement[:, k] >= 0]
        assert held.size == np.unique(held).size and (held < len(points)).all()
    # A track has at most one point per frame, and its frames are contiguous once gaps are filled.
    rows = tracks.to_rows()
    pairs = set(zip(rows["track_id"].tolist(), rows["frame"].tolist()))
    assert len(pairs) == rows["frame"].size
    for track in np.unique(rows["track_id"]):
        frames_of_track = rows["frame"][rows["track_id"] == track]
        assert np.array_equal(frames_of_track, np.arange(frames_of_track.min(), frames_of_track.max() + 1))
    # Measured rows sit on their points, interpolated rows hold no point.
    measured = tracks.measurement >= 0
    track, column = np.nonzero(measured)
    expected = np.array([frames[c][m] for c, m in zip(column, tracks.measurement[track, column])]).reshape(-1, 2)
    assert np.array_equal(tracks.xy[track, column], expected)


@settings(max_examples=15, deadline=None)
@given(random_points(), st.integers(0, 4), st.sampled_from([None, 6.0]))
def test_invariants_hold_on_random_points(frames, max_gap, max_speed):
    tracks = goa_updown_open(frames, GOAConfig(d_max=max_speed), LifecycleConfig(max_gap=max_gap))
    _check_invariants(tracks, frames)


def test_track_command_options(tmp_path):
    hidden = {(0, k) for k in range(4, 7)}
    frames = frames_of(RIGHT, DOWN, missing=hidden)
    points = tmp_path / "points.csv"
    write_table(points, {"frame": np.concatenate([np.full(len(f), k) for k, f in enumerate(frames)]), "x": np.concatenate(frames)[:, 0], "y": np.concatenate(frames)[:, 1]})
    out = tmp_path / "tracks.csv"
    assert main(["track", str(points), "--out", str(out)]) == 0
    assert read_table(out)["interpolated"].sum() == 3 and np.unique(read_table(out)["track_id"]).size == 2
    assert main(["track", str(points), "--out", str(out), "--max-gap", "2", "--min-length", "5"]) == 0
    assert np.unique(read_table(out)["track_id"]).size == 2 and read_table(out)["interpolated"].sum() == 0
    assert main(["track", str(points), "--out", str(out), "--fixed-count"]) == 0
    assert np.unique(read_table(out)["track_id"]).size == 2


@pytest.mark.parametrize(
    "options, message",
    [
        (["--max-gap", "-1"], "--max-gap must be a whole number of frames >= 0"),
        (["--min-length", "-2"], "--min-length must be a whole number of frames >= 0"),
        (["--fixed-count", "--max-gap", "3"], "--max-gap does not apply with --fixed-count"),
        (["--algorithm", "ipan", "--max-gap", "3"], "--max-gap only apply to --algorithm goa-updown"),
        (["--algorithm", "goa-updown-fixed", "--fixed-count"], "--fixed-count only apply to --algorithm goa-updown"),
    ],
)
def test_track_refuses_bad_lifecycle_options(tmp_path, capsys, options, message):
    points = tmp_path / "points.csv"
    points.write_text("frame,x,y\n0,1,1\n1,2,2\n2,3,3\n")
    out = tmp_path / "tracks.csv"
    assert main(["track", str(points), "--out", str(out), *options]) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


@needs_beads
def test_invariants_hold_on_real_beads_with_default_options():
    with open_frames(BEADS, start=100, end=104) as source:
        frames = [np.column_stack((c["x"], c["y"])) for c in (detect_blobs(image, BlobOptions()) for _, image in source)]
    tracks = goa_updown_open(frames)
    _check_invariants(tracks, frames)
    measured = (tracks.measurement >= 0).sum(axis=0)
    assert (measured <= [len(f) for f in frames]).all() and measured.min() > 0


def test_a_fast_dish_with_seeds_missed_now_and_then_keeps_most_tracks():
    # 5% of the seeds hidden in each frame at rim speed 42 px/frame: one head left without a
    # point must not pull a chain of neighbours along, which the zero corner of the augmented
    # matrix (two unlinked parts cost 2 phi_max) lets happen.
    spec = DishSpec(seeds=80, frames=20, rim_speed=42.0, hidden_probability=0.05, random_seed=3)
    scene = make_dish_scene(spec)
    frames = scene.visible_points()
    correct = {
        corner: score_tracks(goa_updown_open(frames, GOAConfig(corner=corner)), scene.truth, tolerance=0.5).correct_tracks
        for corner in ("phi", "zero")
    }
    assert correct["phi"] >= 60 and correct["phi"] >= correct["zero"] + 20, correct


@pytest.mark.parametrize("missed, taken", [((3,), [0, 0]), ((3, 4), [-1])])
def test_a_track_end_takes_a_free_point_across_one_missed_frame_but_not_two(missed, taken):
    # A point whose next frames are missed is left free when a head comes back to it (no point
    # continues it); after the passes its track end takes it back, across one missed frame only.
    frames = [np.array([[10.0 + 2 * k, 10.0]]) for k in range(6)]
    for k in missed:
        frames[k] = np.empty((0, 2))
    assignment = np.full((1, 6), -1)
    assignment[0, :3] = 0
    extended = extend_track_ends(frames, assignment, GOAConfig(d_max=5.0))
    assert extended[0, max(missed) + 1 :].tolist() == taken


def test_objects_gone_for_several_frames_at_a_time_keep_one_track():
    # Points at random, each gone twice for 3 to 6 frames in a row (beads out of focus): weighed
    # on independent misses, a join across such a gap lost to an end and a new start, and the
    # 80 objects became 180 to 200 tracks; the measured returns join them.
    rng = np.random.default_rng(0)
    n, n_frames = 80, 60
    xy = rng.uniform(10.0, 190.0, (n, 1, 2)) + np.cumsum(rng.normal(0.0, 0.3, (n, n_frames, 2)), axis=1)
    seen = np.ones((n, n_frames), bool)
    for i in range(n):
        for _ in range(2):
            gone = rng.integers(5, n_frames - 10)
            seen[i, gone : gone + rng.integers(3, 7)] = False
    measurement = np.full((n, n_frames), -1, np.int64)
    frames = []
    for k in range(n_frames):
        who = np.flatnonzero(seen[:, k])
        measurement[who, k] = np.arange(who.size)
        frames.append(xy[who, k])
    truth = Tracks.from_dense(np.where(seen[..., None], xy, np.nan), measurement)
    tracks = link_goa(frames)[0]
    assert tracks.n_tracks <= 90
    assert score_tracks(tracks, truth, 0.5).correct_tracks >= 64
