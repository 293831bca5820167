"""``seedtrack evaluate TRACKS --truth TRUTH``: score a track set against ground truth."""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from seedtrack.data.atomic import atomic_path, output_folder
from seedtrack.data.csvio import write_table
from seedtrack.data.errors import DataError
from seedtrack.data.trackfile import FORMATS, read_tracks
from seedtrack.tracking.clear_mot import ClearMotScores
from seedtrack.tracking.diagnosis import first_errors
from seedtrack.tracking.evaluation import Scores, evaluate_tracks
from seedtrack.tracking.tracks import Tracks

from ..error_plot import draw_error_plot, write_png
from ..errors import UsageError

DEFAULT_TOLERANCE = 3.0
# A result matching fewer true points than this is checked against the truth one frame off.
_WELL_MATCHED = 0.9


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "evaluate",
        description="Match result points to true points frame by frame (one to one, within --tol, by optimal "
        "assignment) and report the paper's strict track error, relaxed trajectory merit and link error, and "
        "ID switches, fragmentations, MOTA, MOTP and IDF1 as py-motmetrics computes them, HOTA with DetA, AssA and "
        "LocA as TrackEval computes them (point similarity 1 - distance/tol), and the ISBI 2012 particle tracking "
        "challenge's alpha, beta, JSC, JSC_theta and RMSE (gate = tol); see docs/metrics.md. With --out, also "
        "write DIR/evaluation.json, DIR/wrong_tracks.csv and DIR/errors.png. A result with no tracks (a header "
        "only) scores as every true track missed. TRUTH must hold points in at least two frames, since the "
        "track and link errors are about links; otherwise, and for a missing column or a value that is not a "
        "finite number in either file, the exit status is 2.",
    )
    parser.add_argument("tracks", type=Path, metavar="TRACKS", help="result tracks (csv, trackpy csv, MOT txt, TrackMate or ISBI xml)")
    parser.add_argument("--truth", type=Path, required=True, metavar="TRUTH", help="true tracks, in any of the same formats")
    parser.add_argument("--tol", type=float, default=DEFAULT_TOLERANCE, metavar="PX", help=f"matching distance in pixels (default {DEFAULT_TOLERANCE:g})")
    parser.add_argument("--format", choices=sorted(FORMATS), default=None, help="format of TRACKS (default: from the extension and contents)")
    parser.add_argument("--truth-format", choices=sorted(FORMATS), default=None, help="format of TRUTH (default: from the extension and contents)")
    parser.add_argument("--out", type=Path, default=None, metavar="DIR", help="folder for evaluation.json, wrong_tracks.csv and errors.png")
    parser.set_defaults(run=run)


def evaluate(tracks_path: Path, truth_path: Path, tolerance: float, tracks_format: str | None = None, truth_format: str | None = None):
    """Read both files and compute every measure.

    Returns
    -------
    measures : dict
        The file names, then :func:`assess`'s scores by name, in report order.
    clear, wrong, hint
        As :func:`assess` returns them.
    """
    scores, clear, wrong, hint = assess(read_tracks(tracks_path, tracks_format), read_tracks(truth_path, truth_format), tolerance, truth_path)
    return {"tracks": str(tracks_path), "truth": str(truth_path), **dataclasses.asdict(scores)}, clear, wrong, hint


def assess(result: Tracks, truth: Tracks, tolerance: float, truth_source) -> tuple[Scores, ClearMotScores, dict[str, np.ndarray], str | None]:
    """Score a result against the truth read from ``truth_source`` (named in errors and hints).

    Returns
    -------
    scores : Scores
        Rates in [0, 1], MOTP in pixels.
    clear : ClearMotScores
        With the per-frame counts.
    wrong : dict of str to ndarray
        :func:`seedtrack.tracking.diagnosis.first_errors` of the result.
    hint : str or None
        When most true points match nothing but would with the truth's frame numbers one off,
        a line that says so (truth numbered from 1 against tracks from 0 is a common slip).

    Raises
    ------
    DataError
        If the truth holds no track or a single frame.
    """
    if truth.n_tracks == 0:
        raise DataError(truth_source, "holds no true tracks; there is nothing to score against")
    if truth.n_frames < 2:
        raise DataError(truth_source, f"holds a single frame ({truth.first_frame}); scoring links needs at least two")
    scores, clear = evaluate_tracks(result, truth, tolerance)
    return scores, clear, first_errors(result, truth, tolerance), _offset_hint(result, truth, tolerance, clear, truth_source)


def _offset_hint(result: Tracks, truth: Tracks, tolerance: float, clear: ClearMotScores, truth_path) -> str | None:
    if clear.num_objects - clear.num_misses >= _WELL_MATCHED * clear.num_objects:
        return None
    # Points with a result point near them, not one-to-one matches: as good a sign at a
    # fraction of the cost, which matters when large poor results are scored.
    near = {shift: _share_near(result, truth, tolerance, shift) for shift in (0, -1, 1)}
    for shift in (-1, 1):
        if near[shift] >= max(_WELL_MATCHED, near[0] + 0.2):
            return (
                f"hint: {near[shift]:.0%} of the true points have a result point within {tolerance:g} px with "
                f"{truth_path}'s frame numbers shifted by {shift:+d} (against {near[0]:.0%} as given); are both "
                "files' frames 0-based?"
            )
    return None


def _share_near(result: Tracks, truth: Tracks, tolerance: float, shift: int) -> float:
    """Share of the true points with a result point within ``tolerance`` pixels in the frame
    ``shift`` frames after theirs."""
    near = 0
    for column in range(truth.n_frames):
        true_points = truth.xy[truth.present[:, column], column]
        other = truth.first_frame + column + shift - result.first_frame
        if true_points.size == 0 or not 0 <= other < result.n_frames:
            continue
        result_points = result.xy[result.present[:, other], other]
        if result_points.size:
            distance = cKDTree(result_points).query(true_points, distance_upper_bound=tolerance)[0]
            near += int(np.count_nonzero(np.isfinite(distance)))
    return near / max(int(truth.present.sum()), 1)


def format_table(measures: dict) -> str:
    """The measures as a two-column text table."""
    width = max(len(name) for name in measures)
    lines = []
    for name, value in measures.items():
        text = f"{value:.6f}" if isinstance(value, float) else str(value)
        lines.append(f"{name:<{width}}  {text}")
    return "\n".join(lines)


def check_tolerance(tol: float) -> None:
    """Refuse a matching distance that is not a positive finite number of pixels.

    Raises
    ------
    UsageError
    """
    if not (tol > 0 and math.isfinite(tol)):
        raise UsageError(f"--tol must be a positive number of pixels, got {tol:g}")


def run(args: argparse.Namespace) -> int:
    check_tolerance(args.tol)
    measures, clear, wrong, hint = evaluate(args.tracks, args.truth, args.tol, args.format, args.truth_format)
    print(format_table(measures))
    if hint is not None:
        print(hint, file=sys.stderr)
    if args.out is not None:
        with output_folder(args.out), atomic_path(args.out / "evaluation.json") as temporary:
            # JSON has no NaN: a measure undefined for empty input is written as null.
            clean = {k: None if isinstance(v, float) and math.isnan(v) else v for k, v in measures.items()}
            temporary.write_text(json.dumps(clean, indent=2) + "\n")
        write_table(args.out / "wrong_tracks.csv", wrong)
        series = {"missed": clear.frame_misses, "false positives": clear.frame_false_positives, "ID switches": clear.frame_switches}
        title = f"errors per frame: {args.tracks.name} against {args.truth.name}, tolerance {args.tol:g} px"
        write_png(args.out / "errors.png", draw_error_plot(clear.frames, series, title))
        print(f"wrote {args.out / 'evaluation.json'}, {args.out / 'wrong_tracks.csv'}, {args.out / 'errors.png'}")
    return 0
