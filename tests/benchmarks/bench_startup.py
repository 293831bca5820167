"""CPU time of ``seedtrack --help`` and ``--version`` against ``python -c "import numpy"``.

Issue 14 asks for ``seedtrack --help`` within 3x the CPU time of importing numpy. Each command
is run ``--repeat`` times (default 7) and the median CPU time (user + system, from the child's
resource usage) is printed, with the ratio to numpy's.

    python tests/benchmarks/bench_startup.py
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import statistics
import subprocess
import sys


def cpu_seconds(command: list[str]) -> float:
    """User + system CPU time of one run of ``command``, seconds."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    repeat = parser.parse_args().repeat
    seedtrack = shutil.which("seedtrack", path=os.path.dirname(sys.executable)) or "seedtrack"
    commands = {
        'python -c "import numpy"': [sys.executable, "-c", "import numpy"],
        "seedtrack --help": [seedtrack, "--help"],
        "seedtrack --version": [seedtrack, "--version"],
        "seedtrack track --help": [seedtrack, "track", "--help"],
    }
    medians = {name: statistics.median(cpu_seconds(command) for _ in range(repeat)) for name, command in commands.items()}
    numpy = medians['python -c "import numpy"']
    for name, seconds in medians.items():
        print(f"{name:28s} {seconds * 1000:7.1f} ms CPU  ({seconds / numpy:.2f}x numpy's import)")


if __name__ == "__main__":
    main()
