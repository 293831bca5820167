"""GOA-updown run time against the number of points at constant density, on one core.

Run as ``python tests/benchmarks/bench_goa_scaling.py [--sizes 100 1000 ...] [--repeats N] [--write-docs]``
(``--write-docs`` also writes the table into docs/tracking.md, stamped: ``goa-scaling``).
PSMG scenes with the density of the experiments' base scene (50 points in 200 x 200 px, speed
5 px/frame) over 20 frames. Prints, per size, the median seconds per frame step of the up pass
and of the down pass, the seconds that choosing the first links takes (once per run), the whole
run, and trackpy's ``link`` on the same points (search range 2 x the mean speed) as a ratio;
then the growth exponent fitted to the per-step times. Times are CPU seconds of this process
(``time.process_time``), so that other work on a shared machine does not inflate them. Goal
(issue #3): exponent at most 1.2 and at most 0.25 s per frame per pass at 10,000 points.
"""

from __future__ import annotations

import os

# One core: set before numpy and scipy load their thread pools.
for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_name] = "1"

import argparse  # noqa: E402
import math  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402
from dataclasses import replace  # noqa: E402

import numpy as np  # noqa: E402

from seedtrack.experiments import BASE  # noqa: E402
from seedtrack.data.psmg import generate_psmg  # noqa: E402
from seedtrack.tracking.goa import GOAConfig, goa_updown, initial_links  # noqa: E402
from tables import write_table  # noqa: E402

FRAMES = 20


def scene(n_points: int, seed: int = 0) -> list[np.ndarray]:
    """PSMG frames with ``n_points`` points at the base scene's density."""
    size = BASE.size * math.sqrt(n_points / BASE.trajectories)
    frames, _ = generate_psmg(replace(BASE, trajectories=n_points, frames=FRAMES, size=size, random_seed=seed))
    return frames


def time_updown(frames: list[np.ndarray], config: GOAConfig) -> tuple[float, float, float, float]:
    """Median seconds per step of the up pass and of the down pass, the whole run's seconds, and
    the seconds that choosing the first links takes (part of the first up step)."""
    start = time.process_time()
    initial_links(frames, config)
    first = time.process_time() - start
    stamps = [time.process_time()]
    goa_updown(frames, config, progress=lambda _: stamps.append(time.process_time()))
    steps = np.diff(stamps)
    # Progress comes after each frame step of a pass; the first step of each pass only takes
    # its first links.
    n = len(frames)
    up, down = steps[1 : n - 1], steps[n : 2 * n - 2]
    return float(np.median(up)), float(np.median(down)), stamps[-1] - stamps[0], first


def time_trackpy(frames: list[np.ndarray], search_range: float) -> float | None:
    """Seconds of ``trackpy.link`` on the same points, or None without trackpy."""
    try:
        import pandas as pd
        import trackpy
    except ImportError:
        return None
    trackpy.quiet()
    table = pd.DataFrame(
        {
            "frame": np.repeat(np.arange(len(frames)), [len(f) for f in frames]),
            "x": np.concatenate(frames)[:, 0],
            "y": np.concatenate(frames)[:, 1],
        }
    )
    start = time.process_time()
    trackpy.link(table, search_range)
    return time.process_time() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[100, 300, 1000, 3000, 10000])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--max-speed", type=float, default=None, help="d_max for GOA-updown (default none, as users run it)")
    parser.add_argument("--write-docs", action="store_true", help="write the table into docs/tracking.md, stamped")
    args = parser.parse_args()
    config = GOAConfig(d_max=args.max_speed)
    print(f"GOA-updown, d_max {args.max_speed}, {FRAMES} frames, {BASE.trajectories} points per {BASE.size:g}^2 px, "
          f"speed {BASE.mean_speed:g} px/frame; medians of {args.repeats} runs; one core")
    print(f"{'points':>7} {'up s/frame':>11} {'down s/frame':>13} {'first links s':>14} {'total s':>8} {'trackpy s':>10} {'ours/trackpy':>13}")
    time_trackpy(scene(100, seed=1), 2 * BASE.mean_speed)  # numba compiles trackpy's code on its first call
    per_step, rows, exponents = [], [], []
    for n in args.sizes:
        frames = scene(n)
        runs = [time_updown(frames, config) for _ in range(args.repeats)]
        up, down, total, first = (statistics.median(r[i] for r in runs) for i in range(4))
        linked = time_trackpy(frames, 2 * BASE.mean_speed)
        ratio = f"{total / linked:13.2f}" if linked else f"{'-':>13}"
        print(f"{n:>7} {up:11.4f} {down:13.4f} {first:14.2f} {total:8.2f} {linked if linked else float('nan'):10.2f} {ratio}")
        rows.append([f"{n:,}", f"{up:.4f} / {down:.4f}", f"{first:.2f}", f"{total:.2f}", f"{linked:.2f}" if linked else "-", ratio.strip()])
        per_step.append(max(up, down))
    # Fixed costs per step flatten the small sizes; the fit over 1,000 points and up shows the growth.
    sizes, per_step = np.array(args.sizes), np.array(per_step)
    for low in sorted({sizes.min(), 1000}):
        chosen = sizes >= low
        if chosen.sum() > 1:
            slope = np.polyfit(np.log(sizes[chosen]), np.log(per_step[chosen]), 1)[0]
            exponents.append(f"growth exponent of s/frame/pass (slower pass), {sizes[chosen].min():,}-{sizes[chosen].max():,} points: {slope:.2f}")
            print(exponents[-1])
    if args.write_docs:
        header = ["points", "s/frame, up / down", "first links, s", "total, s", "trackpy `link`, s", "ours / trackpy"]
        growth = "; ".join(exponents)
        note = f"d_max {args.max_speed}, {FRAMES} frames, medians of {args.repeats} runs, CPU seconds on one core. {growth[:1].upper()}{growth[1:]}."
        write_table("tracking.md", "goa-scaling", header, rows, note=note)


if __name__ == "__main__":
    main()
