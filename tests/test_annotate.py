"""seedtrack annotate: what clicks mean, its files, its security rules, and the page in a real browser."""

import http.client
import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from seedtrack.annotate.doubt import doubtful_places
from seedtrack.annotate.frames import FrameCache
from seedtrack.annotate.server import AnnotateServer
from seedtrack.annotate.session import CORRECTIONS, EXPORTS, TRACKS, EditRefused, Session, edit_text
from seedtrack.cli import main
from seedtrack.data.corrections import Edit, apply_corrections, read_corrections
from seedtrack.data.dish import DishSpec, write_dish_clip
from seedtrack.data.trackfile import read_tracks, write_tracks
from seedtrack.tracking.tracks import Tracks

SWAPS = ((0, 1, 3), (2, 3, 6), (4, 5, 9))


@pytest.fixture(scope="module")
def dish(tmp_path_factory):
    """A 12-frame dish clip, its truth, and a result with three wrong links (tracks swapped)."""
    folder = tmp_path_factory.mktemp("dish")
    write_dish_clip(DishSpec(seeds=12, frames=12, width=320, height=240, rim_speed=8, random_seed=3), folder)
    truth = read_tracks(folder / "truth.csv")
    wrong = apply_corrections(truth, [Edit("swap", swap, 1) for swap in SWAPS], "made")
    write_tracks(folder / "wrong.csv", wrong)
    rows = truth.to_rows()
    with open(folder / "detections.csv", "w") as handle:
        handle.write("frame,x,y\n" + "".join(f"{f},{x:.4f},{y:.4f}\n" for f, x, y in zip(rows["frame"], rows["x"], rows["y"])))
    return folder, truth


def _rows(tracks):
    rows = tracks.to_rows()
    return sorted(zip(rows["track_id"].tolist(), rows["frame"].tolist(), np.round(rows["x"], 3).tolist(), np.round(rows["y"], 3).tolist()))


def _empty():
    return Tracks.from_rows([], [], [], [])


# --- what a click means ----------------------------------------------------------------------


def test_clicks_make_each_edit(tmp_path):
    # Track 1 in frames 0-4 at x = frame, track 2 in frames 0-2 at x = 10 + frame, y = 0.
    start = Tracks.from_rows([1] * 5 + [2] * 3, [0, 1, 2, 3, 4, 0, 1, 2], [0, 1, 2, 3, 4, 10, 11, 12], [0.0] * 8)
    session = Session(start, tmp_path, None)
    assert session.click(None, 1, 11.2, 0.1) == 2, "a point of a track selects it"
    assert session.edits == []
    session.click(1, 2, 12.0, 0.0)  # track 1 has points from frame 2 on: a swap
    session.click(2, 5, 50.0, 5.0)  # no point of any track there: an added point
    session.click(2, 5, 51.0, 5.0)  # track 2 has one there now: it moves
    assert session.split(2, 5) == 3
    session.click(1, 5, 51.0, 5.0)  # track 1 ends at frame 2: the split-off track 3 joins it
    assert session.click(None, 3, 30.0, 30.0) == 4, "a click on nothing starts a track, with an id never used"
    session.delete(4)
    assert [edit.verb for edit in session.edits] == ["swap", "add", "move", "split", "join", "add", "delete"]
    assert _points(session.tracks) == {(1, 0): 0, (1, 1): 1, (1, 2): 12, (1, 5): 51, (2, 0): 10, (2, 1): 11, (2, 2): 2, (2, 3): 3, (2, 4): 4}


def _points(tracks):
    rows = tracks.to_rows()
    return {(int(t), int(f)): float(x) for t, f, x in zip(rows["track_id"], rows["frame"], rows["x"])}


def test_undo_redo_and_resume(tmp_path):
    session = Session(_empty(), tmp_path, None)
    track = session.click(None, 0, 5.0, 6.0)
    session.click(track, 1, 7.0, 8.0)
    assert session.undo() and _points(session.tracks) == {(track, 0): 5.0}
    assert session.redo() and _points(session.tracks) == {(track, 0): 5.0, (track, 1): 7.0}
    assert not session.redo()
    session.undo()
    session.click(track, 1, 9.0, 9.0)
    assert not session.can_redo, "a new edit drops the edits taken back"
    again = Session(_empty(), tmp_path, None)
    assert _points(again.tracks) == {(track, 0): 5.0, (track, 1): 9.0}, "a second session resumes the folder's edits"


def test_correct_reproduces_the_saved_tracks_and_exports_every_format(tmp_path, dish):
    folder, truth = dish
    session = Session(read_tracks(folder / "wrong.csv"), tmp_path, folder / "wrong.csv")
    session.click(0, 3, *truth.xy[0, 3])
    session.split(2, 5)
    session.click(session.click(None, 2, 1.5, 2.5), 3, 2.5, 3.5)
    session.close()  # tracks.csv is written a moment after the last edit, or now
    assert main(["correct", str(folder / "wrong.csv"), str(tmp_path / CORRECTIONS), "--out", str(tmp_path / "again.csv")]) == 0
    assert (tmp_path / "again.csv").read_bytes() == (tmp_path / TRACKS).read_bytes()
    written = session.export()
    assert sorted(path.name for path in written) == sorted(EXPORTS.values())
    for name, file in EXPORTS.items():
        assert len(_rows(read_tracks(tmp_path / file, name))) == len(_rows(session.tracks))


def test_doubtful_places_put_the_wrong_links_first(dish):
    folder, truth = dish
    places = doubtful_places(read_tracks(folder / "wrong.csv"))
    wrong = {(frame, track) for a, b, frame in SWAPS for track in (a, b)}
    assert {(p["frame"], p["track"]) for p in places[: len(wrong)]} == wrong
    assert all(p["score"] > 1 for p in places[: len(wrong)]), "another point was nearer at each wrong link"
    assert not any(p["kind"] == "close call" for p in doubtful_places(truth)), "the truth holds no close call"


def test_doubtful_places_name_slaves_short_tracks_and_ends():
    tracks = Tracks.from_rows([1, 1, 1, 2, 2], [0, 1, 2, 5, 6], [0, 1, 2, 50, 51], [0.0] * 5, interpolated=[0, 1, 0, 0, 0])
    kinds = {(p["kind"], p["track"], p["frame"]) for p in doubtful_places(tracks, n_frames=10)}
    assert kinds == {("interpolated", 1, 1), ("short", 1, 0), ("end", 1, 2), ("short", 2, 5), ("start", 2, 5), ("end", 2, 6)}


def test_frames_come_in_any_order(dish):
    folder, _ = dish
    frames = FrameCache(folder / "clip.mp4", capacity=2)
    pictures = {index: frames.jpeg(index) for index in (5, 6, 2, 11, 0)}
    assert frames.jpeg(5) != pictures[6] and all(picture[:2] == b"\xff\xd8" for picture in pictures.values())
    with pytest.raises(IndexError):
        frames.jpeg(12)
    frames.close()


# --- the server's rules ----------------------------------------------------------------------


@pytest.fixture
def served(tmp_path, dish):
    folder, _ = dish
    out = tmp_path / "out"
    out.mkdir()
    server = AnnotateServer(Session(read_tracks(folder / "wrong.csv"), out, folder / "wrong.csv"), FrameCache(folder / "clip.mp4"))
    thread = threading.Thread(target=server.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True)
    thread.start()
    yield server
    server.shutdown()
    server.server_close()


def _request(server, method, path, host=None, body=None):
    connection = http.client.HTTPConnection("127.0.0.1", server.port, timeout=10)
    headers = {"Host": host if host is not None else f"127.0.0.1:{server.port}"}
    connection.request(method, path, body=json.dumps(body) if body is not None else None, headers=headers)
    response = connection.getresponse()
    data = response.read()
    connection.close()
    return response.status, data


def test_every_request_needs_the_token(served):
    token = served.token
    for method, path in (("GET", "/"), ("GET", "/app.js"), ("GET", "/api/state"), ("GET", "/api/frame?i=0"), ("POST", "/api/undo")):
        assert _request(served, method, path)[0] == 403, path
        assert _request(served, method, path + ("&" if "?" in path else "?") + "token=" + token[:-1] + ("y" if token.endswith("x") else "x"))[0] == 403, path
    status, body = _request(served, "GET", f"/api/frame?i=0&token={token}")
    assert status == 200 and body[:2] == b"\xff\xd8"
    status, body = _request(served, "GET", f"/?token={token}")
    assert status == 200 and f"app.js?token={token}".encode() in body


def test_a_foreign_host_header_is_refused(served):
    # A page on evil.example whose name has been pointed at 127.0.0.1 (DNS rebinding) sends this.
    for host in (f"evil.example:{served.port}", "127.0.0.1", f"127.0.0.1:{served.port + 1}", ""):
        assert _request(served, "GET", f"/api/state?token={served.token}", host=host)[0] == 403, host
    assert _request(served, "GET", f"/api/state?token={served.token}", host=f"localhost:{served.port}")[0] == 200


def test_no_file_outside_the_session_can_be_read(served, tmp_path):
    secret = tmp_path / "secret.txt"
    secret.write_text("not for the page")
    token = served.token
    for path in (f"/{secret}", f"/..{secret}", "/../../../etc/passwd", "/static/app.js", "/app.js/../../session.py", "/%2e%2e/server.py", f"/api/frame?i={secret}", f"/api/frame?i=../../etc/passwd", "/api/frame?i=99"):
        status, body = _request(served, "GET", path + ("&" if "?" in path else "?") + f"token={token}")
        assert status in (400, 404) and b"not for the page" not in body and b"import" not in body, path


def test_bad_edits_are_refused_and_change_nothing(served):
    token = served.token
    before = (served.session.folder / CORRECTIONS).read_bytes()
    assert _request(served, "POST", f"/api/split?token={token}", body={"track": 99, "frame": 3})[0] == 409
    assert _request(served, "POST", f"/api/click?token={token}", body={"frame": "3", "x": 1, "y": 2})[0] == 400
    assert _request(served, "POST", f"/api/click?token={token}", body={"frame": 3, "x": float("nan"), "y": 2})[0] == 400
    assert (served.session.folder / CORRECTIONS).read_bytes() == before


def test_the_command_prints_its_address_first_and_stops_cleanly_on_ctrl_c(tmp_path, dish):
    folder, _ = dish
    command = [sys.executable, "-m", "seedtrack", "annotate", str(folder / "clip.mp4"), str(folder / "wrong.csv"), "--out", str(tmp_path / "out"), "--no-browser"]
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        address = process.stdout.readline().strip()
        assert address.startswith("http://127.0.0.1:") and "/?token=" in address
        port = int(address.split(":")[2].split("/")[0])
        token = address.split("token=")[1]
        connection = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
        connection.request("POST", f"/api/split?token={token}", body=json.dumps({"track": 0, "frame": 4}), headers={"Host": f"127.0.0.1:{port}"})
        assert connection.getresponse().status == 200
        connection.close()
    finally:
        process.send_signal(signal.SIGINT)
        _, errors = process.communicate(timeout=20)
    assert process.returncode == 0, errors
    assert (tmp_path / "out" / CORRECTIONS).read_text().splitlines()[-1] == "split 0 4 12"
    assert read_tracks(tmp_path / "out" / TRACKS).n_tracks == 13
    assert not [path for path in (tmp_path / "out").iterdir() if path.name.startswith(".")], "no temporary file left"


# --- the page, in headless Chromium ----------------------------------------------------------


@pytest.fixture(scope="module")
def browser():
    from chromium import headless_chromium, missing_browser

    missing = missing_browser()
    if missing:
        # .ci/run installs both, and says a skip there is a failure.
        if os.environ.get("SEEDTRACK_REQUIRE_BROWSER"):
            pytest.fail(f"{missing}, and SEEDTRACK_REQUIRE_BROWSER is set")
        pytest.skip(f"{missing} (apt-get install -y chromium chromium-driver)")
    driver = headless_chromium()
    yield driver
    driver.quit()


def _serve(session, clip, detections=None):
    from seedtrack.data.csvio import read_table

    table = read_table(detections, required=("frame", "x", "y")) if detections is not None else None
    server = AnnotateServer(session, FrameCache(clip), table)
    threading.Thread(target=server.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True).start()
    return server


def _wait(browser, script, timeout=10.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = browser.execute_script(script)
        if value:
            return value
        time.sleep(0.02)
    raise AssertionError(f"timed out waiting for {script}")


class Page:
    """The page as a user meets it: keys pressed and clicks at image positions, counted."""

    def __init__(self, browser, server):
        from selenium.webdriver.common.by import By

        self.browser, self.server, self.actions = browser, server, 0
        browser.get(server.url)
        _wait(browser, "return window.annotate && window.annotate.state.ready")
        self.canvas = browser.find_element(By.ID, "view")

    def state(self, name):
        return self.browser.execute_script(f"return window.annotate.state.{name}")

    def key(self, key):
        from selenium.webdriver.common.action_chains import ActionChains

        ActionChains(self.browser).send_keys(key).perform()
        self.actions += 1

    def click(self, x, y, shift=False):
        """Click the picture at image position (x, y) (with shift held: another track's point is
        taken without asking) and wait for the page to take it in."""
        from selenium.webdriver.common.action_chains import ActionChains
        from selenium.webdriver.common.keys import Keys

        edits = len(self.state("edits"))
        sx, sy = self.browser.execute_script("return window.annotate.toScreen(arguments[0], arguments[1])", float(x), float(y))
        width, height = self.browser.execute_script("return [arguments[0].clientWidth, arguments[0].clientHeight]", self.canvas)
        chain = ActionChains(self.browser).move_to_element_with_offset(self.canvas, round(sx - width / 2), round(sy - height / 2))
        if shift:
            chain = chain.key_down(Keys.SHIFT).click().key_up(Keys.SHIFT)
        else:
            chain = chain.click()
        chain.perform()
        self.actions += 1
        _wait(self.browser, f"return window.annotate.state.edits.length > {edits}")

    def click_only(self, x, y):
        """Click the picture at image position (x, y), waiting for nothing."""
        from selenium.webdriver.common.action_chains import ActionChains

        sx, sy = self.browser.execute_script("return window.annotate.toScreen(arguments[0], arguments[1])", float(x), float(y))
        width, height = self.browser.execute_script("return [arguments[0].clientWidth, arguments[0].clientHeight]", self.canvas)
        ActionChains(self.browser).move_to_element_with_offset(self.canvas, round(sx - width / 2), round(sy - height / 2)).click().perform()


def test_three_wrong_links_fixed_by_two_actions_each(browser, dish, tmp_path):
    folder, truth = dish
    server = _serve(Session(read_tracks(folder / "wrong.csv"), tmp_path, folder / "wrong.csv"), folder / "clip.mp4", folder / "detections.csv")
    page = Page(browser, server)
    truth_xy = {int(track): truth.xy[row] for row, track in enumerate(truth.track_ids)}
    for _ in SWAPS:
        # The doubtful places follow an edit a moment later, apart from its answer.
        _wait(browser, "return window.annotate.state.doubtVersion === window.annotate.state.version")
        page.key("n")  # to the most doubtful place: the page selects the track there
        frame, track = page.state("frame"), page.state("selected")
        assert page.browser.execute_script("return window.annotate.state.tracks.size") == truth.n_tracks
        # Up to the wrong link the track is its true self: the true track it was in the frame before.
        previous = server.session.tracks.xy[list(server.session.tracks.track_ids).index(track), frame - 1]
        true_id = next(t for t, xy in truth_xy.items() if np.allclose(xy[frame - 1], previous))
        page.click(*truth_xy[true_id][frame], shift=True)
    server.shutdown()
    server.session.close()
    assert page.actions == 2 * len(SWAPS)
    assert _rows(read_tracks(tmp_path / TRACKS)) == _rows(truth)
    assert [line.split()[0] for line in (tmp_path / CORRECTIONS).read_text().splitlines() if not line.startswith("#")] == ["swap"] * 3


def test_a_plain_click_on_another_tracks_point_asks_first(browser, dish, tmp_path):
    folder, truth = dish
    server = _serve(Session(read_tracks(folder / "wrong.csv"), tmp_path, folder / "wrong.csv"), folder / "clip.mp4", folder / "detections.csv")
    page = Page(browser, server)
    page.key("n")  # a doubtful place, its track selected
    frame, track = page.state("frame"), page.state("selected")
    rows = server.session.tracks.to_rows()
    other = (rows["frame"] == frame) & (rows["track_id"] != track)
    x, y, holder = float(rows["x"][other][0]), float(rows["y"][other][0]), int(rows["track_id"][other][0])
    for answer in ("dismiss", "accept"):
        page.click_only(x, y)
        from selenium.webdriver.support import expected_conditions
        from selenium.webdriver.support.ui import WebDriverWait

        alert = WebDriverWait(browser, 10).until(expected_conditions.alert_is_present())
        assert f"this is track {holder}'s point: the click would" in alert.text and f"from frame {frame} on" in alert.text
        getattr(alert, answer)()
        if answer == "dismiss":
            _wait(browser, "return document.getElementById('status').textContent.startsWith('nothing changed')")
            assert server.session.edits == []
    _wait(browser, "return window.annotate.state.edits.length === 1")
    server.shutdown()
    assert server.session.edits[0].verb in ("swap", "join") and holder in server.session.edits[0].arguments


def test_ground_truth_from_nothing_by_clicks(browser, tmp_path):
    write_dish_clip(DishSpec(seeds=2, frames=4, width=160, height=120, rim_speed=6, random_seed=1), tmp_path)
    truth = read_tracks(tmp_path / "truth.csv")
    out = tmp_path / "out"
    out.mkdir()
    server = _serve(Session(_empty(), out, None), tmp_path / "clip.mp4")
    page = Page(browser, server)
    assert page.browser.execute_script("return document.getElementById('advance').checked"), "with no tracks, a point moves on to the next frame"
    for row in range(truth.n_tracks):
        page.key("\ue011")  # Home: back to frame 0
        page.key("\ue00c")  # Escape: no track selected, so the first click starts one
        for frame in range(truth.n_frames):
            assert page.state("frame") == frame
            page.click(*truth.xy[row, frame])
    server.shutdown()
    server.session.close()
    made = read_tracks(out / TRACKS)
    assert made.n_tracks == truth.n_tracks and made.n_frames == truth.n_frames
    assert np.abs(made.xy - truth.xy).max() < 0.5, "each point where it was clicked, to half a pixel"
    assert main(["correct", str(out / "start.csv"), str(out / CORRECTIONS), "--out", str(tmp_path / "again.csv")]) == 0
    assert (tmp_path / "again.csv").read_bytes() == (out / TRACKS).read_bytes()


def test_links_another_result_does_not_make_are_doubtful(dish):
    folder, truth = dish
    wrong = read_tracks(folder / "wrong.csv")
    # A link elsewhere the tracks' own points cannot tell: only the second result shows it.
    places = [p for p in doubtful_places(truth, other=wrong) if p["kind"] == "disagreement"]
    assert {(p["frame"], p["track"]) for p in places} == {(frame, track) for a, b, frame in SWAPS for track in (a, b)}


def test_bad_input_is_one_line_exit_2_and_no_folder(tmp_path, dish, capsys):
    folder, _ = dish
    for args in ([str(tmp_path / "missing.mp4")], [str(folder / "clip.mp4"), str(tmp_path / "missing.csv")], [str(folder / "clip.mp4"), "--port", "70000"]):
        assert main(["annotate", *args, "--out", str(tmp_path / "out"), "--no-browser"]) == 2
        error = capsys.readouterr().err
        assert error.count("\n") == 1 and error.startswith("seedtrack annotate: error:"), error
        assert not (tmp_path / "out").exists()


def test_jumps_in_a_video_give_the_frames_sequential_decoding_gives(tmp_path):
    import av

    # Key frames every 4 frames and B-frames, so that jumps seek and frames are reordered.
    rng = np.random.default_rng(0)
    with av.open(str(tmp_path / "gop.mp4"), "w") as container:
        stream = container.add_stream("libx264", rate=25)
        stream.width, stream.height, stream.pix_fmt = 64, 48, "yuv420p"
        stream.codec_context.gop_size = 4
        stream.options = {"bf": "2", "keyint_min": "4", "sc_threshold": "0"}
        for k in range(23):
            image = np.full((48, 64, 3), 10 * k, np.uint8) + rng.integers(0, 9, (48, 64, 3), dtype=np.uint8)
            for packet in stream.encode(av.VideoFrame.from_ndarray(image, format="bgr24")):
                container.mux(packet)
        for packet in stream.encode():
            container.mux(packet)
    with av.open(str(tmp_path / "gop.mp4")) as container:
        expected = [cv2_jpeg(frame.to_ndarray(format="bgr24")) for frame in container.decode(video=0)]
    frames = FrameCache(tmp_path / "gop.mp4", capacity=1)
    assert frames._seeker is not None and len(frames._seeker._keys) > 4, "this video's timestamps number its frames"
    for index in (20, 3, 21, 22, 9, 0, 1, 17, 4, 5, 6):
        assert frames.jpeg(index) == expected[index], index
    frames.close()


def cv2_jpeg(image):
    import cv2

    from seedtrack.annotate.frames import JPEG_QUALITY

    return cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY])[1].tobytes()


def test_no_tracks_no_doubt():
    assert doubtful_places(_empty(), n_frames=5) == []


def test_frames_of_an_image_folder(tmp_path):
    import cv2

    for k in range(4):
        cv2.imwrite(str(tmp_path / f"img{k}.png"), np.full((8, 10, 3), 60 * k, np.uint8))
    frames = FrameCache(tmp_path)
    assert (frames.size, frames.frame_count) == ((10, 8), 4)
    shades = [int(cv2.imdecode(np.frombuffer(frames.jpeg(k), np.uint8), cv2.IMREAD_GRAYSCALE).mean()) for k in (3, 1, 2, 0)]
    assert [round(shade / 60) for shade in shades] == [3, 1, 2, 0]
    frames.close()


# --- incremental state and files -------------------------------------------------------------


def _post(server, path, body, version=None):
    connection = http.client.HTTPConnection("127.0.0.1", server.port, timeout=10)
    headers = {"Host": f"127.0.0.1:{server.port}"}
    if version is not None:
        headers["X-Version"] = str(version)
    connection.request("POST", f"{path}?token={server.token}", body=json.dumps(body), headers=headers)
    response = connection.getresponse()
    reply = json.loads(response.read())
    connection.close()
    assert response.status == 200, reply
    return reply


def _mirror(reply, held=None):
    """What the page holds after taking ``reply``: {track: [(frame, x, y, interpolated)]}."""
    held = {} if reply["since"] is None else {track: list(points) for track, points in held.items()}
    for track in reply["removed"]:
        held.pop(track, None)
    rows = reply["tracks"]
    fresh = {}
    for row in zip(rows["track_id"], rows["frame"], rows["x"], rows["y"], rows["interpolated"]):
        fresh.setdefault(row[0], []).append(row[1:])
    held.update(fresh)
    return held


def test_an_edit_answers_only_the_tracks_it_changed(served):
    server = served
    status, body = _request(server, "GET", f"/api/state?token={server.token}")
    whole = json.loads(body)
    assert status == 200 and whole["since"] is None and whole["version"] == 0
    held = _mirror(whole)
    reply = _post(server, "/api/split", {"track": 2, "frame": 5}, version=0)
    assert (reply["since"], reply["version"], reply["selected"]) == (0, 1, 12)
    assert sorted(set(reply["tracks"]["track_id"])) == [2, 12] and reply["removed"] == [], "only the split track and the new one"
    held = _mirror(reply, held)
    reply = _post(server, "/api/delete", {"track": 12}, version=1)
    assert reply["tracks"]["track_id"] == [] and reply["removed"] == [12]
    held = _mirror(reply, held)
    reply = _post(server, "/api/undo", {}, version=2)
    assert set(reply["tracks"]["track_id"]) == {12} and reply["version"] == 3
    held = _mirror(reply, held)
    assert held == _mirror(json.loads(_request(server, "GET", f"/api/state?token={server.token}")[1])), "the deltas add up to the whole state"
    doubt = json.loads(_request(server, "GET", f"/api/doubtful?token={server.token}")[1])
    places = doubtful_places(server.session.tracks, n_frames=12)
    assert doubt["version"] == 3 and doubt["places"] == places and doubt["count"] == len(places)
    assert doubt["per_frame"] == np.bincount([p["frame"] for p in places], minlength=12).tolist()
    stale = _post(server, "/api/redo", {}, version=99)
    assert stale["since"] is None and len(set(stale["tracks"]["track_id"])) == 12, "a version the server never made gets the whole state"
    assert _post(server, "/api/undo", {})["since"] is None, "no version named: the whole state"


def test_undo_and_redo_give_the_tracks_of_replaying_the_edits(tmp_path, dish):
    folder, _ = dish
    start = read_tracks(folder / "wrong.csv")
    session = Session(start, tmp_path, folder / "wrong.csv")
    rng = np.random.default_rng(5)
    held, version, undone = _mirror(_state_of(session)), 0, 0
    for step in range(60):
        choice = rng.integers(0, 6)
        frame = int(rng.integers(0, 12))
        ids = sorted(session.points)
        try:
            if choice == 0:
                session.click(int(rng.choice(ids)), frame, *rng.uniform(0, 200, 2))
            elif choice == 1:
                track, other = rng.choice(ids, 2, replace=False)
                x, y = session.points[int(other)].get(frame, (-1.0, -1.0))[:2]
                session.click(int(track), frame, x, y)
            elif choice == 2:
                session.split(int(rng.choice(ids)), frame)
            elif choice == 3:
                session.delete(int(rng.choice(ids)), frame if rng.random() < 0.7 else None)
            elif choice == 4:
                undone += session.undo()
            else:
                session.redo()
        except EditRefused:
            pass
        expected = apply_corrections(start, session.edits, "replayed")
        assert _rows(session.tracks) == _rows(expected), step
        assert [edit_text(edit) for edit in read_corrections(tmp_path / CORRECTIONS)] == [edit_text(edit) for edit in session.edits], "the log is the edits"
        held = _mirror(_delta_of(session, version), held)
        version = session.version
        assert held == _mirror(_state_of(session)), step
    assert undone > 5 and len(session.edits) > 10
    session.close()
    assert _rows(read_tracks(tmp_path / TRACKS)) == _rows(session.tracks)


def _state_of(session):
    return AnnotateServer.state(_Stub(session))


def _delta_of(session, since):
    return AnnotateServer.delta(_Stub(session), since)


class _Stub:
    """The part of a server that states and deltas read, without a socket."""

    def __init__(self, session):
        self.session = session

    def state(self):
        return AnnotateServer.state(self)


def test_tracks_csv_is_written_once_for_a_burst_of_edits(tmp_path, monkeypatch):
    import seedtrack.annotate.session as module

    writes = []
    # Only this session's writes count: another test's session may still have a save pending.
    monkeypatch.setattr(module, "write_tracks", lambda path, tracks, **kw: (Path(path).parent == tmp_path and writes.append(tracks.n_tracks)) or write_tracks(path, tracks, **kw))
    monkeypatch.setattr(module, "SAVE_DELAY", 3.0)  # well above five clicks on a loaded machine
    session = Session(_empty(), tmp_path, None)
    writes.clear()
    track = session.click(None, 0, 1.0, 1.0)
    for frame in range(1, 5):
        session.click(track, frame, frame + 1.0, 1.0)
    assert len(read_corrections(tmp_path / CORRECTIONS)) == 5, "each edit is in the log at once"
    _wait_for(lambda: writes == [1])
    time.sleep(0.3)
    assert writes == [1] and len(_rows(read_tracks(tmp_path / TRACKS))) == 5
    session.close()
    assert writes == [1], "nothing new to write at close"


def _wait_for(condition, timeout=10.0):
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.05)


def test_a_half_written_last_line_is_dropped_on_resume(tmp_path):
    session = Session(_empty(), tmp_path, None)
    track = session.click(None, 0, 1.0, 2.0)
    session.close()
    with open(tmp_path / CORRECTIONS, "a") as log:
        log.write(f"add {track} 1 3.")  # what a kill in the middle of a write leaves
    again = Session(_empty(), tmp_path, None)
    assert [edit_text(edit) for edit in again.edits] == [f"add {track} 0 1.0 2.0"]
    again.close()


def test_kill_9_loses_no_edit(tmp_path, dish):
    folder, _ = dish
    out = tmp_path / "out"
    command = [sys.executable, "-m", "seedtrack", "annotate", str(folder / "clip.mp4"), str(folder / "wrong.csv"), "--out", str(out), "--no-browser"]
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        address = process.stdout.readline().strip()
        server = _Address(int(address.split(":")[2].split("/")[0]), address.split("token=")[1])
        for path, body in (("/api/split", {"track": 0, "frame": 4}), ("/api/click", {"selected": 1, "frame": 2, "x": 5.0, "y": 6.0}), ("/api/delete", {"track": 3}), ("/api/undo", {}), ("/api/delete", {"track": 4, "frame": 7})):
            _post(server, path, body)
        served = _mirror(json.loads(_request(server, "GET", f"/api/state?token={server.token}")[1]))
    finally:
        process.kill()  # SIGKILL: no handler runs, tracks.csv is not caught up
        process.wait(timeout=20)
    assert [line.split()[0] for line in (out / CORRECTIONS).read_text().splitlines() if not line.startswith("#")] == ["split", "move", "delete"]
    session = Session(read_tracks(folder / "wrong.csv"), out, folder / "wrong.csv")
    assert _mirror(_state_of(session)) == served, "the log replays to the tracks the server held"
    assert _rows(read_tracks(out / TRACKS)) == _rows(session.tracks), "and tracks.csv catches up on resume"
    session.close()


class _Address:
    def __init__(self, port, token):
        self.port, self.token = port, token


def test_an_edit_that_cannot_be_saved_is_not_made(tmp_path, monkeypatch):
    import errno

    import seedtrack.annotate.session as module

    session = Session(_empty(), tmp_path, None)
    track = session.click(None, 0, 1.0, 2.0)
    log = (tmp_path / CORRECTIONS).read_bytes()

    def full(descriptor):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(module.os, "fsync", full)
    with pytest.raises(EditRefused, match="No space left on device"):
        session.click(track, 1, 3.0, 4.0)
    monkeypatch.undo()
    assert (tmp_path / CORRECTIONS).read_bytes() == log and _points(session.tracks) == {(track, 0): 1.0}
    assert session.undo() and session.points == {}
    session.close()


def test_edits_while_tracks_csv_is_being_written_do_not_lock_up(tmp_path, monkeypatch):
    import seedtrack.annotate.session as module

    # Every edit starts a write at once, so writes and edits overlap all the time.
    monkeypatch.setattr(module, "SAVE_DELAY", 0.0)
    session = Session(_empty(), tmp_path, None)
    track = session.click(None, 0, 1.0, 1.0)

    def edit():
        for frame in range(1, 150):
            session.click(track, frame, frame + 1.0, 1.0)

    worker = threading.Thread(target=edit, daemon=True)
    worker.start()
    worker.join(timeout=30)
    assert not worker.is_alive(), "an edit and a write wait for each other"
    session.close()
    assert len(_rows(read_tracks(tmp_path / TRACKS))) == 150
