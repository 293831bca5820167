"""MSD of real beads, seedtrack beside trackpy: ``python tests/benchmarks/bench_analysis.py CLIP RUN_DIR [--write-docs]``.

RUN_DIR is what ``seedtrack run CLIP --out RUN_DIR`` wrote (for the docs: the bulk-water clip of
shared/data, 1 um beads at 2.85 px/um). Runs ``seedtrack analyze`` on its tracks with the clip's
frame rate and that pixel size, with and without the drift subtracted, and prints D and alpha
beside trackpy's ``emsd`` on the same tracks, fitted over the same lags, with the largest
difference of the two MSDs. With ``--write-docs``, writes the table into docs/analysis.md and
the plots into docs/pictures/ (reduced to 256 colours).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
from PIL import Image

from tables import markdown_table, write_table

PICTURES = Path(__file__).resolve().parents[2] / "docs" / "pictures"
PIXEL_SIZE_UM = 1 / 2.85
FIT_LAGS = 10


def small_png(source: Path, target: Path) -> None:
    Image.open(source).convert("RGB").quantize(256, method=Image.Quantize.MEDIANCUT).save(target, optimize=True)


def main() -> None:
    import trackpy

    from seedtrack.tracking.analysis import fit_msd

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("clip", type=Path)
    parser.add_argument("run", type=Path, help="the folder seedtrack run CLIP --out wrote")
    parser.add_argument("--write-docs", action="store_true", help="write the table into docs/analysis.md and the plots into docs/pictures")
    args = parser.parse_args()
    scratch = Path(tempfile.mkdtemp(prefix="analysis-"))
    common = [sys.executable, "-m", "seedtrack", "analyze", str(args.run / "tracks.csv"), "--clip", str(args.clip), "--pixel-size", f"{PIXEL_SIZE_UM:.6f}", "--space-unit", "um", "--fit-lags", str(FIT_LAGS)]
    seedtrack_fit = {}
    for name, extra in (("as measured", []), ("drift subtracted", ["--subtract-drift"])):
        subprocess.run([*common, "--out", str(scratch / name), *extra], check=True, capture_output=True)
        table = pd.read_csv(scratch / name / "msd.csv")
        seedtrack_fit[name] = (table, fit_msd(table["lag_time"].to_numpy()[:FIT_LAGS], table["msd"].to_numpy()[:FIT_LAGS]))

    tracks = pd.read_csv(args.run / "tracks.csv")
    particles = tracks[tracks["interpolated"] == 0].rename(columns={"track_id": "particle"})[["frame", "particle", "x", "y"]]
    inputs = {"as measured": particles, "drift subtracted": trackpy.subtract_drift(particles, trackpy.compute_drift(particles)).reset_index(drop=True)}
    rows = []
    for name, (ours, (D, alpha)) in seedtrack_fit.items():
        theirs = trackpy.emsd(inputs[name], mpp=PIXEL_SIZE_UM, fps=1 / ours["lag_time"].iloc[0], max_lagtime=FIT_LAGS)
        their_D, their_alpha = fit_msd(theirs.index.to_numpy(dtype=float), theirs.to_numpy())
        worst = float(np.max(np.abs(ours["msd"].to_numpy()[:FIT_LAGS] / theirs.to_numpy() - 1)))
        rows.append([name, f"D = {D:.3f} um²/s, alpha = {alpha:.3f}", f"D = {their_D:.3f} um²/s, alpha = {their_alpha:.3f}", f"{worst:.1%}"])
    header = [f"MSD over lags 1-{FIT_LAGS}", "seedtrack (all pairs)", "trackpy emsd on the same tracks", "largest MSD difference"]
    print(f"{tracks['track_id'].nunique()} tracks")
    print(markdown_table(header, rows))
    if args.write_docs:
        write_table("analysis.md", "bulk-water-msd", header, rows)
        for plot in ("msd", "drift", "speed"):
            small_png(scratch / "drift subtracted" / f"{plot}.png", PICTURES / f"analysis-{plot}.png")


if __name__ == "__main__":
    main()
