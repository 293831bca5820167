"""Counts in the messages people read."""


def counted(count: int, noun: str) -> str:
    """``"1 frame"``, ``"3 frames"``: the count and the noun, plural unless the count is one."""
    return f"{count} {noun}" if count == 1 else f"{count} {noun}s"
