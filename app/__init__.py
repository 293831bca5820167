"""seedtrack: track many small look-alike objects through video by motion alone (GOA-updown).

The four stages of ``seedtrack run`` as functions over pandas tables (see :mod:`seedtrack.api`)::

    points = seedtrack.detect("clip.mp4")        # frame, x, y, area, ... (detections.csv)
    tracks = seedtrack.link(points)              # track_id, frame, x, y, interpolated, ...
    scores = seedtrack.evaluate(tracks, truth)   # the scores `seedtrack evaluate` prints
    seedtrack.render("clip.mp4", tracks, "overlay.mp4")

Each stage's options are also a settings object that checks itself (``seedtrack.DetectSettings``,
``LinkSettings``, ``EvaluateSettings``, ``RenderSettings``; :mod:`seedtrack.settings`).

The parts they are made of, importable by these names:

- :mod:`seedtrack.detection`: ``clip`` (:class:`ClipDetector`, the once-per-clip decisions),
  ``blobs`` (:class:`BlobOptions`, ``detect_blobs``), ``spots``, ``roi``, ``background``.
- :mod:`seedtrack.tracking`: ``linking`` (:func:`link_goa`, GOA fitted to the motion, the path
  every command takes), ``goa`` (:class:`GOAConfig`, ``goa``, ``goa_updown``), ``lifecycle``
  (:class:`LifecycleConfig`), ``motion`` (:class:`IndividualModel`, :class:`CombinedModel`),
  ``regime`` (``choose_motion``), ``trackers`` (``run_tracker``, ``TRACKERS``: nn, ss, rs,
  ipan), ``tracks`` (:class:`Tracks`), ``evaluation`` (:class:`Scores`), ``metrics``,
  ``clear_mot``.
- :mod:`seedtrack.data`: ``frames`` (``open_frames``: read a clip), ``trackfile``
  (``read_tracks``, ``write_tracks``: csv, trackpy, MOT, TrackMate, ISBI), ``csvio``,
  ``dish``, ``psmg``, ``walkers`` (generators with ground truth).

The most used of them are also attributes of the package (``seedtrack.Tracks``,
``seedtrack.GOAConfig``, ``seedtrack.read_tracks``, ...). Everything is imported on first use,
so that ``seedtrack --help`` starts fast.
"""

from __future__ import annotations

import importlib
import importlib.metadata


def _version() -> str:
    try:
        return importlib.metadata.version("seedtrack")
    except importlib.metadata.PackageNotFoundError:
        # Run from a checkout that was never installed: the version pyproject.toml declares.
        import pathlib
        import tomllib

        pyproject = pathlib.Path(__file__).resolve().parent.parent / "pyproject.toml"
        with pyproject.open("rb") as file:
            return tomllib.load(file)["project"]["version"]


__version__ = _version()

# Name -> module that defines it, imported on first access (PEP 562).
_LAZY = {
    "detect": "seedtrack.api",
    "link": "seedtrack.api",
    "evaluate": "seedtrack.api",
    "render": "seedtrack.api",
    "msd": "seedtrack.analysis",
    "drift": "seedtrack.analysis",
    "velocity": "seedtrack.analysis",
    "Scores": "seedtrack.tracking.evaluation",
    "DetectSettings": "seedtrack.pipeline",
    "LinkSettings": "seedtrack.settings",
    "EvaluateSettings": "seedtrack.settings",
    "RenderSettings": "seedtrack.settings",
    "Tracks": "seedtrack.tracking.tracks",
    "GOAConfig": "seedtrack.tracking.goa",
    "LifecycleConfig": "seedtrack.tracking.lifecycle",
    "IndividualModel": "seedtrack.tracking.motion",
    "CombinedModel": "seedtrack.tracking.motion",
    "link_goa": "seedtrack.tracking.linking",
    "run_tracker": "seedtrack.tracking.trackers",
    "TRACKERS": "seedtrack.tracking.trackers",
    "BlobOptions": "seedtrack.detection.blobs",
    "ClipDetector": "seedtrack.detection.clip",
    "open_frames": "seedtrack.data.frames",
    "read_tracks": "seedtrack.data.trackfile",
    "write_tracks": "seedtrack.data.trackfile",
    "DataError": "seedtrack.data.errors",
}
_SUBPACKAGES = ("api", "settings", "detection", "tracking", "data", "pipeline", "cli")

__all__ = [*_LAZY, *_SUBPACKAGES]


def __getattr__(name: str):
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name]), name)
    elif name in _SUBPACKAGES:
        value = importlib.import_module(f"{__name__}.{name}")
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
