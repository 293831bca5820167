"""Detectors: a frame (numpy array) in, a table of measurements out; nothing here knows of tracking or files.

Submodules are imported on first use as attributes (``seedtrack.detection.<module>``), as by
``import seedtrack.detection.<module>``; see :mod:`seedtrack` for what each holds.
"""

import importlib


def __getattr__(name: str):
    if not name.startswith("_"):
        try:
            return importlib.import_module(f"{__name__}.{name}")
        except ModuleNotFoundError as error:
            if error.name != f"{__name__}.{name}":
                raise
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
