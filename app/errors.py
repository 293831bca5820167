"""Errors the command line reports in one line with exit status 2."""


class UsageError(Exception):
    """Options that make no sense together or on their own."""


def option_name(field: str) -> str:
    """The command-line option of a setting: ``min_area_px`` is ``--min-area``, ``max_speed`` is ``--max-speed``."""
    return "--" + field.removesuffix("_px").replace("_", "-")
