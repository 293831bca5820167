"""Errors the command line reports in one line with exit status 2."""

from __future__ import annotations

import argparse
import os
from pathlib import Path


class UsageError(Exception):
    """Options that make no sense together or on their own."""


def option_name(field: str) -> str:
    """The command-line option of a setting: ``min_area_px`` is ``--min-area``, ``max_speed`` is ``--max-speed``."""
    return "--" + field.removesuffix("_px").replace("_", "-")


def output_file(text: str) -> Path:
    """The ``type`` of an option naming an output file: a name ending in a slash names a folder,
    and writing a file of the folder's name instead would surprise."""
    if text.endswith(("/", os.sep)):
        raise argparse.ArgumentTypeError(f"{text} names a folder; give a file name")
    return Path(text)
