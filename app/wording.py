"""Counts in the messages people read."""

from __future__ import annotations


def counted(count: int, noun: str, plural: str | None = None) -> str:
    """``"1 frame"``, ``"3 frames"``: the count and the noun, plural (``noun + "s"`` unless
    given) when the count is not one."""
    return f"{count} {noun}" if count == 1 else f"{count} {plural or noun + 's'}"


# What every command's INPUT may be: open_frames (data/frames.py) reads all of them.
CLIP_INPUT_HELP = "video file, TIFF stack (multi-page .tif), image folder or glob pattern such as 'frames/*.png'"
