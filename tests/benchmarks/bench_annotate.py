"""How fast the annotation page is on a 1080p clip, in headless Chromium (issue 19's goals:
page ready within 2 s, the next frame shown within 100 ms of the key).

Run as ``python tests/benchmarks/bench_annotate.py``. Makes a 1920x1080 dish clip of 30 frames
with 150 seeds, serves it with its truth as the tracks, and prints:

* page ready: from asking for the address to the first frame drawn with the tracks over it;
* step: from the right-arrow key to the next frame drawn, as the page measures it, stepping
  through the clip one frame at a time as a reviewer does (the page fetches the next frames
  while the current one is looked at);
* cold frame: what the server takes to decode and JPEG-encode the next frame when the page has
  not fetched it ahead (the frames one after another from a fresh cache), and a jump back.

The machine's load average is printed too: the figures are wall-clock times.
"""

from __future__ import annotations

import os
import statistics
import sys
import tempfile
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from chromium import headless_chromium  # noqa: E402
from selenium.webdriver.common.action_chains import ActionChains  # noqa: E402
from selenium.webdriver.common.keys import Keys  # noqa: E402

from seedtrack.annotate.frames import FrameCache  # noqa: E402
from seedtrack.annotate.server import AnnotateServer  # noqa: E402
from seedtrack.annotate.session import Session  # noqa: E402
from seedtrack.data.dish import DishSpec, write_dish_clip  # noqa: E402
from seedtrack.data.trackfile import read_tracks  # noqa: E402

FRAMES, SEEDS = 30, 150
# A reviewer looks at a frame for a while before the next key; the page uses that time.
LOOK_SECONDS = 0.15


def wait(driver, script: str, timeout: float = 30.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = driver.execute_script(script)
        if value:
            return value
        time.sleep(0.005)
    raise TimeoutError(script)


def main() -> None:
    folder = Path(tempfile.mkdtemp(prefix="bench-annotate-"))
    write_dish_clip(DishSpec(seeds=SEEDS, frames=FRAMES, width=1920, height=1080, rim_speed=30), folder)
    (folder / "out").mkdir()

    cache = FrameCache(folder / "clip.mp4")
    cold = []
    for index in range(FRAMES):
        started = time.perf_counter()
        cache.jpeg(index)
        cold.append(time.perf_counter() - started)
    cache = FrameCache(folder / "clip.mp4", capacity=1)
    cache.jpeg(FRAMES - 1)
    started = time.perf_counter()
    cache.jpeg(FRAMES // 2)
    back = time.perf_counter() - started
    cache.close()

    session = Session(read_tracks(folder / "truth.csv"), folder / "out", folder / "truth.csv")
    server = AnnotateServer(session, FrameCache(folder / "clip.mp4"))
    threading.Thread(target=server.serve_forever, daemon=True).start()
    driver = headless_chromium()
    driver.set_window_size(1920, 1080)
    try:
        driver.get("about:blank")
        started = time.perf_counter()
        driver.get(server.url)
        wait(driver, "return window.annotate && window.annotate.state.ready")
        ready = time.perf_counter() - started
        steps = []
        for frame in range(1, FRAMES):
            time.sleep(LOOK_SECONDS)
            ActionChains(driver).send_keys(Keys.ARROW_RIGHT).perform()
            wait(driver, f"return window.annotate.state.drawnFrame === {frame} && window.annotate.state.stepStarted === null")
            steps.append(driver.execute_script("return window.annotate.state.lastStepMs"))
    finally:
        driver.quit()
        server.shutdown()
    steps.sort()
    print(f"1920x1080 clip, {FRAMES} frames, {SEEDS} tracks, headless Chromium")
    print(f"page ready: {ready * 1000:.0f} ms (goal 2000)")
    print(f"step to the next frame: median {statistics.median(steps):.0f} ms, 90th percentile {steps[int(0.9 * len(steps))]:.0f} ms, worst {steps[-1]:.0f} ms (goal 100)")
    print(f"cold next frame (decode + JPEG encode on the server): median {statistics.median(cold) * 1000:.0f} ms; jump back {FRAMES // 2} frames: {back * 1000:.0f} ms")
    print(f"load average while measuring: {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")


if __name__ == "__main__":
    main()
