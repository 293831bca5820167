"""``seedtrack analyze TRACKS --out DIR``: MSD, drift and velocity of tracks, as tables and plots."""

from __future__ import annotations

import argparse
from pathlib import Path

from seedtrack.data.atomic import output_folder
from seedtrack.data.csvio import write_table
from seedtrack.data.trackfile import FORMATS, read_calibration, read_tracks
from seedtrack.tracking.analysis import drift_table, fit_msd, msd_table, velocity_table, without_drift

from ..errors import UsageError
from .units import add_unit_options, calibration_from

DEFAULT_MAX_LAG = 100
DEFAULT_FIT_LAGS = 10
# Physical units make small numbers (an MSD of 0.0012 um^2): significant digits, not decimals.
SIGNIFICANT = "%.8g"


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "analyze",
        description="Write DIR/msd.csv (mean squared displacement against lag time over all point pairs of all "
        "tracks), DIR/msd_per_track.csv, DIR/drift.csv (the tracks' mean step summed over time, as trackpy's "
        "compute_drift), DIR/velocity.csv (per track: duration, path length, mean speed, net velocity) and "
        "plots of the MSD in log-log with the fitted diffusion coefficient and exponent (MSD = 4 D t^alpha), "
        "of the speed distribution and of the drift, as PNG and SVG. Only measured points count. Units: pixels "
        "and frames, unless --pixel-size and --frame-interval are given, TRACKS carries a calibration "
        "(TrackMate XML, GEFF) or --clip names a calibrated TIFF or a video (its frame rate). See docs/analysis.md.",
    )
    parser.add_argument("tracks", type=Path, metavar="TRACKS", help="tracks in any format seedtrack reads")
    parser.add_argument("--out", type=Path, required=True, metavar="DIR", help="folder for the tables and plots")
    parser.add_argument("--format", choices=sorted(FORMATS), default=None, help="format of TRACKS (default: from the extension and contents)")
    parser.add_argument("--max-lag", type=int, default=DEFAULT_MAX_LAG, metavar="FRAMES", help=f"longest MSD lag (default {DEFAULT_MAX_LAG})")
    parser.add_argument("--clip", type=Path, default=None, metavar="CLIP", help="take the units from the clip the tracks come from: a calibrated TIFF's pixel size and frame interval, a video's frame rate")
    parser.add_argument("--subtract-drift", action="store_true", help="take the drift off the positions before the MSD and velocities (as trackpy's subtract_drift)")
    parser.add_argument("--fit-lags", type=int, default=DEFAULT_FIT_LAGS, metavar="N", help=f"fit D and alpha over the first N lags (default {DEFAULT_FIT_LAGS})")
    add_unit_options(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from ..analysis_plots import drift_figure, msd_figure, save, speed_figure

    for name in ("max_lag", "fit_lags"):
        if getattr(args, name) < 1:
            raise UsageError(f"--{name.replace('_', '-')} must be at least 1, got {getattr(args, name)}")
    tracks = read_tracks(args.tracks, args.format)
    if args.clip is not None:
        from seedtrack.data.clip_units import clip_calibration

        read = clip_calibration(args.clip)
    else:
        read = read_calibration(args.tracks, args.format)
    units = calibration_from(args, read)
    space, time = units.space_unit, units.time_unit
    scale = (units.pixel_size, units.frame_interval)
    drift = drift_table(tracks, *scale)
    if args.subtract_drift:
        tracks = without_drift(tracks)
    ensemble = msd_table(tracks, *scale, args.max_lag)
    fit = fit_msd(ensemble["lag_time"][: args.fit_lags], ensemble["msd"][: args.fit_lags])
    velocity = velocity_table(tracks, *scale)
    name = args.tracks.name
    with output_folder(args.out):
        write_table(args.out / "msd.csv", ensemble, SIGNIFICANT)
        write_table(args.out / "msd_per_track.csv", msd_table(tracks, *scale, args.max_lag, per_track=True), SIGNIFICANT)
        write_table(args.out / "drift.csv", drift, SIGNIFICANT)
        write_table(args.out / "velocity.csv", velocity, SIGNIFICANT)
        written = save(msd_figure(ensemble["lag_time"], ensemble["msd"], fit, args.fit_lags, space, time, f"MSD: {name}"), args.out / "msd")
        written += save(speed_figure(velocity["mean_speed"], space, time, f"speeds: {name}"), args.out / "speed")
        written += save(drift_figure(drift["time"], drift["x"], drift["y"], space, time, f"drift: {name}"), args.out / "drift")
    print(f"D = {fit[0]:.6g} {space}^2/{time}, alpha = {fit[1]:.4f} (MSD = 4 D t^alpha over the first {min(args.fit_lags, len(ensemble['lag']))} lags)")
    print(f"tracks {tracks.n_tracks}, median mean speed {_median(velocity['mean_speed']):.6g} {space}/{time}")
    print(f"wrote {', '.join(str(args.out / n) for n in ('msd.csv', 'msd_per_track.csv', 'drift.csv', 'velocity.csv'))} and {len(written)} plots")
    return 0


def _median(values) -> float:
    import numpy as np

    return float(np.median(values)) if len(values) else float("nan")
