"""Shared test settings: Hypothesis draws the same examples on every CI run."""

import os

from hypothesis import settings

# CI must not pass or fail by the luck of the draw: a derandomised profile replays the same
# examples each run (seeded from each test's name); elsewhere Hypothesis keeps exploring.
settings.register_profile("ci", derandomize=True, deadline=None, print_blob=True)
if os.environ.get("CI"):
    settings.load_profile("ci")
