"""Readers, writers and generators: clips, track files, CSV tables, synthetic scenes with ground truth.

Submodules are imported on first use as attributes (``seedtrack.data.<module>``), as by
``import seedtrack.data.<module>``; see :mod:`seedtrack` for what each holds.
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
