"""``seedtrack experiment NAME --out DIR``: rerun one of the paper's PSMG experiments."""

from __future__ import annotations

import argparse
import math
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from seedtrack.data.atomic import output_folder
from seedtrack.data.csvio import write_table

from ..error_plot import draw_line_plot, write_png
from ..errors import UsageError
from ..experiments import EXPERIMENTS, PROTOCOLS, Experiment, Task, run_task, summarise, trackers_of
from ..processes import check_worker_count
from ..progress import progress_bar
from ..wording import counted

DEFAULT_RUNS = 100


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "experiment",
        description="Generate PSMG data, run every tracker (and trackpy/laptrack when installed) on it, and "
        "write DIR/NAME-PROTOCOL.csv (one row per run and tracker), DIR/NAME-PROTOCOL-summary.csv (means with 95% "
        "intervals) and DIR/NAME-PROTOCOL.png. Experiments: " + ", ".join(f"{e.name} ({e.title})" for e in EXPERIMENTS.values()) + ".",
    )
    parser.add_argument("name", choices=sorted(EXPERIMENTS), metavar="NAME", help="one of: " + ", ".join(EXPERIMENTS))
    parser.add_argument("--out", type=Path, required=True, metavar="DIR", help="output folder (created if missing)")
    parser.add_argument("--runs", type=int, default=DEFAULT_RUNS, metavar="N", help=f"runs per setting (default {DEFAULT_RUNS})")
    parser.add_argument("--jobs", type=int, default=1, metavar="N", help="worker processes (default 1)")
    parser.add_argument(
        "--protocol",
        choices=PROTOCOLS,
        default="self",
        help="self (default): every tracker initialises itself; given: every tracker is given the true links of "
        "frames 0 and 1, as in the paper's sweeps (its section 6)",
    )
    parser.add_argument(
        "--values",
        type=_values,
        default=None,
        metavar="X,X,...",
        help="run only these of the experiment's swept values (the same data as in the full sweep)",
    )
    parser.add_argument("--tiny", action="store_true", help="a few points over a few frames: a check that runs in seconds")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    if args.runs < 1:
        raise UsageError(f"--runs must be at least 1, got {args.runs}")
    check_worker_count("--jobs", args.jobs)
    experiment = EXPERIMENTS[args.name]
    trackers = trackers_of(experiment)
    cases = experiment.cases(args.tiny)
    chosen = _chosen_cases(cases, args.values)
    tasks = [Task(experiment.name, index, run, args.tiny, trackers, args.protocol) for run in range(args.runs) for index in chosen]
    stem = f"{experiment.name}-{args.protocol}"
    with output_folder(args.out):
        rows = _run_tasks(tasks, args.jobs, stem)
        timed = experiment.measure == "seconds"
        # Times differ from run to run; only the experiment that measures them writes them, so
        # every other output is the same byte for byte for the same options.
        write_table(args.out / f"{stem}.csv", _columns(rows, keep_seconds=timed))
        summary = summarise(experiment, rows, args.tiny)
        write_table(args.out / f"{stem}-summary.csv", _columns(summary, keep_seconds=timed))
        write_png(args.out / f"{stem}.png", _plot(experiment, summary, args.runs, args.protocol))
        for line in _report(experiment, summary):
            print(line)
    print(f"wrote {args.out / (stem + '.csv')}, {stem}-summary.csv and {stem}.png")
    return 0


def _values(text: str) -> tuple[float, ...]:
    try:
        return tuple(float(value) for value in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected numbers separated by commas, got {text!r}") from None


def _chosen_cases(cases: list, values: tuple[float, ...] | None) -> list[int]:
    """Indices of the cases whose swept value is among ``values`` (all without)."""
    if values is None:
        return list(range(len(cases)))
    unknown = [v for v in values if not any(math.isclose(v, case.x) for case in cases)]
    if unknown:
        raise UsageError(f"--values {', '.join(f'{v:g}' for v in unknown)} not swept by this experiment "
                         f"(it sweeps {', '.join(f'{case.x:g}' for case in cases)})")
    return [index for index, case in enumerate(cases) if any(math.isclose(v, case.x) for v in values)]


def _run_tasks(tasks: list[Task], jobs: int, name: str) -> list[dict]:
    rows: list[dict] = []
    with progress_bar(len(tasks), name, unit="run") as bar:
        if jobs == 1:
            for result in map(run_task, tasks):
                rows.extend(result)
                bar.update(1)
        else:
            with ProcessPoolExecutor(max_workers=jobs) as pool:
                for result in pool.map(run_task, tasks):
                    rows.extend(result)
                    bar.update(1)
    return rows


def _columns(rows: list[dict], keep_seconds: bool) -> dict[str, np.ndarray]:
    names = [n for n in rows[0] if keep_seconds or not n.startswith("seconds")] if rows else []
    columns = {}
    for name in names:
        values = [r[name] for r in rows]
        columns[name] = np.array(values, dtype=object if isinstance(values[0], str) else None)
    return columns


def _plot(experiment: Experiment, summary: list[dict], runs: int, protocol: str) -> np.ndarray:
    if experiment.measure == "merit":
        return _merit_plot(experiment, summary, runs)
    column = "seconds" if experiment.measure == "seconds" else "track_error"
    label = "seconds per run" if column == "seconds" else "mean track error, 95% interval"
    swept = _settings_keys(summary)[0]
    x = np.array(sorted({float(e[swept]) for e in summary}))
    series, intervals = {}, {}
    for tracker in dict.fromkeys(e["tracker"] for e in summary):
        by_x = {float(e[swept]): e for e in summary if e["tracker"] == tracker}
        series[tracker] = np.array([by_x[v][column] if v in by_x else np.nan for v in x])
        intervals[tracker] = np.array([by_x[v][column + "_ci95"] if v in by_x else 0.0 for v in x])
    started = "first links given" if protocol == "given" else "self-initialised"
    title = f"{experiment.name}: {experiment.title}, {started}, {counted(runs, 'run')}"
    return draw_line_plot(x, series, title, experiment.x_label, label, intervals)


def _merit_plot(experiment: Experiment, summary: list[dict], runs: int) -> np.ndarray:
    x = np.array(sorted({float(e["trajectories"]) for e in summary}))
    series, intervals = {}, {}
    for speed in sorted({e["mean_speed"] for e in summary}):
        for occlusion in sorted({e["occlusion"] for e in summary}):
            mine = [e for e in summary if e["mean_speed"] == speed and e["occlusion"] == occlusion]
            tag = f"v={speed:g}" + (" occl" if occlusion else "")
            for tracker in dict.fromkeys(e["tracker"] for e in mine):
                by_x = {float(e["trajectories"]): e for e in mine if e["tracker"] == tracker}
                series[f"{tracker} {tag}"] = np.array([by_x[v]["merit"] if v in by_x else np.nan for v in x])
                intervals[f"{tracker} {tag}"] = np.array([by_x[v]["merit_ci95"] if v in by_x else 0.0 for v in x])
            by_x = {float(e["trajectories"]): e["published_ipan"] for e in mine}
            series[f"published {tag}"] = np.array([by_x.get(v, np.nan) for v in x])
    return draw_line_plot(x, series, f"ipan-table: {experiment.title}, {counted(runs, 'run')}", experiment.x_label, "", intervals)


def _report(experiment: Experiment, summary: list[dict]) -> list[str]:
    lines = []
    for e in summary:
        settings = " ".join(f"{k}={e[k]:g}" for k in _settings_keys(summary))
        if experiment.measure == "merit":
            lines.append(f"{settings:40s} {e['tracker']:12s} merit {e['merit']:6.2f} ± {e['merit_ci95']:.2f}  "
                         f"published IPAN {e['published_ipan']:.2f}")
        elif experiment.measure == "seconds":
            lines.append(f"{settings:40s} {e['tracker']:18s} {e['seconds']:.4f} s")
        else:
            failed = f"  ({e['failures']} failed)" if e["failures"] else ""
            lines.append(f"{settings:40s} {e['tracker']:18s} track error {e['track_error']:.3f} ± {e['track_error_ci95']:.3f}{failed}")
    return lines


def _settings_keys(summary: list[dict]) -> list[str]:
    """The case settings, which come before the tracker in every summary entry."""
    return list(summary[0])[: list(summary[0]).index("tracker")] if summary else []
