"""Hypothesis profiles: derandomised in CI (env CI set), so that a run there draws the same
examples every time; ``SEEDTRACK_FUZZ_EXAMPLES`` sets the examples of the fuzz suite for a
longer run (tests/benchmarks/fuzz_long.py)."""

import os

from hypothesis import settings

# CI must not pass or fail by the luck of the draw: a derandomised profile replays the same
# examples each run (seeded from each test's name); elsewhere Hypothesis keeps exploring.
settings.register_profile("ci", derandomize=True, deadline=None, print_blob=True)
settings.register_profile("dev", deadline=None)
settings.load_profile("ci" if os.environ.get("CI") else "dev")
