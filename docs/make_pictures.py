"""Remake the README's pictures of bulk water: ``python docs/make_pictures.py CLIP RUN_DIR``.

RUN_DIR is what ``seedtrack run CLIP --out RUN_DIR`` wrote. Writes into docs/pictures/: the
summary, one overlay frame (a quarter of the view, enlarged), and a screenshot of the annotate
page in headless Chromium, each reduced to 256 colours to stay small.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

from PIL import Image

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))

from chromium import headless_chromium  # noqa: E402

from seedtrack.annotate.frames import FrameCache  # noqa: E402
from seedtrack.annotate.server import AnnotateServer  # noqa: E402
from seedtrack.annotate.session import Session  # noqa: E402
from seedtrack.data.csvio import read_table  # noqa: E402
from seedtrack.data.trackfile import read_tracks  # noqa: E402


def small_png(source: Path, target: Path) -> None:
    Image.open(source).convert("RGB").quantize(256, method=Image.Quantize.MEDIANCUT).save(target, optimize=True)


def main(clip: Path, run: Path) -> None:
    out = HERE / "pictures"
    scratch = Path(tempfile.mkdtemp(prefix="pictures-"))
    seedtrack = [sys.executable, "-m", "seedtrack"]
    subprocess.run([*seedtrack, "render", str(clip), str(run / "tracks.csv"), "--out", str(scratch / "frame.png"), "--frame", "120", "--summary", str(scratch / "summary.png")], check=True)
    subprocess.run([*seedtrack, "render", str(clip), str(run / "tracks.csv"), "--out", str(scratch / "overlay.png"), "--frame", "120", "--crop", "160,106,480,318", "--scale", "2", "--detections", str(run / "detections.csv")], check=True)
    small_png(scratch / "summary.png", out / "bulk-water-summary.png")
    small_png(scratch / "overlay.png", out / "bulk-water-overlay.png")

    (scratch / "session").mkdir()
    session = Session(read_tracks(run / "tracks.csv"), scratch / "session", run / "tracks.csv")
    server = AnnotateServer(session, FrameCache(clip), read_table(run / "detections.csv", required=("frame", "x", "y")))
    threading.Thread(target=server.serve_forever, daemon=True).start()
    driver = headless_chromium()
    try:
        driver.set_window_size(1400, 820)
        driver.get(server.url)
        while not driver.execute_script("return window.annotate && window.annotate.state.ready"):
            time.sleep(0.05)
        # The first doubtful place, zoomed in on, as a reviewer meets it.
        driver.execute_script("document.dispatchEvent(new KeyboardEvent('keydown', {key: 'n'}))")
        for _ in range(3):
            driver.execute_script("document.dispatchEvent(new KeyboardEvent('keydown', {key: '+'}))")
        time.sleep(1.0)
        driver.save_screenshot(str(scratch / "page.png"))
    finally:
        driver.quit()
        server.shutdown()
    small_png(scratch / "page.png", out / "annotate-page.png")


if __name__ == "__main__":
    main(Path(sys.argv[1]), Path(sys.argv[2]))
