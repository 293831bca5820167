"""Rerun the paper's PSMG sweeps under both protocols and rewrite docs/paper.md's tables (not run in CI).

    python tests/benchmarks/bench_paper_tables.py [--runs N] [--table-runs N] [--jobs N] [--out DIR] [--readme PAGE]

Runs ``seedtrack experiment`` for models, density, velocity, occlusion and dmax under the paper's
protocol (first links given) and self-initialised, and ipan-table self-initialised (IPAN's own
protocol), writing each experiment's CSVs and plot to DIR (default tests/benchmarks/results). It
then rewrites the part of docs/paper.md between the ``paper-tables`` markers: one table per sweep and
protocol, the IPAN table and the paper's findings one by one, each verdict decided by the rule
its row states. ``--readme -`` prints the markdown instead. It ends by printing the time taken.
"""

from __future__ import annotations

import argparse
import math
import shutil
import sys
import time
from pathlib import Path

import pandas as pd

from seedtrack.cli import main
from seedtrack.experiments import PROTOCOLS, SWEEP_PEERS
from tables import provenance

ROOT = Path(__file__).resolve().parents[2]
BEGIN = "<!-- paper-tables: written by tests/benchmarks/bench_paper_tables.py, do not edit by hand -->"
END = "<!-- end of paper-tables -->"
SWEEPS = ("models", "density", "velocity", "occlusion", "dmax")
PLOTTED = ("density", "velocity", "occlusion", "dmax")
PROTOCOL_NAMES = {"given": "first links given (the paper's protocol)", "self": "self-initialised"}
COLUMN = {"models": "trajectories", "density": "trajectories", "velocity": "mean_speed", "occlusion": "occlusion",
          "dmax": "d_max_factor"}
HEADINGS = {
    "models": ("Motion models: the published scheme with each model, track error vs number of points", "{:g} points", "{:g}"),
    "density": ("Density: track error vs number of points", "{:g} points", "{:g}"),
    "velocity": ("Velocity: track error vs mean speed, same density", "{:g} px/frame", "{:g}"),
    "occlusion": ("Occlusion: track error vs occlusion probability", "p_occ {:g}", "{:g}"),
    "dmax": ("Speed limit: track error vs d_max / mean speed", "d_max {:g} v", "{:g} v"),
}
# The swept values the regeneration runs (a subset of each experiment's, the same data), chosen so
# that the whole regeneration at 5 runs takes about 20 minutes on the shared 2-core machine.
VALUES = {"models": "20,60,100", "density": "10,25,50,100", "velocity": "2,6,12", "occlusion": "0.05,0.25,0.45",
          "dmax": "1.5,2,5,10"}
# How close two mean track errors must be to call them level, and the spread over a sweep of
# d_max below which a tracker is called flat (track error, 0..1).
LEVEL = 0.01
FLAT = 0.05


def run_all(out: Path, runs: int, table_runs: int, jobs: int) -> None:
    for name in SWEEPS:
        for protocol in PROTOCOLS:
            _experiment(name, protocol, runs, jobs, out)
    _experiment("ipan-table", "self", table_runs, jobs, out)


def _experiment(name: str, protocol: str, runs: int, jobs: int, out: Path) -> None:
    start = time.perf_counter()
    values = ["--values", VALUES[name]] if name in VALUES else []
    status = main(["experiment", name, "--out", str(out), "--runs", str(runs), "--jobs", str(jobs), "--protocol", protocol, *values])
    print(f"== {name} {protocol}: exit {status}, {time.perf_counter() - start:.0f} s", flush=True)
    if status:
        raise SystemExit(status)


def load(out: Path) -> dict:
    """``table[(experiment, protocol)][tracker][x] = (mean, ci95, failures, runs)``."""
    tables = {}
    for name in SWEEPS:
        for protocol in PROTOCOLS:
            frame = pd.read_csv(out / f"{name}-{protocol}-summary.csv")
            table: dict = {}
            for row in frame.itertuples(index=False):
                entry = row._asdict()
                table.setdefault(entry["tracker"], {})[float(entry[COLUMN[name]])] = (
                    entry["track_error"], entry["track_error_ci95"], int(entry["failures"]), int(entry["runs"]))
            tables[(name, protocol)] = table
    return tables


def _cell(value: tuple | None) -> str:
    if value is None:
        return "not run"
    mean, ci, failures, runs = value
    if failures == runs:
        return f"all {runs} failed"
    return f"{mean:.3f} ± {ci:.3f}" + (f" ({failures} failed)" if failures else "")


def sweep_tables(tables: dict, runs: int) -> list[str]:
    lines = []
    for name in SWEEPS:
        title, first, rest = HEADINGS[name]
        for protocol in PROTOCOLS:
            table = tables[(name, protocol)]
            xs = sorted({x for by_x in table.values() for x in by_x})
            lines += [f"### {title}: {PROTOCOL_NAMES[protocol]} ({runs} runs)", ""]
            if name in PLOTTED:
                lines += [f"![{name} {protocol}](pictures/paper/{name}-{protocol}.png)", ""]
            header = [first.format(xs[0])] + [rest.format(x) for x in xs[1:]]
            lines.append("| tracker | " + " | ".join(header) + " |")
            lines.append("| --- " * (len(xs) + 1) + "|")
            for tracker, by_x in table.items():
                lines.append(f"| {tracker} | " + " | ".join(_cell(by_x.get(x)) for x in xs) + " |")
            lines.append("")
    return lines


def ipan_table(out: Path, runs: int) -> list[str]:
    frame = pd.read_csv(out / "ipan-table-self-summary.csv")
    counts = sorted(frame["trajectories"].unique())
    lines = [
        f"### IPAN's published table, with the default and the published scheme on the same data: self-initialised ({runs} runs)",
        "",
        "Strict trajectory merit (%, 100 x (1 - track error)); PSMG without entry or exit, 20 frames, 200 x 200 px,",
        "v_max 2v, IPAN with delta_max 0.6 and N_ver 2. The sources do not give the occlusion probability of",
        "the \"with occlusion\" rows; we use 0.03 (single frames).",
        "",
        "| occlusion | speed | tracker | " + " | ".join(f"{c} points" if i == 0 else f"{c}" for i, c in enumerate(counts)) + " |",
        "| --- | --- | --- | " + "--- | " * len(counts),
    ]
    gaps, intervals = [], []
    for occlusion in sorted(frame["occlusion"].unique()):
        for speed in sorted(frame["mean_speed"].unique()):
            mine = frame[(frame["occlusion"] == occlusion) & (frame["mean_speed"] == speed)]
            label = "none" if occlusion == 0 else f"{occlusion:g}"
            published = [mine[mine["trajectories"] == c]["published_ipan"].iloc[0] for c in counts]
            lines.append(f"| {label} | {speed:g} | IPAN, published | " + " | ".join(f"{p:.2f}" for p in published) + " |")
            for tracker in dict.fromkeys(mine["tracker"]):
                cells = []
                for c, p in zip(counts, published):
                    row = mine[(mine["tracker"] == tracker) & (mine["trajectories"] == c)].iloc[0]
                    cells.append(f"{row['merit']:.2f} ± {row['merit_ci95']:.2f}")
                    if tracker == "ipan":
                        gaps.append(row["merit"] - p)
                        intervals.append(row["merit_ci95"])
                lines.append(f"| | | {'ipan (ours)' if tracker == 'ipan' else tracker} | " + " | ".join(cells) + " |")
    largest = max(gaps, key=abs)
    lines += ["", f"Our IPAN is within {max(abs(g) for g in gaps):.1f} points of every published cell (largest gap "
              f"{largest:+.2f}; {sum(g > 0 for g in gaps)} of {len(gaps)} cells above the published value; its own intervals "
              f"reach ±{max(intervals):.1f} at {runs} runs). The PSMG spreads and the occlusion probability are not published;",
              "ours were chosen to match this table (at 100 runs our IPAN came within 3.2 points of every cell), so the",
              "table checks our IPAN and PSMG as a pair.", ""]
    return lines


def _mean(table: dict, tracker: str, x: float) -> float:
    value = table.get(tracker, {}).get(x)
    return math.nan if value is None or value[2] == value[3] else value[0]


def _xs(table: dict) -> list[float]:
    return sorted({x for by_x in table.values() for x in by_x})


def _verdict(holds: bool) -> str:
    return "**holds**" if holds else "**does not hold**"


def findings(tables: dict) -> list[str]:
    """The paper's findings, each with the rule that decides it and the figures, per protocol."""
    rows = []

    def add(finding: str, rule: str, decide) -> None:
        cells = []
        for protocol in PROTOCOLS:
            holds, figures = decide(protocol)
            cells.append(figures if holds is None else f"{_verdict(holds)}: {figures}")
        rows.append(f"| {finding} | {rule} | " + " | ".join(cells) + " |")

    def models(protocol):
        t = tables[("models", protocol)]
        xs = _xs(t)
        top = xs[-1]
        others = {x: min(_mean(t, "goa im1", x), _mean(t, "goa im3", x)) for x in xs}
        holds = all(_mean(t, "goa im2", x) <= others[x] for x in xs) and _mean(t, "goa im2", top) < others[top]
        return holds, f"at {top:g} points IM2 {_mean(t, 'goa im2', top):.3f}, IM3 {_mean(t, 'goa im3', top):.3f}, IM1 {_mean(t, 'goa im1', top):.3f}"

    add("IM2 beats IM3 and IM1", "IM2 at most IM1 and IM3 at every density, below both at the largest (published scheme)", models)

    def cm2(form):
        def decide(protocol):
            t = tables[("models", protocol)]
            xs = _xs(t)
            names = {"CM1": "goa im2", "w=0.1": f"goa im2 {form} w=0.1", "w=0.5": f"goa im2 {form} w=0.5"}
            average = {label: sum(_mean(t, name, x) for x in xs) / len(xs) for label, name in names.items()}
            same = sum(abs(_mean(t, names[w], x) - _mean(t, "goa im2", x)) < 1e-12 for w in ("w=0.1", "w=0.5") for x in xs)
            holds = average["CM1"] <= average["w=0.1"] < average["w=0.5"]
            return holds, (f"mean over densities CM1 {average['CM1']:.4f}, w=0.1 {average['w=0.1']:.4f}, w=0.5 "
                           f"{average['w=0.5']:.4f}; equal to CM1 in {same} of {2 * len(xs)} cells")

        return decide

    for form, label in (("cm2", "CM2 as written (means)"), ("cm2-margin", "cm2-margin")):
        add(f"CM1 beats CM2 (w1 = w2), and CM2 improves as w goes to 0: {label}",
            "mean error over densities CM1 <= w=0.1 < w=0.5", cm2(form))

    def lowest(protocol):
        parts, all_hold = [], True
        for tracker in ("published", "default"):
            level = total = 0
            for name in ("density", "velocity"):
                t = tables[(name, protocol)]
                for x in _xs(t):
                    means = [m for m in (_mean(t, other, x) for other in t) if not math.isnan(m)]
                    total += 1
                    level += _mean(t, tracker, x) <= min(means) + LEVEL
            parts.append(f"{tracker} {level} of {total}")
            all_hold &= tracker != "published" or level == total
        return all_hold, "columns where lowest or within 0.01 of it: " + ", ".join(parts)

    add("GOA has the lowest track error over density and velocity", "the published scheme lowest (within 0.01) in every density and velocity column", lowest)

    def ss(protocol):
        t = tables[("density", protocol)]
        xs = _xs(t)
        below = sum(_mean(t, "ss", x) < _mean(t, "ipan", x) for x in xs)
        d = tables[("dmax", protocol)]
        best = min(_xs(d), key=lambda x: _mean(d, "ss", x))
        return below == len(xs), (f"SS below IPAN in {below} of {len(xs)} density columns; SS at its best d_max ({best:g} v) "
                                  f"{_mean(d, 'ss', best):.3f}, published there {_mean(d, 'published', best):.3f}")

    add("SS is slightly worse than GOA at its best d_max, and consistently better than CV (IPAN)", "SS below IPAN in every density column", ss)

    def rs(protocol):
        d = tables[("dmax", protocol)]
        xs = _xs(d)
        best = min(xs, key=lambda x: _mean(d, "rs", x))
        holds = best <= 3 and _mean(d, "rs", xs[-1]) > 2 * _mean(d, "rs", best)
        return holds, f"best {_mean(d, 'rs', best):.3f} at {best:g} v, {_mean(d, 'rs', xs[-1]):.3f} at {xs[-1]:g} v"

    add("RS' is good only with an accurate d_max", "RS' best at d_max <= 3 v and at 10 v over twice its best", rs)

    def occlusion(protocol):
        t = tables[("occlusion", protocol)]
        xs = _xs(t)
        gaps = [_mean(t, "rs", x) - _mean(t, "published", x) for x in xs]
        holds = all(g > 0 for g in gaps) and gaps[-1] > gaps[0]
        return holds, (f"published {min(_mean(t, 'published', x) for x in xs):.3f} to {max(_mean(t, 'published', x) for x in xs):.3f}, "
                       f"RS {_mean(t, 'rs', xs[0]):.3f} to {_mean(t, 'rs', xs[-1]):.3f}; gap {gaps[0]:.3f} at {xs[0]:g}, {gaps[-1]:.3f} at {xs[-1]:g}")

    add("Slave interpolation beats extrapolation under occlusion, the gap widening with p_occ",
        "published below RS (extrapolation) at every p_occ, gap larger at 0.45 than at 0.05", occlusion)

    def spread(protocol, tracker, low):
        d = tables[("dmax", protocol)]
        values = [_mean(d, tracker, x) for x in _xs(d) if x >= low]
        return max(values) - min(values)

    def flat_goa(protocol):
        goa, ss_, rs_ = (spread(protocol, t, 1.5) for t in ("published", "ss", "rs"))
        return goa <= FLAT and ss_ > FLAT and rs_ > FLAT, (
            f"spread over 1.5 v to 10 v: published {goa:.3f}, default {spread(protocol, 'default', 1.5):.3f}, SS {ss_:.3f}, RS' {rs_:.3f}")

    add("d_max: GOA flat; SS and RS' sensitive", "spread of the error over 1.5 v to 10 v at most 0.05 for GOA, above it for SS and RS'", flat_goa)

    def flat_ipan(protocol):
        value = spread(protocol, "ipan", 1.5)
        return value <= FLAT, f"IPAN's spread over 1.5 v to 10 v {value:.3f}"

    add("d_max: CV (IPAN) flat", "IPAN's spread over 1.5 v to 10 v at most 0.05", flat_ipan)

    def almost(protocol):
        if protocol == "given":
            return None, "(the comparison of the two protocols: see the self-initialised column)"
        parts, holds = [], True
        for name, x in (("density", None), ("velocity", None), ("occlusion", None)):
            s, g = tables[(name, "self")], tables[(name, "given")]
            x = _xs(s)[-1]
            for tracker in ("published", "default"):
                a, b = _mean(s, tracker, x), _mean(g, tracker, x)
                holds &= tracker != "published" or a - b <= 0.02
                parts.append(f"{name} {x:g} {tracker} {a:.3f} vs {b:.3f}")
        return holds, "; ".join(parts)

    add("GOA-updown almost as good as GOA given the first links",
        "self-initialised published within 0.02 of given, at the largest density, speed and p_occ", almost)

    def updown_flat(protocol):
        goa, ipan = spread(protocol, "published", 2.0), spread(protocol, "ipan", 2.0)
        return goa <= FLAT < ipan, (f"spread over 2 v to 10 v: published {goa:.3f}, default {spread(protocol, 'default', 2.0):.3f}, "
                                    f"IPAN {ipan:.3f}")

    add("GOA-updown flat vs d_max while CV needs an accurate one", "spread over 2 v to 10 v at most 0.05 for GOA, above it for IPAN", updown_flat)

    def mht(protocol):
        t = tables[("density", protocol)]
        xs = [x for x in _xs(t) if not math.isnan(_mean(t, "stonesoup-mfa", x))]
        if not xs:
            return False, "Stone Soup's MFA not run"
        parts = [f"{x:g} points: MFA {_mean(t, 'stonesoup-mfa', x):.3f}, GNN {_mean(t, 'stonesoup', x):.3f}, "
                 f"published {_mean(t, 'published', x):.3f}, default {_mean(t, 'default', x):.3f}" for x in xs]
        holds = all(_mean(t, "stonesoup-mfa", x) >= _mean(t, "published", x) for x in xs)
        return holds, "; ".join(parts)

    add("MHT is similar to GOA up to 50 points and slower", "Stone Soup's MFA (window 3) no better than the published scheme where it runs", mht)
    return ["| finding (Veenman et al.) | decided by | " + " | ".join(PROTOCOL_NAMES[p] for p in PROTOCOLS) + " |",
            "| --- | --- | " + "--- | " * len(PROTOCOLS), *rows, ""]


def markdown(out: Path, runs: int, table_runs: int, seconds: float | None) -> str:
    tables = load(out)
    limits = ", ".join(f"{name} up to {limit} points" for name, limit in SWEEP_PEERS.items() if limit is not None)
    # A run stamps the commit and the machine it measured on; --tables-only reformats earlier runs.
    took = f" in {seconds / 60:.0f} minutes at {provenance()}" if seconds is not None else ""
    lines = [
        BEGIN,
        "",
        f"Made by `python tests/benchmarks/bench_paper_tables.py --runs {runs} --table-runs {table_runs}`{took}. Sizes: the",
        f"sweeps' scenes as described above at the values " + "; ".join(f"{n} {v.replace(',', ', ')}" for n, v in VALUES.items()) + ",",
        f"{runs} runs per cell under each protocol (the paper ran 100: intervals here are wide); the IPAN table {table_runs} runs",
        f"per cell; the slow peers only on the smaller scenes ({limits}; \"not run\" elsewhere).",
        "",
        "## The paper's findings, one by one",
        "",
        *findings(tables),
        *sweep_tables(tables, runs),
        *ipan_table(out, table_runs),
        END,
    ]
    return "\n".join(lines)


def rewrite(readme: Path, text: str, out: Path) -> None:
    """Replace the paper tables of page ``readme`` with ``text``, and copy the sweeps' plots it
    shows from ``out`` to the page's pictures/paper/ (the docs site serves only docs/)."""
    pictures = readme.parent / "pictures" / "paper"
    pictures.mkdir(parents=True, exist_ok=True)
    for name in PLOTTED:
        for protocol in PROTOCOLS:
            plot = out / f"{name}-{protocol}.png"
            if plot.exists():  # --tables-only on a fresh checkout: the page's own copies stand
                shutil.copy2(plot, pictures / plot.name)
    old = readme.read_text()
    start, end = old.index(BEGIN), old.index(END) + len(END)
    temporary = readme.with_suffix(".md.tmp")
    temporary.write_text(old[:start] + text + old[end:])
    temporary.replace(readme)


def run() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5, help="runs per cell of the sweeps (default 5)")
    parser.add_argument("--table-runs", type=int, default=10, help="runs per cell of the IPAN table (default 10)")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--out", type=Path, default=ROOT / "tests" / "benchmarks" / "results")
    parser.add_argument("--readme", default=str(ROOT / "docs" / "paper.md"), help="page to rewrite (default docs/paper.md), or - to print")
    parser.add_argument("--tables-only", action="store_true", help="rewrite from the summaries in --out without running")
    args = parser.parse_args()
    start = time.perf_counter()
    seconds = None
    if not args.tables_only:
        run_all(args.out, args.runs, args.table_runs, args.jobs)
        seconds = time.perf_counter() - start
    text = markdown(args.out, args.runs, args.table_runs, seconds)
    if args.readme == "-":
        print(text)
    else:
        rewrite(Path(args.readme), text, args.out)
        print(f"rewrote the paper tables of {args.readme}")
    print(f"took {time.perf_counter() - start:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(run())
