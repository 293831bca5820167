"""What the stages after detection are asked to do, as frozen dataclasses that check themselves.

:class:`LinkSettings`, :class:`EvaluateSettings` and :class:`RenderSettings` hold the options of
``seedtrack track``, ``evaluate`` and ``render`` under the same names (``--max-speed`` is
``max_speed``) with the same defaults, as :class:`seedtrack.pipeline.DetectSettings` holds those
of ``seedtrack detect`` (kept there so that tracking loads no detection code). The Python API
(:mod:`seedtrack.api`) builds them from its keywords, the commands from their parsed arguments;
either way an option that makes no sense is an :class:`~seedtrack.errors.OptionError` (a
ValueError) naming it.
"""

from __future__ import annotations

import dataclasses
import math
import os
from dataclasses import dataclass
from pathlib import Path

from seedtrack.data.numbers import MAX_COORDINATE_PX
from seedtrack.data.trackfile import FORMATS
from seedtrack.tracking.goa import GOAConfig
from seedtrack.tracking.lifecycle import LifecycleConfig
from seedtrack.tracking.linking import GOA_FAMILY
from seedtrack.tracking.motion import COMBINED_MODELS, INDIVIDUAL_MODELS, CombinedModel, IndividualModel
from seedtrack.tracking.regime import MOTIONS
from seedtrack.tracking.trackers import TRACKERS

from .errors import OptionError
from .points import TrackingSettings

__all__ = ["OptionError", "LinkSettings", "INDIVIDUAL_CHOICES", "COMBINED_CHOICES", "EvaluateSettings", "RenderSettings", "FIRST_LINKS", "check_tolerance"]


# How a pass starts: our default, the paper's first links alone, and the paper's whole scheme.
FIRST_LINKS = {
    "lookahead": {},
    "nearest": {"initialisation": "im1"},
    "paper": {"initialisation": "im1", "restart_lost": False},
}
# Options that only the GOA family reads; the other trackers refuse them rather than ignore them.
_GOA_ONLY = ("individual_model", "combined_model", "min_speed", "first_links")
# The largest value of a limit that still limits, and why.
_LARGEST = {
    "phi_max": (1.1, "IM2's smoothness cost lies in 0..1.1; a larger limit admits every link"),
    "max_speed": (MAX_COORDINATE_PX, "no point moves farther than the largest coordinate read"),
    "min_speed": (MAX_COORDINATE_PX, "no point moves farther than the largest coordinate read"),
}
_DEFAULT_PHI_MAX = GOAConfig().phi_max


def _by_name(registry: dict[str, type]) -> tuple[str, ...]:
    """The registered models that a name alone builds (the persistent model needs the
    statistics a first pass measures)."""
    return tuple(
        name
        for name, model in registry.items()
        if all(f.default is not dataclasses.MISSING or f.default_factory is not dataclasses.MISSING for f in dataclasses.fields(model))
    )


# What --individual-model and --combined-model choose from.
INDIVIDUAL_CHOICES = _by_name(INDIVIDUAL_MODELS)
COMBINED_CHOICES = _by_name(COMBINED_MODELS)


@dataclass(frozen=True)
class LinkSettings:
    """What the tracker is asked to do: the options of ``seedtrack track`` (``run``, ``demo``
    and ``batch`` take all but the GOA-only ones).

    Attributes
    ----------
    algorithm : str
        "goa-updown" (tracks open and end anywhere), "goa-updown-fixed" (the paper's fixed count
        of tracks), "goa" (one forward pass), or a comparison tracker: "nn", "ss", "rs", "ipan".
    max_speed : float or None
        Largest speed, pixels/frame; None: measured (``motion`` "auto").
    motion : {"auto", "smooth", "random"}
        Measure how the points move on a first pass, or say it.
    phi_max : float
        Largest smoothness cost of a link (IM2, 0..1.1), also the cost of a missed point.
    max_gap : int or None
        A track ends after this many missed frames in a row (None: 10).
    fixed_count : bool
        GOA-updown as published: one track per point of the first frame.
    min_length : int
        Tracks spanning fewer frames, gaps included, are dropped.
    individual_model, combined_model : str or None
        "im1", "im2", "im3"; "cm1", "cm2" (None: fitted to the motion, cm1).
    min_speed : float or None
        Smallest speed, pixels/frame.
    first_links : str, path or None
        "lookahead" (None), "nearest", "paper", or (algorithm "goa") a tracks file.

    Raises
    ------
    OptionError
        Naming the option that is out of range or that the algorithm does not read.

    Examples
    --------
    >>> LinkSettings(max_speed=8.0).tracking().config.d_max
    8.0
    >>> LinkSettings(algorithm="nn", min_speed=1.0)
    Traceback (most recent call last):
    ...
    seedtrack.errors.OptionError: min_speed only apply to algorithm goa or goa-updown, not nn
    """

    algorithm: str = "goa-updown"
    max_speed: float | None = None
    motion: str = "auto"
    phi_max: float = _DEFAULT_PHI_MAX
    max_gap: int | None = None
    fixed_count: bool = False
    min_length: int = 0
    individual_model: str | None = None
    combined_model: str | None = None
    min_speed: float | None = None
    first_links: str | os.PathLike | None = None

    def __post_init__(self) -> None:
        if self.algorithm not in ("goa", *TRACKERS):
            raise OptionError(f"algorithm must be one of {', '.join(('goa', *TRACKERS))}, got {self.algorithm!r}", "algorithm")
        if self.motion not in MOTIONS:
            raise OptionError(f"motion must be one of {', '.join(MOTIONS)}, got {self.motion!r}", "motion")
        for options, kind, allowed in ((("max_speed", "phi_max"), "a positive", lambda v: v > 0), (("min_speed",), "a non-negative", lambda v: v >= 0)):
            for name in options:
                value = getattr(self, name)
                if value is not None and not (math.isfinite(value) and allowed(value)):
                    raise OptionError(f"{name} must be {kind} finite number, got {value:g}", name)
                if value is not None and value > _LARGEST[name][0]:
                    largest, why = _LARGEST[name]
                    raise OptionError(f"{name} must be at most {largest:g} ({why}), got {value:g}", name)
        if self.min_speed is not None and self.max_speed is not None and self.min_speed >= self.max_speed:
            raise OptionError(f"min_speed ({self.min_speed:g}) must be below max_speed ({self.max_speed:g})", "min_speed", "max_speed")
        if self.algorithm not in GOA_FAMILY:
            given = [name for name in _GOA_ONLY if getattr(self, name) is not None]
            given += [name for name, default in (("phi_max", _DEFAULT_PHI_MAX), ("motion", "auto")) if getattr(self, name) != default]
            if given:
                raise OptionError(f"{', '.join(given)} only apply to algorithm goa or goa-updown, not {self.algorithm}", *given, "algorithm")
        if self.first_links_file is not None:
            text = os.fspath(self.first_links)
            if self.algorithm != "goa":
                if text.startswith("-") or not Path(text).suffix:
                    raise OptionError(f"first_links takes lookahead, nearest, paper or a tracks file, not {text!r}", "first_links")
                raise OptionError("first_links FILE only applies to algorithm goa (the single pass from given first links)", "first_links", "algorithm")
            if not Path(text).is_file():
                raise OptionError(f"first_links: {text}: no such file", "first_links")
        if self.algorithm != "goa-updown":
            # Options of the open GOA-updown (the default) alone.
            given = ["max_gap"] * (self.max_gap is not None) + ["fixed_count"] * bool(self.fixed_count)
            if given:
                raise OptionError(f"{', '.join(given)} only apply to algorithm goa-updown, not {self.algorithm}", *given, "algorithm")
        for name in ("max_gap", "min_length"):
            value = getattr(self, name)
            if value is not None and value < 0:
                raise OptionError(f"{name} must be a whole number of frames >= 0, got {value}", name)
        if self.fixed_count and self.max_gap is not None:
            raise OptionError("max_gap does not apply with fixed_count (no track ends)", "max_gap", "fixed_count")
        for name, choices in (("individual_model", INDIVIDUAL_CHOICES), ("combined_model", COMBINED_CHOICES)):
            if getattr(self, name) not in (None, *choices):
                raise OptionError(f"{name} must be one of {', '.join(choices)}, got {getattr(self, name)!r}", name)

    @property
    def first_links_file(self) -> Path | None:
        """The tracks file that gives the first links, if ``first_links`` names one."""
        if self.first_links is None or self.first_links in FIRST_LINKS:
            return None
        return Path(self.first_links)

    @property
    def fixed(self) -> bool:
        """Whether the count of tracks is the first frame's, none starting or ending later."""
        return self.fixed_count or self.algorithm == "goa-updown-fixed"

    def tracking(self) -> TrackingSettings:
        """The tracker's configuration before it is fitted to the motion (the first links of a
        file are read by :func:`seedtrack.points.link_points`, which has the points)."""
        options = {
            "individual": IndividualModel(self.individual_model or "im2"),
            "combined": CombinedModel(self.combined_model or "cm1"),
            "d_max": self.max_speed,
            "phi_max": self.phi_max,
            **FIRST_LINKS[self.first_links if self.first_links in FIRST_LINKS else "lookahead"],
        }
        if self.min_speed is not None:
            options["d_min"] = self.min_speed
        lifecycle = None if self.fixed else LifecycleConfig() if self.max_gap is None else LifecycleConfig(max_gap=self.max_gap)
        return TrackingSettings(self.algorithm, GOAConfig(**options), lifecycle, self.motion, self.individual_model is not None, self.min_length)


def check_tolerance(tol: float) -> None:
    """Refuse a matching distance that is not a positive finite number of pixels.

    Raises
    ------
    OptionError
    """
    if not (tol > 0 and math.isfinite(tol)):
        raise OptionError(f"tol must be a positive number of pixels, got {tol:g}", "tol")


def _check_format(name: str, value: str | None) -> None:
    if value is not None and value not in FORMATS:
        raise OptionError(f"{name} must be one of {', '.join(sorted(FORMATS))}, got {value!r}", name)


@dataclass(frozen=True)
class EvaluateSettings:
    """How tracks are scored against the truth: the options of ``seedtrack evaluate``.

    Attributes
    ----------
    tol : float
        Matching distance, pixels.
    format, truth_format : str or None
        Formats of the two track files (:data:`seedtrack.data.trackfile.FORMATS`); None: from
        the extension and contents.

    Examples
    --------
    >>> EvaluateSettings(tol=0)
    Traceback (most recent call last):
    ...
    seedtrack.errors.OptionError: tol must be a positive number of pixels, got 0
    """

    tol: float = 3.0
    format: str | None = None
    truth_format: str | None = None

    def __post_init__(self) -> None:
        check_tolerance(self.tol)
        _check_format("format", self.format)
        _check_format("truth_format", self.truth_format)


# Beyond what any player shows, or GIF's 1/100 s frame delays can hold.
_MAX_FPS = 1000
# A GIF holds a frame's delay as a 16-bit count of hundredths of a second (at most 655 s), and a
# rate near zero overflowed it; one frame per 100 s is slower than anyone plays a clip.
_MIN_FPS = 0.01


@dataclass(frozen=True)
class RenderSettings:
    """Which frames are drawn and how: the options ``seedtrack render`` and ``compare`` share,
    as :func:`seedtrack.render` takes them (``start``, ``end``, ``step``, ``frame``: 0-based
    frames; ``trail``: positions; ``crop``: "x0,y0,x1,y1" in pixels; ``fps``: None for the
    clip's).

    Examples
    --------
    >>> RenderSettings(step=0)
    Traceback (most recent call last):
    ...
    seedtrack.errors.OptionError: step must be at least 1, got 0
    """

    start: int = 0
    end: int | None = None
    step: int = 1
    frame: int | None = None
    trail: int = 10
    labels: bool = True
    scale: float = 1.0
    crop: str | None = None
    fps: float | None = None

    def __post_init__(self) -> None:
        for name in ("start", "end", "frame"):
            value = getattr(self, name)
            if value is not None and value < 0:
                raise OptionError(f"{name} must be a 0-based frame index >= 0, got {value}", name)
        if self.step < 1:
            raise OptionError(f"step must be at least 1, got {self.step}", "step")
        if self.trail < 0:
            raise OptionError(f"trail must be >= 0, got {self.trail}", "trail")
        if self.fps is not None and not _MIN_FPS <= self.fps <= _MAX_FPS:
            raise OptionError(f"fps must be at least {_MIN_FPS:g} and at most {_MAX_FPS} frames per second, got {self.fps:g}", "fps")
