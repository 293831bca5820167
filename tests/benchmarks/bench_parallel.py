"""Cores and memory of ``seedtrack run``: how much of two cores it uses, and whether a long clip
runs in the memory of a short one.

Run as ``python tests/benchmarks/bench_parallel.py [--quick]``. Prints, for a generated 300-frame
640x512 dish clip:

- in turns (decoding alone, ``run --workers 1``, ``run --workers 2``), each one's wall time (and
  ``run``'s CPU time, the command's and every process it starts: they are reaped here, this
  process being their subreaper), the load average, each turn's ratios (``run`` over decoding
  the clip alone as a whole process, imports included; 2 workers over 1) and their medians, and
  whether the files of 1 and 2 workers are the same byte for byte (``--write-docs`` writes that
  table into docs/batch.md);

and, for generated 128x128 clips of 2,000 and 20,000 frames with 6 seeds, ``run``'s peak memory
(``--workers 1``, one process: its maximum resident set) and their ratio (the goal: at most 1.2).
``--quick`` skips the 20,000-frame clip, ``--memory-only`` the 300-frame clip, ``--speed-only``
the long clips, and ``--repeats N``
runs the 300-frame clip N times with each number of workers (in turns) and measures each long
clip N times, and prints the median of each figure and of the ratios. ``--phases``
prints instead, for decoding the 300-frame clip alone (imports, then decoding), ``run --workers
1`` and ``--workers 2`` of it (in turns, N of each), each phase's wall time and the CPU time of
every thread and of the processes it starts (read from /proc every 20 ms), with the wall time two
free cores would need at least: the larger of half the phase's CPU time and its busiest thread's;
then that least wall time of each whole and the ratios (each ``run`` over decoding, 2 workers
over 1), turn by turn. The imports phase is ``run``'s own
beside the fork server's (with 2 workers), started
first as ``run`` starts it. CPU times change little with the load, so on a
busy machine that bound says what the wall time alone cannot. Wall times on a shared machine include what other
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
from tables import markdown_table, write_table

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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="skip the 20,000-frame clip")
    parser.add_argument("--memory-only", action="store_true", help="skip the 300-frame clip (cores and frames/s)")
    parser.add_argument("--speed-only", action="store_true", help="skip the long clips (peak memory)")
    parser.add_argument("--repeats", type=int, default=1, metavar="N", help="runs of the 300-frame clip per number of workers, and peak memory measurements per long clip (default 1)")
    parser.add_argument("--phases", action="store_true", help="CPU time of every thread and process, phase by phase, of runs with 1 and 2 workers")
    parser.add_argument("--write-docs", action="store_true", help="write the speed and memory tables (with --phases: the least wall times) into docs/batch.md, stamped")
    args = parser.parse_args()
    become_subreaper()
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        if args.phases:
            phases(folder, args.repeats, args.write_docs)
            return
        if not args.memory_only:
            cores(folder, args.repeats, args.write_docs)
        if not args.speed_only:
            header, rows = long_clips(folder, (2_000,) if args.quick else (2_000, 20_000), args.repeats)
            if args.write_docs and not args.quick:  # the table is the ratio of the long clip to the short
                write_table("batch.md", "run-memory", header, rows)


# Decoding the clip alone, as a whole process, as `run` decodes it (imports included).
_DECODE = "import sys\nfrom seedtrack.data.frames import open_frames\nwith open_frames(sys.argv[1]) as frames:\n    for _ in frames:\n        pass\n"
SPEED_HEADER = [
    "turn", "load average", "decoding alone, s", "`--workers 1` wall, s (CPU)", "`--workers 2` wall, s (CPU)",
    "workers 1 / decoding", "workers 2 / decoding", "workers 2 / workers 1",
]


def cores(folder: Path, repeats: int, write_docs: bool = False) -> None:
    """Wall and CPU time of ``run`` on a 300-frame 640x512 clip with 1 and 2 workers beside
    decoding the clip alone, in turns (decoding, 1, 2; ``repeats`` turns), each turn's ratios and
    their medians; ``write_docs`` writes the table into docs/batch.md."""
    clip = folder / "dish" / "clip.mp4"
    write_dish_clip(DishSpec(seeds=80, frames=300, width=640, height=512, rim_speed=20.0), clip.parent)
    print(f"300 frames, 640x512, 80 seeds; {os.cpu_count()} cores; {repeats} turns of decoding alone, run --workers 1, run --workers 2")
    turns = []
    for _ in range(repeats):
        load = os.getloadavg()[0]
        decode, _, _ = measured([sys.executable, "-c", _DECODE, str(clip)])
        runs = {workers: measured(seedtrack("run", clip, "--out", folder / f"run{workers}", "--workers", workers))[:2] for workers in ("1", "2")}
        turns.append((load, decode, runs["1"], runs["2"]))
        print(f"load {load:.1f}: decoding {decode:.2f} s, workers 1 {runs['1'][0]:.2f} s, workers 2 {runs['2'][0]:.2f} s", flush=True)
    rows = [
        [str(number), f"{load:.1f}", f"{decode:.2f}", f"{one[0]:.2f} ({one[1]:.2f})", f"{two[0]:.2f} ({two[1]:.2f})",
         f"{one[0] / decode:.2f}", f"{two[0] / decode:.2f}", f"{two[0] / one[0]:.2f}"]
        for number, (load, decode, one, two) in enumerate(turns, 1)
    ]
    loads, decodes, ones, twos = zip(*turns)
    median = statistics.median
    rows.append([
        f"median of {repeats}", f"{median(loads):.1f}", f"{median(decodes):.2f}",
        f"{median(w for w, _ in ones):.2f} ({median(c for _, c in ones):.2f})", f"{median(w for w, _ in twos):.2f} ({median(c for _, c in twos):.2f})",
        f"{median(o[0] / d for d, o in zip(decodes, ones)):.2f}", f"{median(t[0] / d for d, t in zip(decodes, twos)):.2f}",
        f"**{median(t[0] / o[0] for o, t in zip(ones, twos)):.2f}**",
    ])
    print(markdown_table(SPEED_HEADER, rows))
    same = all((folder / "run1" / name).read_bytes() == (folder / "run2" / name).read_bytes() for name in ("detections.csv", "tracks.csv", "overlay.mp4"))
    print(f"files identical for 1 and 2 workers: {same}")
    if write_docs:
        write_table("batch.md", "run-speed", SPEED_HEADER, rows + [["files identical for 1 and 2 workers", str(same), "", "", "", "", "", ""]])


_PHASES = """
import os, sys, threading, time
from pathlib import Path

TICK = os.sysconf("SC_CLK_TCK")
ME = os.getpid()
seen, marks, lock = {}, [], threading.Lock()
# The sampling thread's own time (reading /proc, about 5% of a core) is not the measured program's.
SAMPLER = []


def descendants():
    children = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                children.setdefault(int(open(f"/proc/{entry}/stat").read().rsplit(")", 1)[1].split()[1]), []).append(int(entry))
            except OSError:
                pass
    found, todo = [], [ME]
    while todo:
        found.append(todo.pop())
        todo += children.get(found[-1], [])
    return found


def sample():
    with lock:
        for pid in descendants():
            try:
                threads = os.listdir(f"/proc/{pid}/task")
            except OSError:
                continue
            for tid in threads:
                if pid == ME and int(tid) in SAMPLER:
                    continue
                try:
                    fields = open(f"/proc/{pid}/task/{tid}/stat").read().rsplit(")", 1)[1].split()
                except OSError:
                    continue
                seen[(pid, int(tid))] = (int(fields[11]) + int(fields[12])) / TICK


def sampler():
    SAMPLER.append(threading.get_native_id())
    while True:
        sample()
        time.sleep(0.02)


def mark(name):
    sample()
    with lock:
        marks.append((name, time.perf_counter(), dict(seen)))


def marked(name, function):
    def call(*args, **kwargs):
        mark(name)
        return function(*args, **kwargs)
    return call


def decode_alone(path):
    mark("imports")
    from seedtrack.data.frames import open_frames
    mark("decoding")
    with open_frames(path) as frames:
        for _ in frames:
            pass


if __name__ == "__main__":
    threading.Thread(target=sampler, daemon=True).start()
    mark("")
    if sys.argv[2] == "decode":
        decode_alone(Path(sys.argv[1]))
        mark("end")
        for (name, start, before), (_, end, after) in zip(marks[1:], marks[2:]):
            spent = sorted((after[key] - before.get(key, 0.0) for key in after), reverse=True)
            print("phase", name, end - start, sum(spent), *spent[:3])
        sys.exit()
    mark("imports")
    workers = int(sys.argv[3])
    # As `seedtrack run` does before its imports, with more than one worker.
    from seedtrack.processes import start_fork_server
    if workers > 1:
        start_fork_server()
    import seedtrack.pipeline as pipeline
    pipeline.detect_clip = marked("detection", pipeline.detect_clip)
    pipeline.track_frames = marked("tracking", pipeline.track_frames)
    pipeline._render = marked("overlay", pipeline._render)
    pipeline.run_pipeline(Path(sys.argv[1]), Path(sys.argv[2]), workers=workers)
    time.sleep(0.1)  # the encoder's last CPU time is read before it is reaped
    mark("end")
    for (name, start, before), (_, end, after) in zip(marks[1:], marks[2:]):
        spent = sorted((after[key] - before.get(key, 0.0) for key in after), reverse=True)
        print("phase", name, end - start, sum(spent), *spent[:3])
"""


PHASES_HEADER = [
    "turn", "load average", "decoding alone: least wall on two free cores, s", "`--workers 1`: the same, s", "`--workers 2`: the same, s",
    "workers 1 / decoding", "workers 2 / decoding", "workers 2 / workers 1",
]


def least_wall(command: list[str], title: str) -> float:
    """Run the phases script as ``command``, print its phases under ``title``, and return the
    least wall time two free cores would need for the whole (the sum over its phases)."""
    lines = subprocess.run(command, check=True, capture_output=True, text=True).stdout.splitlines()
    print(title)
    print("| phase | wall, s | CPU, s | busiest threads, CPU s | two free cores need at least, s |")
    print("| --- | --- | --- | --- | --- |")
    totals = [0.0, 0.0, 0.0]
    for line in (line for line in lines if line.startswith("phase ")):
        name, wall, cpu, *busiest = line.split()[1:]
        wall, cpu, busiest = float(wall), float(cpu), [float(value) for value in busiest]
        bound = max(cpu / 2, busiest[0])
        totals = [totals[0] + wall, totals[1] + cpu, totals[2] + bound]
        print(f"| {name} | {wall:.2f} | {cpu:.2f} | {', '.join(f'{value:.2f}' for value in busiest)} | {bound:.2f} |")
    print(f"| all | {totals[0]:.2f} | {totals[1]:.2f} | | {totals[2]:.2f} (CPU / that: {totals[1] / totals[2]:.2f}) |")
    return totals[2]


def phases(folder: Path, repeats: int, write_docs: bool = False) -> None:
    """Per phase of decoding the 300-frame clip alone, ``run --workers 1`` and ``--workers 2``,
    in turns: wall, CPU, busiest threads and the least wall time two free cores would need; then
    that least wall time of each, and each turn's ratios (``write_docs``: into docs/batch.md)."""
    clip = folder / "dish" / "clip.mp4"
    write_dish_clip(DishSpec(seeds=80, frames=300, width=640, height=512, rim_speed=20.0), clip.parent)
    script = folder / "phases.py"
    script.write_text(_PHASES)
    turns = []
    for _ in range(repeats):
        load = os.getloadavg()[0]
        decode = least_wall([sys.executable, str(script), str(clip), "decode"], f"decoding alone, 300 frames, 640x512; load average {os.getloadavg()[0]:.1f}")
        one, two = (
            least_wall([sys.executable, str(script), str(clip), str(folder / f"out{workers}"), str(workers)],
                       f"run --workers {workers}, 300 frames, 640x512, 80 seeds; load average {os.getloadavg()[0]:.1f}")
            for workers in (1, 2)
        )
        turns.append((load, decode, one, two))
    rows = [
        [str(number), f"{load:.1f}", f"{decode:.2f}", f"{one:.2f}", f"{two:.2f}", f"{one / decode:.2f}", f"{two / decode:.2f}", f"{two / one:.2f}"]
        for number, (load, decode, one, two) in enumerate(turns, 1)
    ]
    median = statistics.median
    loads, decodes, ones, twos = zip(*turns)
    rows.append([
        f"median of {repeats}", f"{median(loads):.1f}", f"{median(decodes):.2f}", f"{median(ones):.2f}", f"{median(twos):.2f}",
        f"{median(o / d for d, o in zip(decodes, ones)):.2f}", f"**{median(t / d for d, t in zip(decodes, twos)):.2f}**",
        f"**{median(t / o for o, t in zip(ones, twos)):.2f}**",
    ])
    print(markdown_table(PHASES_HEADER, rows))
    if write_docs:
        write_table("batch.md", "run-phases", PHASES_HEADER, rows)


def long_clips(folder: Path, lengths: tuple[int, ...], repeats: int) -> tuple[list[str], list[list[str]]]:
    """Peak memory of ``run`` on 6-seed clips of each length, ``repeats`` times (one run of each
    length after the other, so that a ratio compares runs made under the same load): the table's
    header and rows, the medians, the last with the ratio to the first (goal at most 1.2)."""
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
    rows = [[f"{frames:,}", f"{statistics.median(peaks[frames]) / 1024:.0f}"] for frames in lengths]
    if ratios:
        rows[-1][1] += f" (ratio {statistics.median(ratios):.2f} x, {min(ratios):.2f} to {max(ratios):.2f} over {repeats}; goal 1.2)"
    return ["frames, 128x128, 6 seeds", f"peak, MB (median of {repeats})"], rows


if __name__ == "__main__":
    main()
