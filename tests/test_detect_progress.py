"""Detection says what it is doing while the first frame's once-per-clip decisions are made (tens
of seconds on a 4000 x 3000 frame), then counts frames off."""

import pickle

import numpy as np

import seedtrack.pipeline
from seedtrack.detection.clip import ClipDetector
from seedtrack.pipeline import DetectSettings, detect_clip

SPOT_STEPS = ["looking for a dish", "telling dark objects from light", "measuring the spots' size", "measuring the noise and the least mass", "detecting"]


def beads(seed, size=(120, 160)):
    """Dark Gaussian beads (sigma 1.6 px) on a noisy light field, 8-bit."""
    rng = np.random.default_rng(seed)
    rows, columns = np.mgrid[0 : size[0], 0 : size[1]]
    image = 150 + rng.normal(0, 2, size)
    for x, y in rng.uniform(10, [size[1] - 10, size[0] - 10], (20, 2)):
        image -= 60 * np.exp(-((columns - x) ** 2 + (rows - y) ** 2) / (2 * 1.6**2))
    return np.clip(np.round(image), 0, 255).astype(np.uint8)


def test_the_first_frames_decisions_are_said_as_they_begin_and_only_then():
    steps = []
    detector = ClipDetector(progress=steps.append)
    detector.detect(beads(0))
    assert detector.choice.name == "spot" and steps == SPOT_STEPS
    detector.detect(beads(1))
    assert steps == SPOT_STEPS
    # Decided, the detector no longer holds the hook (a bar would not pickle).
    pickle.dumps(detector)
    given = []
    ClipDetector(detector="blob", roi="none", progress=given.append).detect(beads(0))
    assert given == ["telling dark objects from light", "detecting"]


class RecordingBar:
    """Stands for the tqdm bar: records what is shown on it, in order."""

    shown: list = []

    def __init__(self, total, description, unit="frame"):
        RecordingBar.shown = [("start", total)]

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def set_postfix_str(self, text, refresh=True):
        self.shown.append(("postfix", text))

    def update(self, count=1):
        self.shown.append(("update", count))


def test_the_detecting_bar_shows_the_first_frames_steps_before_it_first_moves(monkeypatch):
    monkeypatch.setattr(seedtrack.pipeline, "progress_bar", RecordingBar)
    detect_clip([beads(seed) for seed in range(3)], DetectSettings(), say=None)
    shown = RecordingBar.shown
    first_update = shown.index(("update", 1))
    assert shown[1:first_update] == [("postfix", f"first frame: {step}") for step in SPOT_STEPS] + [("postfix", "")]
    assert shown[first_update:] == [("update", 1)] * 3
