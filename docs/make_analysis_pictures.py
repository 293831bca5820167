"""Remake docs/analysis.md's pictures: ``python docs/make_analysis_pictures.py CLIP RUN_DIR``.

RUN_DIR is what ``seedtrack run CLIP --out RUN_DIR`` wrote (for the docs: the bulk-water clip of
/work/shared/data, 1 um beads at 2.85 px/um). Runs ``seedtrack analyze`` on its tracks with the
clip's frame rate and that pixel size, with and without the drift subtracted, copies the plots
into docs/pictures/ (reduced to 256 colours), and prints D and alpha beside trackpy's ``emsd``
on the same tracks, fitted over the same lags.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
from PIL import Image

HERE = Path(__file__).resolve().parent
PIXEL_SIZE_UM = 1 / 2.85
FIT_LAGS = 10


def small_png(source: Path, target: Path) -> None:
    Image.open(source).convert("RGB").quantize(256, method=Image.Quantize.MEDIANCUT).save(target, optimize=True)


def main(clip: Path, run: Path) -> None:
    import trackpy

    from seedtrack.tracking.analysis import fit_msd

    scratch = Path(tempfile.mkdtemp(prefix="analysis-"))
    common = [sys.executable, "-m", "seedtrack", "analyze", str(run / "tracks.csv"), "--clip", str(clip), "--pixel-size", f"{PIXEL_SIZE_UM:.6f}", "--space-unit", "um", "--fit-lags", str(FIT_LAGS)]
    for name, extra in (("raw", []), ("drift-free", ["--subtract-drift"])):
        out = subprocess.run([*common, "--out", str(scratch / name), *extra], check=True, capture_output=True, text=True).stdout
        print(f"seedtrack analyze ({name}): {out.splitlines()[0]}")
    for plot in ("msd", "drift", "speed"):
        small_png(scratch / "drift-free" / f"{plot}.png", HERE / "pictures" / f"analysis-{plot}.png")

    tracks = pd.read_csv(run / "tracks.csv")
    particles = tracks[tracks["interpolated"] == 0].rename(columns={"track_id": "particle"})[["frame", "particle", "x", "y"]]
    fps = 1 / pd.read_csv(scratch / "raw" / "msd.csv")["lag_time"].iloc[0]
    for name, table in (("raw", particles), ("drift-free", trackpy.subtract_drift(particles, trackpy.compute_drift(particles)).reset_index(drop=True))):
        theirs = trackpy.emsd(table, mpp=PIXEL_SIZE_UM, fps=fps, max_lagtime=FIT_LAGS)
        D, alpha = fit_msd(theirs.index.to_numpy(dtype=float), theirs.to_numpy())
        ours = pd.read_csv(scratch / name / "msd.csv").iloc[:FIT_LAGS]
        worst = float(np.max(np.abs(ours["msd"].to_numpy() / theirs.to_numpy() - 1)))
        print(f"trackpy emsd ({name}): D = {D:.4f} um^2/s, alpha = {alpha:.3f}; largest MSD difference from seedtrack's over lags 1-{FIT_LAGS}: {worst:.2%}")


if __name__ == "__main__":
    main(Path(sys.argv[1]), Path(sys.argv[2]))
