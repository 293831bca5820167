"""Each stage's settings check themselves, and the default link cost comes from the model registry."""

from __future__ import annotations

import pytest

from seedtrack.data.walkers import WalkerSpec, generate_walkers
from seedtrack.errors import OptionError, in_option_names
from seedtrack.pipeline import DetectSettings
from seedtrack.settings import EvaluateSettings, LinkSettings, RenderSettings
from seedtrack.detection.roi import Circle
from seedtrack.tracking.linking import link_goa
from seedtrack.tracking.motion import INDIVIDUAL_MODELS
from seedtrack.tracking.persistence import PersistentModel


@pytest.mark.parametrize(
    "settings, message, names",
    [
        (lambda: DetectSettings(threshold="high"), "threshold must be otsu, adaptive or a number of grey levels, got 'high'", ("threshold",)),
        (lambda: DetectSettings(min_area=9.0, max_area=4.0), "min_area 9 exceeds max_area 4", None),
        (lambda: DetectSettings(start=4, end=2), "end (2) must come after start (4)", ("end", "start")),
        (lambda: DetectSettings(roi=(1.0, 2.0, -3.0)), "roi circle needs finite X,Y and a radius > 0", ("roi",)),
        (lambda: LinkSettings(max_speed=-1.0), "max_speed must be a positive finite number, got -1", ("max_speed",)),
        (lambda: LinkSettings(fixed_count=True, max_gap=2), "max_gap does not apply with fixed_count", ("max_gap", "fixed_count")),
        (lambda: LinkSettings(algorithm="goa-updown-fixed", max_gap=0), "max_gap only apply to algorithm goa-updown", ("max_gap", "algorithm")),
        (lambda: LinkSettings(individual_model="persistent"), "individual_model must be one of im1, im2, im3", ("individual_model",)),
        (lambda: EvaluateSettings(format="xls"), "format must be one of csv, geff, isbi, mot, napari, trackmate, trackpy", ("format",)),
        (lambda: RenderSettings(fps=0.0), "fps must be at least 0.01", ("fps",)),
    ],
)
def test_a_setting_that_makes_no_sense_is_named(settings, message, names):
    with pytest.raises(OptionError) as raised:
        settings()
    assert str(raised.value).startswith(message)
    if names is not None:
        assert raised.value.names == names


def test_the_command_line_names_the_option_once_and_leaves_the_same_word_in_the_text():
    assert in_option_names("frame must be a 0-based frame index >= 0, got -1", ["frame"]) == "--frame must be a 0-based frame index >= 0, got -1"
    assert in_option_names("min_area 9 exceeds max_area 4", ["min_area", "max_area"]) == "--min-area 9 exceeds --max-area 4"


def test_settings_hold_what_the_stage_reads():
    detect = DetectSettings(threshold="25", roi="160,120,90", min_area=6)
    assert detect.roi == Circle(160.0, 120.0, 90.0) and detect.options.threshold == 25.0 and detect.options.min_area_px == 6
    assert DetectSettings(threshold=25, roi=(160, 120, 90), min_area=6) == detect
    fixed = LinkSettings(fixed_count=True).tracking()
    assert fixed.lifecycle is None and LinkSettings(algorithm="goa-updown-fixed").tracking().lifecycle is None
    assert LinkSettings(max_gap=4).tracking().lifecycle.max_gap == 4


def test_the_default_link_cost_is_built_from_the_model_registry(monkeypatch):
    assert INDIVIDUAL_MODELS["persistent"] is PersistentModel
    # Whatever model is registered under the name is the one a default run links with.
    monkeypatch.setitem(INDIVIDUAL_MODELS, "persistent", PersistentModel)
    built = []

    class Counted(PersistentModel, key="persistent"):
        def __post_init__(self) -> None:
            built.append(self)
            super().__post_init__()

    frames, _ = generate_walkers(WalkerSpec(walkers=40, frames=6, size=200.0, random_seed=3))
    _, fit = link_goa(frames)
    assert built and isinstance(fit.config.individual, Counted)
