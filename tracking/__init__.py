"""GOA-updown and the comparison trackers: positions per frame in, tracks out; numpy and scipy only.

Submodules are imported on first use as attributes (``seedtrack.tracking.<module>``), as by
``import seedtrack.tracking.<module>``; see :mod:`seedtrack` for what each holds.
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
