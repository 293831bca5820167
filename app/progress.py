"""Progress bars for loops over frames, shown on a terminal and silent in logs."""

from __future__ import annotations

from tqdm import tqdm


def progress_bar(total: int | None, description: str, unit: str = "frame") -> tqdm:
    """A tqdm bar on standard error; hidden when standard error is not a terminal."""
    return tqdm(total=total, desc=description, unit=unit, disable=None, leave=False, dynamic_ncols=True)
