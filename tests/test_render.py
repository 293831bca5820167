"""The renderer and the ``render`` and ``compare`` commands, on small generated clips."""

from __future__ import annotations

import av
import cv2
import numpy as np
import pytest
from PIL import Image

from seedtrack.cli import main
from seedtrack.scoring import disagreeing_links
from seedtrack.drawing import PALETTE_BGR, WARNING_BGR, FalseDetections, Occupancy, Style, TrackLayer, View, annotate, draw_text, ring_radius, summary_picture, track_colour
from seedtrack.data.csvio import write_table
from seedtrack.data.dish import DishSpec, write_dish_clip
from seedtrack.data.frames import open_frames
from seedtrack.data.trackfile import read_tracks, write_tracks
from seedtrack.tracking.tracks import Tracks

FRAMES, WIDTH, HEIGHT = 8, 320, 240


@pytest.fixture(scope="module")
def clip(tmp_path_factory):
    """A dish clip whose truth has hidden (interpolated) positions."""
    folder = tmp_path_factory.mktemp("clip")
    spec = DishSpec(seeds=12, frames=FRAMES, width=WIDTH, height=HEIGHT, rim_speed=10.0, random_seed=3, hidden_probability=0.2)
    write_dish_clip(spec, folder)
    return folder


def render(capsys, *args):
    """Run ``seedtrack render`` in process; returns (exit status, stderr)."""
    status = main(["render", *map(str, args)])
    return status, capsys.readouterr().err


def decode(path):
    with av.open(str(path)) as container:
        stream = container.streams.video[0]
        codec = stream.codec_context.name
        frames = [frame for frame in container.decode(stream)]
    return codec, [frame.format.name for frame in frames], [frame.to_ndarray(format="bgr24") for frame in frames]


def loneliest(truth: Tracks, column: int) -> int:
    """Row of the measured track in ``column`` farthest from every other track there."""
    points = truth.xy[:, column]
    distance = np.hypot(*(points[:, None] - points[None, :]).transpose(2, 0, 1))
    np.fill_diagonal(distance, np.inf)
    nearest = np.where(truth.interpolated[:, column], -np.inf, np.nanmin(distance, axis=1))
    return int(np.argmax(nearest))


def closest_palette_colour(pixel: np.ndarray) -> tuple[int, int, int]:
    index = np.argmin(np.abs(PALETTE_BGR.astype(int) - pixel.astype(int)).sum(axis=1))
    return tuple(int(c) for c in PALETTE_BGR[index])


def test_mp4_is_h264_yuv420p_with_frames_size_and_track_colours(clip, tmp_path, capsys):
    out = tmp_path / "clip.mp4"
    status, err = render(capsys, clip / "clip.mp4", clip / "truth.csv", "--out", out, "--scale", 2, "--start", 1, "--step", 2)
    assert status == 0, err
    codec, formats, images = decode(out)
    assert codec == "h264" and set(formats) == {"yuv420p"}
    assert len(images) == len(range(1, FRAMES, 2))
    assert images[0].shape == (2 * HEIGHT, 2 * WIDTH, 3)
    truth = read_tracks(clip / "truth.csv")
    for position, frame in enumerate(range(1, FRAMES, 2)):
        row = loneliest(truth, frame)
        # A pixel centre x maps to 2x + 0.5 on the doubled frame; the head is a ring around it.
        x, y = truth.xy[row, frame] * 2 + 0.5
        radius = ring_radius(Style.for_size((2 * WIDTH, 2 * HEIGHT)))
        rows, columns = np.mgrid[: 2 * HEIGHT, : 2 * WIDTH]
        ring = images[position][np.abs(np.hypot(columns - x, rows - y) - radius) < 0.6].astype(int)
        colour = track_colour(truth.track_ids[row])
        near = np.abs(ring - colour).max(axis=1) < 40
        assert near.mean() > 0.5, "most of the ring is in the track's colour"
        assert all(closest_palette_colour(pixel) == colour for pixel in ring[near])


def test_png_is_byte_identical_on_two_runs_and_matches_the_folder_frame(clip, tmp_path, capsys):
    for name in ("a.png", "b.png"):
        assert render(capsys, clip / "clip.mp4", clip / "truth.csv", "--out", tmp_path / name, "--frame", 5)[0] == 0
    assert (tmp_path / "a.png").read_bytes() == (tmp_path / "b.png").read_bytes()
    status, err = render(capsys, clip / "clip.mp4", clip / "truth.csv", "--out", f"{tmp_path / 'frames'}/", "--end", 6)
    assert status == 0, err
    written = sorted(path.name for path in (tmp_path / "frames").iterdir())
    assert written == [f"frame_{index:06d}.png" for index in range(6)]
    # Drawing carries no state from frame to frame: the folder's frame 5 is the single picture.
    assert (tmp_path / "frames" / "frame_000005.png").read_bytes() == (tmp_path / "a.png").read_bytes()


def test_a_frame_whose_trail_holds_no_link_is_drawn(clip, tmp_path, capsys):
    # Nothing is tracked in frames 2 to 4: their trails of one frame hold no link to draw.
    tracks = _write(tmp_path / "gap.csv", "track_id,frame,x,y\n1,0,10,10\n1,1,12,10\n2,5,50,50\n2,6,52,50\n")
    status, err = render(capsys, clip / "clip.mp4", tracks, "--out", tmp_path / "gap.png", "--frame", 4, "--trail", 1)
    assert status == 0, err
    assert (tmp_path / "gap.png").is_file()


def test_interpolated_head_is_a_hollow_ring(clip, tmp_path, capsys):
    truth = read_tracks(clip / "truth.csv")
    hidden_rows, hidden_columns = np.nonzero(truth.interpolated)
    row, column = hidden_rows[0], hidden_columns[0]
    out = tmp_path / "hollow.png"
    assert render(capsys, clip / "clip.mp4", clip / "truth.csv", "--out", out, "--frame", column, "--scale", 3, "--trail", 0, "--no-labels")[0] == 0
    picture = cv2.imread(str(out))
    with open_frames(clip / "clip.mp4", start=column, end=column + 1) as source:
        (_, frame), = list(source)
    plain = cv2.resize(frame, None, fx=3, fy=3, interpolation=cv2.INTER_LINEAR)
    x, y = np.round(truth.xy[row, column] * 3 + 1).astype(int)
    # The centre of a hollow ring shows the frame; the ring itself is in the track's colour.
    assert np.abs(picture[y, x].astype(int) - plain[y, x].astype(int)).max() <= 2
    ring = picture[y - 20 : y + 21, x - 20 : x + 21].reshape(-1, 3).astype(int)
    assert (np.abs(ring - track_colour(truth.track_ids[row])).max(axis=1) < 30).any()


def test_gif_has_every_frame_at_the_clip_rate(clip, tmp_path, capsys):
    out = tmp_path / "clip.gif"
    status, err = render(capsys, clip / "clip.mp4", clip / "truth.csv", "--out", out, "--scale", 0.5, "--fps", 10)
    assert status == 0, err
    with Image.open(out) as gif:
        assert gif.n_frames == FRAMES
        assert gif.size == (WIDTH // 2, HEIGHT // 2)
        assert gif.info["duration"] == 100


def test_summary_draws_every_trajectory_over_the_first_frame(clip, tmp_path, capsys):
    out = tmp_path / "summary.png"
    status, err = render(capsys, clip / "clip.mp4", clip / "truth.csv", "--summary", out, "--no-labels")
    assert status == 0, err
    picture = cv2.imread(str(out))
    truth = read_tracks(clip / "truth.csv")
    # Every track's midway point lies on its drawn path.
    for row in range(truth.n_tracks):
        x, y = np.round(truth.xy[row, FRAMES // 2]).astype(int)
        patch = picture[y - 1 : y + 2, x - 1 : x + 2].reshape(-1, 3)
        assert (np.abs(patch.astype(int) - track_colour(truth.track_ids[row])).max(axis=1) < 60).any()


def test_crop_and_scale_set_the_size(clip, tmp_path, capsys):
    out = tmp_path / "crop.mp4"
    assert render(capsys, clip / "clip.mp4", clip / "truth.csv", "--out", out, "--crop", "40,20,200,140", "--scale", 2, "--end", 3)[0] == 0
    _, _, images = decode(out)
    assert len(images) == 3 and images[0].shape == (240, 320, 3)


def test_view_maps_pixel_centres_to_pixel_centres():
    view = View.of((100, 80), "10,20,60,70", 2.0)
    assert view.size == (100, 100)
    np.testing.assert_allclose(view.points(np.array([[10.0, 20.0], [59.0, 69.0]])), [[0.5, 0.5], [98.5, 98.5]])


def test_a_head_outside_a_cropped_view_takes_no_room_from_labels():
    taken = Occupancy((100, 200))
    taken.add_points(np.array([[-30.0, 50.0], [50.0, -30.0]]), 5.6)
    assert not taken.grid.any()
    taken.add_points(np.array([[50.0, 50.0]]), 5.6)
    assert not taken.free(48, 48, 52, 52) and taken.free(100, 50, 110, 60)


def test_false_detections_are_those_no_measured_point_holds():
    xy = np.array([[[10.0, 10.0], [12.0, 10.0], [14.0, 10.0]]])
    tracks = Tracks.from_dense(xy=xy, measurement=np.array([[0, -1, 0]]), first_frame=4)
    # Frame 5's point is interpolated, so the detection there belongs to no track.
    frame = np.array([4, 5, 5, 6, 6])
    x = np.array([10.0, 12.0, 30.0, 14.0, 10.0])
    y = np.array([10.0, 10.0, 30.0, 10.0, 10.0])
    false = FalseDetections(frame, x, y, tracks, View.of((64, 48)))
    np.testing.assert_array_equal(false.frames, [5, 5, 6])
    np.testing.assert_allclose(false.xy, [[12, 10], [30, 30], [10, 10]])


def test_detections_option_crosses_out_false_detections(clip, tmp_path, capsys):
    detections = tmp_path / "detections.csv"
    write_table(detections, {"frame": np.array([2]), "x": np.array([40.0]), "y": np.array([200.0]), "area": np.array([5.0])})
    args = (clip / "clip.mp4", clip / "truth.csv", "--frame", 2, "--no-labels", "--trail", 0)
    assert render(capsys, *args, "--out", tmp_path / "with.png", "--detections", detections)[0] == 0
    assert render(capsys, *args, "--out", tmp_path / "without.png")[0] == 0
    changed = np.any(cv2.imread(str(tmp_path / "with.png")) != cv2.imread(str(tmp_path / "without.png")), axis=2)
    ys, xs = np.nonzero(changed)
    # Only the cross at (40, 200) and the legend's new row differ.
    near = np.hypot(xs - 40, ys - 200) < 16
    assert near.any() and (xs[~near] > WIDTH // 2).all()


def test_frames_are_drawn_alike_at_any_size():
    tracks = Tracks.from_dense(xy=np.array([[[100.0, 100.0], [110.0, 104.0]]]), measurement=np.zeros((1, 2), int))
    coverage = []
    for size in ((640, 480), (3840, 2160)):
        view = View.of((640, 480), scale=size[0] / 640)
        blank = np.zeros((480, 640, 3), np.uint8)
        drawn = annotate(blank, 1, view, [TrackLayer(tracks, view)])
        coverage.append(np.count_nonzero(drawn.any(axis=2)) / drawn.shape[0] / drawn.shape[1])
    # Marks, labels and legend grow with the frame: they cover a similar share of it (a little
    # more at 640x480, where ring lines and glyph strokes are rounded up to whole pixels).
    assert 0.4 < coverage[1] / coverage[0] < 2


@pytest.mark.parametrize(
    "make, out, message",
    [
        (lambda tmp, clip: _outside(tmp), "clip.mp4", "lie outside the video"),
        (lambda tmp, clip: _outside(tmp), "last.png", "lie outside the video"),
        (lambda tmp, clip: clip / "truth.csv", f"one.png --frame {FRAMES}", f"--frame {FRAMES} is past the last frame"),
        (lambda tmp, clip: _write(tmp / "odd.csv", "id,t,px,py\n1,0,3,4\n"), "clip.mp4", "track_id,frame,x,y"),
        (lambda tmp, clip: clip / "truth.csv", "missing/clip.mp4", "does not exist"),
        (lambda tmp, clip: clip / "truth.csv", "clip.avi", "unsupported output extension"),
        (lambda tmp, clip: clip / "truth.csv", "clip.gif --scale 0", "--scale must be a finite number > 0"),
    ],
)
def test_bad_input_is_one_line_exit_2_and_no_file(clip, tmp_path, capsys, make, out, message):
    tracks = make(tmp_path, clip)
    name, *extra = out.split()
    status, err = render(capsys, clip / "clip.mp4", tracks, "--out", tmp_path / name, *extra)
    assert status == 2
    assert err.count("\n") == 1 and message in err
    assert not (tmp_path / name).exists()
    assert not [path for path in tmp_path.iterdir() if path.name.startswith(".")]


def _outside(tmp):
    path = tmp / "late.csv"
    write_table(path, {"track_id": np.array([1, 1]), "frame": np.array([FRAMES + 3, FRAMES + 4]), "x": np.array([5.0, 6.0]), "y": np.array([5.0, 6.0])})
    return path


def _write(path, text):
    path.write_text(text)
    return path


def swapped(truth: Tracks, frame: int) -> Tracks:
    """The truth with the first two tracks exchanging identities from ``frame`` on."""
    xy = truth.xy.copy()
    xy[[0, 1], frame:] = xy[[1, 0], frame:]
    return Tracks.from_dense(xy=xy, measurement=truth.measurement.copy(), first_frame=truth.first_frame, track_ids=truth.track_ids)


def test_disagreeing_links_are_exactly_the_swapped_ones(clip):
    truth = read_tracks(clip / "truth.csv")
    result = swapped(truth, 4)
    expected = np.zeros(truth.present.shape, bool)
    expected[[0, 1], 4] = True
    np.testing.assert_array_equal(disagreeing_links(result, truth, 1.0), expected)
    np.testing.assert_array_equal(disagreeing_links(truth, result, 1.0), expected)
    assert not disagreeing_links(truth, truth, 1.0).any()


def test_compare_reads_truth_formats_and_draws_disagreements_in_the_warning_colour(clip, tmp_path, capsys):
    truth = read_tracks(clip / "truth.csv")
    write_tracks(tmp_path / "truth.xml", truth)
    write_tracks(tmp_path / "same.txt", truth)
    write_tracks(tmp_path / "swapped.txt", swapped(truth, 4))
    warning_pixels = []
    for other in ("same.txt", "swapped.txt"):
        out = tmp_path / f"{other}.png"
        status = main(["compare", str(clip / "clip.mp4"), str(tmp_path / "truth.xml"), str(tmp_path / other), "--out", str(out), "--frame", "4", "--overlay"])
        assert status == 0, capsys.readouterr().err
        warning_pixels.append(int((cv2.imread(str(out)) == WARNING_BGR).all(axis=2).sum()))
    assert warning_pixels[1] > warning_pixels[0]


def test_compare_side_by_side_clip_is_twice_as_wide(clip, tmp_path, capsys):
    out = tmp_path / "compare.mp4"
    assert main(["compare", str(clip / "clip.mp4"), str(clip / "truth.csv"), str(clip / "truth.csv"), "--out", str(out), "--end", "3"]) == 0
    codec, formats, images = decode(out)
    assert codec == "h264" and len(images) == 3
    assert images[0].shape[0] == HEIGHT and images[0].shape[1] >= 2 * WIDTH + 2
    assert "A 0 of" in capsys.readouterr().out


@pytest.mark.parametrize("name, kept", [("clip.mp4", []), ("clip.gif", []), ("frames/", ["frame_000000.png", "frame_000001.png"])])
def test_ctrl_c_leaves_no_partial_file(clip, tmp_path, capsys, monkeypatch, name, kept):
    import seedtrack.drawing

    real, calls = seedtrack.drawing.annotate, []

    def interrupted(*args, **kwargs):
        calls.append(1)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    monkeypatch.setattr(seedtrack.drawing, "annotate", interrupted)
    status, err = render(capsys, clip / "clip.mp4", clip / "truth.csv", "--out", f"{tmp_path}/{name}")
    assert status == 130 and "interrupted" in err
    left = sorted(path.name for path in tmp_path.rglob("*") if path.is_file())
    assert left == kept


def test_tracks_with_missing_frames_are_linked_across_the_gap():
    # A file written every other frame: frames 0, 2, 4 of one track, 1 and 2 of another.
    xy = np.full((2, 5, 2), np.nan)
    xy[0, [0, 2, 4]] = [[10, 10], [20, 10], [30, 10]]
    xy[1, [1, 2]] = [[50, 40], [52, 40]]
    layer = TrackLayer(Tracks.from_dense(xy=xy, measurement=np.zeros((2, 5), int)), View.of((64, 48)), trail=4)
    rows, ends, points = layer.segments(0, 4)
    assert sorted(zip(rows.tolist(), ends.tolist())) == [(0, 2), (0, 4), (1, 2)]
    starts = {(row, end): tuple(point[0] / 16) for row, end, point in zip(rows, ends, points)}
    assert starts[(0, 4)] == (20, 10)


def test_summary_marks_where_a_track_starts_and_ends_inside_the_clip():
    # Frames 2..5 of 8, straight along y = 200: the marks reach beyond the line at both ends only.
    xy = np.full((1, 8, 2), np.nan)
    xy[0, 2:6] = np.column_stack([np.linspace(100, 300, 4), np.full(4, 200.0)])
    view = View.of((400, 300))
    blank = np.zeros((300, 400, 3), np.uint8)
    picture = summary_picture(blank, view, [TrackLayer(Tracks.from_dense(xy, np.zeros((1, 8), int)), view, labels=False)])
    beside = picture[204:208].max(axis=(0, 2))
    assert beside[97:104].any() and beside[297:304].any() and not beside[150:250].any()


def test_disagreement_across_a_gap():
    xy = np.full((2, 5, 2), np.nan)
    xy[0, [0, 2, 4]] = [[10, 10], [20, 10], [30, 10]]
    xy[1, [0, 2, 4]] = [[10, 30], [20, 30], [30, 30]]
    truth = Tracks.from_dense(xy=xy, measurement=np.zeros((2, 5), int))
    wrong = swapped(truth, 4)
    expected = np.zeros((2, 5), bool)
    expected[:, 4] = True
    np.testing.assert_array_equal(disagreeing_links(wrong, truth, 1.0), expected)


def test_compare_with_tracks_past_the_video_is_one_line_exit_2(clip, tmp_path, capsys):
    out = tmp_path / "compare.mp4"
    status = main(["compare", str(clip / "clip.mp4"), str(clip / "truth.csv"), str(_outside(tmp_path)), "--out", str(out)])
    err = capsys.readouterr().err
    assert status == 2 and err.count("\n") == 1 and "late.csv" in err and "lie outside the video" in err
    assert not out.exists()


@pytest.mark.parametrize("thickness", [1, 2, 3])
def test_text_halo_hugs_the_text(thickness):
    # OpenCV spaces thin glyphs narrower than thick ones; a halo drawn thicker than thin text ran ahead of it.
    canvas = np.full((60, 400, 3), 128, np.uint8)
    draw_text(canvas, "frame 0: 416 found", (10, 40), (255, 255, 255), 0.7, thickness)
    text_columns = np.nonzero((canvas == 255).all(axis=2).any(axis=0))[0]
    halo_columns = np.nonzero((canvas < 64).all(axis=2).any(axis=0))[0]
    assert abs(halo_columns.max() - text_columns.max()) <= thickness + 2
    assert abs(halo_columns.min() - text_columns.min()) <= thickness + 2
