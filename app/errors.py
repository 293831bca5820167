"""Errors the command line reports in one line with exit status 2."""


class UsageError(Exception):
    """Options that make no sense together or on their own."""
