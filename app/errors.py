"""Errors the command line reports in one line with exit status 2."""

from __future__ import annotations

import argparse
import os
import re
from pathlib import Path
from typing import Iterable


class UsageError(Exception):
    """Options that make no sense together or on their own."""


class OptionError(ValueError):
    """A setting that makes no sense, alone or with another (see :mod:`seedtrack.settings`); the
    command line reports it with the options' names (``max_speed`` as ``--max-speed``).

    Attributes
    ----------
    names : tuple of str
        The settings the message names, by their Python names.
    """

    def __init__(self, message: str, *names: str) -> None:
        super().__init__(message)
        self.names = names


def option_name(field: str) -> str:
    """The command-line option of a setting: ``min_area_px`` is ``--min-area``, ``max_speed`` is ``--max-speed``."""
    return "--" + field.removesuffix("_px").replace("_", "-")


def output_file(text: str) -> Path:
    """The ``type`` of an option naming an output file: a name ending in a slash names a folder,
    and writing a file of the folder's name instead would surprise."""
    if text.endswith(("/", os.sep)):
        raise argparse.ArgumentTypeError(f"{text} names a folder; give a file name")
    return Path(text)


def in_option_names(message: str, fields: Iterable[str]) -> str:
    """A library's message about its settings (``bad DishSpec: hidden_probability must be in
    [0, 1]``) in the command's words (``--hidden-probability must be in [0, 1]``).

    Only the first mention of each is the setting: later ones are words of the message.

    Example
    -------
    >>> in_option_names("bad DishSpec: rim_speed must be >= 0", ["rim_speed", "seeds"])
    '--rim-speed must be >= 0'
    >>> in_option_names("frame must be a 0-based frame index", ["frame"])
    '--frame must be a 0-based frame index'
    """
    # Longest names first, so that background_size is not read as background.
    names = re.compile(r"\b(" + "|".join(sorted(map(re.escape, fields), key=len, reverse=True)) + r")\b")
    seen: set[str] = set()

    def first_as_option(match: re.Match) -> str:
        name = match.group(1)
        if name in seen:
            return name
        seen.add(name)
        return option_name(name)

    return names.sub(first_as_option, re.sub(r"^bad \w+: ", "", message))
