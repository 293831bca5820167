"""Reading a points file: seedtrack's read_table against pandas.read_csv (issue 14).

Writes a 200,000-row points file (frame, x, y, area; 200 frames of 1,000 points) to a temporary
folder and prints the median CPU time of each reader over ``--repeat`` runs.

    python tests/benchmarks/bench_csv.py
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from seedtrack.data.csvio import read_table, write_table


def cpu(function) -> float:
    start = time.process_time()
    function()
    return time.process_time() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=200_000)
    parser.add_argument("--repeat", type=int, default=5)
    options = parser.parse_args()
    rng = np.random.default_rng(0)
    n = options.rows
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "points.csv"
        columns = {"frame": np.arange(n) // 1000, "x": rng.uniform(0, 1000, n), "y": rng.uniform(0, 1000, n), "area": rng.uniform(1, 50, n)}
        write_seconds = cpu(lambda: write_table(path, columns))
        ours = statistics.median(cpu(lambda: read_table(path, required=("frame", "x", "y"))) for _ in range(options.repeat))
        theirs = statistics.median(cpu(lambda: pd.read_csv(path)) for _ in range(options.repeat))
    print(f"{n} rows: read_table {ours:.3f} s CPU, pandas.read_csv {theirs:.3f} s ({ours / theirs:.1f}x); write_table {write_seconds:.3f} s")


if __name__ == "__main__":
    main()
