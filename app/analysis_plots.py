"""The plots of ``seedtrack analyze``, drawn with matplotlib and written as PNG and SVG.

Written the same, byte for byte, from the same tables: no date or software stamp, and a fixed
salt for the SVG's element ids.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from seedtrack.data.atomic import atomic_path


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    matplotlib.rcParams["svg.hashsalt"] = "seedtrack"
    from matplotlib import pyplot

    return pyplot


def save(figure, stem: Path) -> list[Path]:
    """Write ``figure`` as ``stem.png`` and ``stem.svg``, atomically; close it."""
    written = []
    for suffix, metadata in ((".png", {"Software": None}), (".svg", {"Date": None, "Creator": None})):
        path = stem.with_suffix(suffix)
        with atomic_path(path) as temporary:
            figure.savefig(temporary, format=suffix[1:], dpi=120, metadata=metadata)
        written.append(path)
    _pyplot().close(figure)
    return written


def msd_figure(lag_time: np.ndarray, msd: np.ndarray, fit: tuple[float, float], fit_lags: int, space: str, time: str, title: str):
    """MSD against lag time in log-log, with the fitted ``4 D t^alpha`` over the first
    ``fit_lags`` lags."""
    plt = _pyplot()
    figure, axes = plt.subplots(figsize=(6, 4.5))
    axes.loglog(lag_time, msd, "o", markersize=4, color="#1f77b4", label="MSD")
    D, alpha = fit
    if np.isfinite(D):
        shown = lag_time[:fit_lags]
        axes.loglog(shown, 4 * D * shown**alpha, "-", color="#d62728", label=f"fit: D = {D:.4g} {space}²/{time}, α = {alpha:.3f}")
    axes.set_xlabel(f"lag time ({time})")
    axes.set_ylabel(f"MSD ({space}²)")
    axes.set_title(title)
    axes.grid(True, which="both", alpha=0.3)
    axes.legend()
    figure.tight_layout()
    return figure


def speed_figure(mean_speed: np.ndarray, space: str, time: str, title: str):
    """Histogram of the tracks' mean speeds."""
    plt = _pyplot()
    figure, axes = plt.subplots(figsize=(6, 4.5))
    axes.hist(mean_speed, bins=min(50, max(5, int(np.sqrt(mean_speed.size)))), color="#2ca02c", edgecolor="white")
    if mean_speed.size:
        axes.axvline(float(np.median(mean_speed)), color="black", linestyle="--", label=f"median {np.median(mean_speed):.4g} {space}/{time}")
        axes.legend()
    axes.set_xlabel(f"mean speed per track ({space}/{time})")
    axes.set_ylabel("tracks")
    axes.set_title(title)
    figure.tight_layout()
    return figure


def drift_figure(time_points: np.ndarray, x: np.ndarray, y: np.ndarray, space: str, time: str, title: str):
    """Drift in x and y against time."""
    plt = _pyplot()
    figure, axes = plt.subplots(figsize=(6, 4.5))
    axes.plot(time_points, x, label="x (right)")
    axes.plot(time_points, y, label="y (down)")
    axes.set_xlabel(f"time ({time})")
    axes.set_ylabel(f"drift ({space})")
    axes.set_title(title)
    axes.grid(True, alpha=0.3)
    axes.legend()
    figure.tight_layout()
    return figure
