"""Cores and memory of ``seedtrack run``: how much of two cores it uses, and whether a long clip
runs in the memory of a short one.

Run as ``python tests/benchmarks/bench_parallel.py [--quick]``. Prints, for a generated 300-frame
640x512 dish clip:

- ``run``'s CPU time over its wall time, with ``--workers 1`` and with the default (every core);
  the CPU time is that of the command and every process it starts (they are reaped here, this
  process being their subreaper);
- its frames per second beside decoding the clip alone;

and, for generated 128x128 clips of 2,000 and 20,000 frames with 6 seeds, ``run``'s peak memory
(``--workers 1``, one process: its maximum resident set) and their ratio (the goal: at most 1.2).
``--quick`` skips the 20,000-frame clip, ``--memory-only`` the 300-frame clip, and ``--repeats N``
measures each long clip N times and prints the median of each and of their ratio. Wall times on a shared machine include what other
programs take; run it when the machine is quiet, and read the CPU times beside them.
"""

from __future__ import annotations

import argparse
import ctypes
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from seedtrack.data.dish import DishSpec, write_dish_clip
from seedtrack.data.frames import open_frames
from seedtrack.parallel import default_workers

_PR_SET_CHILD_SUBREAPER = 36


def become_subreaper() -> None:
    """Orphaned descendants (the fork server of ``run``'s workers) are reparented to this
    process, so that their CPU time reaches ``RUSAGE_CHILDREN`` when they are reaped here."""
    ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0)


def reap_all() -> None:
    """Wait for every descendant left, so that its times are counted."""
    while True:
        try:
            os.waitpid(-1, 0)
        except ChildProcessError:
            return


def measured(command: list[str]) -> tuple[float, float, int]:
    """Wall seconds, CPU seconds (user + system, the command and all it started), and the peak
    resident set in kB of the largest single process, for ``command``."""
    reap_all()
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    reap_all()
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, after.ru_maxrss


def peak_memory(clip: Path, out: Path) -> int:
    """Peak resident set (kB) of ``seedtrack run --workers 1`` in a fresh process (the
    children's maximum is that of the largest process ever reaped, so each run is measured in a
    process of its own)."""
    probe = (
        "import resource, subprocess, sys\n"
        "subprocess.run(sys.argv[1:], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)\n"
        "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)\n"
    )
    command = [sys.executable, "-c", probe, *seedtrack("run", clip, "--out", out, "--workers", "1")]
    return int(subprocess.run(command, check=True, capture_output=True, text=True).stdout)


def seedtrack(*args) -> list[str]:
    return [sys.executable, "-m", "seedtrack", *map(str, args)]


def decode_seconds(clip: Path) -> float:
    start = time.perf_counter()
    with open_frames(clip) as source:
        for _ in source:
            pass
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="skip the 20,000-frame clip")
    parser.add_argument("--memory-only", action="store_true", help="skip the 300-frame clip (cores and frames/s)")
    parser.add_argument("--repeats", type=int, default=1, metavar="N", help="peak memory measurements per long clip (default 1)")
    args = parser.parse_args()
    become_subreaper()
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        if not args.memory_only:
            cores(folder)
        long_clips(folder, (2_000,) if args.quick else (2_000, 20_000), args.repeats)


def cores(folder: Path) -> None:
    """CPU over wall time and frames/s of ``run`` on a 300-frame 640x512 clip."""
    clip = folder / "dish" / "clip.mp4"
    write_dish_clip(DishSpec(seeds=80, frames=300, width=640, height=512, rim_speed=20.0), clip.parent)
    decode = min(decode_seconds(clip) for _ in range(2))
    print(f"300 frames, 640x512, 80 seeds; {default_workers()} cores usable; load average {os.getloadavg()[0]:.1f}")
    print(f"decoding alone: {300 / decode:.0f} frames/s")
    print("| workers | wall, s | CPU, s | CPU / wall | frames/s | of decoding's |")
    print("| --- | --- | --- | --- | --- | --- |")
    for workers in ("1", str(default_workers())):
        wall, cpu, _ = measured(seedtrack("run", clip, "--out", folder / f"run{workers}", "--workers", workers))
        print(f"| {workers} | {wall:.1f} | {cpu:.1f} | {cpu / wall:.2f} | {300 / wall:.0f} | {decode / wall:.0%} |")
    same = all((folder / "run1" / name).read_bytes() == (folder / f"run{default_workers()}" / name).read_bytes() for name in ("detections.csv", "tracks.csv", "overlay.mp4"))
    print(f"files identical for 1 and {default_workers()} workers: {same}")


def long_clips(folder: Path, lengths: tuple[int, ...], repeats: int) -> None:
    """Peak memory of ``run`` on 6-seed clips of each length, ``repeats`` times (one run of each
    length after the other, so that a ratio compares runs made under the same load)."""
    clips = {}
    for frames in lengths:
        clips[frames] = folder / f"long{frames}" / "clip.mp4"
        write_dish_clip(DishSpec(seeds=6, frames=frames, width=128, height=128, rim_speed=4.0), clips[frames].parent)
    peaks = {frames: [] for frames in lengths}
    ratios = []
    for repeat in range(repeats):
        for frames in lengths:
            peaks[frames].append(peak_memory(clips[frames], folder / f"outlong{frames}"))
            print(f"{frames:,} frames, 128x128, 6 seeds: peak resident memory {peaks[frames][-1] / 1024:.0f} MB")
        if len(lengths) == 2:
            ratios.append(peaks[lengths[1]][-1] / peaks[lengths[0]][-1])
            print(f"{lengths[1]:,} frames / {lengths[0]:,} frames: {ratios[-1]:.2f} x (goal <= 1.2)")
    if repeats > 1:
        medians = ", ".join(f"{frames:,} frames {statistics.median(peaks[frames]) / 1024:.0f} MB" for frames in lengths)
        ratio = f"; ratio {statistics.median(ratios):.2f} x (of {min(ratios):.2f} to {max(ratios):.2f})" if ratios else ""
        print(f"median of {repeats}: {medians}{ratio}")


if __name__ == "__main__":
    main()
