"""The fuzz suite's longer run, for before a release: at least 10,000 examples (issue 18).

Runs tests/test_fuzz.py with ``SEEDTRACK_FUZZ_EXAMPLES`` (default 10,200, shared among the
commands by the weights in the suite) and Hypothesis' statistics, then prints the examples each
command ran and the total. Exit status is pytest's.

    python tests/benchmarks/fuzz_long.py [--examples N] [--seed S]
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    # Shared by weight, and some commands have fewer distinct inputs than their share
    # (experiment: 24), so a little above 10,000 is asked for to run at least 10,000.
    parser.add_argument("--examples", type=int, default=10_200)
    parser.add_argument("--seed", type=int, default=None, help="hypothesis seed (default: random)")
    options = parser.parse_args()
    env = {**os.environ, "SEEDTRACK_FUZZ_EXAMPLES": str(options.examples)}
    env.pop("CI", None)  # a long run explores; CI's profile replays the same examples
    command = [sys.executable, "-m", "pytest", "-q", "-p", "no:xdist", "-p", "no:cacheprovider", "tests/test_fuzz.py", "--hypothesis-show-statistics"]
    if options.seed is not None:
        command.append(f"--hypothesis-seed={options.seed}")
    result = subprocess.run(command, cwd=ROOT, env=env, capture_output=True, text=True)
    total = 0
    # Statistics blocks: "tests/test_fuzz.py::test_track:", then per phase "- N passing, M failing, and K invalid test cases"
    for block in re.split(r"\n(?=tests/test_fuzz\.py::)", result.stdout):
        name = re.match(r"tests/test_fuzz\.py::(\w+)", block)
        if not name:
            continue
        passing = sum(int(n) for n in re.findall(r"(\d+) passing", block))
        total += passing
        print(f"{name.group(1):20s} {passing:6d} examples")
    print(f"{'total':20s} {total:6d} examples; pytest: {result.stdout.strip().splitlines()[-1] if result.stdout.strip() else result.stderr[-500:]}")
    if result.returncode:
        print(result.stdout[-6000:])
    return result.returncode


if __name__ == "__main__":
    raise SystemExit(main())
