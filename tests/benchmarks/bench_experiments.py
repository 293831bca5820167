"""Run every PSMG experiment at full size and print the summaries (not run in CI).

    python tests/benchmarks/bench_experiments.py [--runs N] [--jobs N] [--out DIR] [NAME ...]

Writes NAME.csv, NAME-summary.csv and NAME.png per experiment to DIR (default
experiments-out); this is what the README's plots and tables come from.
"""

from __future__ import annotations

import argparse
import sys
import time

from seedtrack.cli import main
from seedtrack.experiments import EXPERIMENTS


def run() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", default=list(EXPERIMENTS), metavar="NAME")
    parser.add_argument("--runs", type=int, default=100)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--out", default="experiments-out")
    args = parser.parse_args()
    for name in args.names:
        start = time.perf_counter()
        status = main(["experiment", name, "--out", args.out, "--runs", str(args.runs), "--jobs", str(args.jobs)])
        print(f"== {name}: exit {status}, {time.perf_counter() - start:.0f} s", flush=True)
        if status:
            return status
    return 0


if __name__ == "__main__":
    sys.exit(run())
