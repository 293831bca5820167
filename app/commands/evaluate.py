"""``seedtrack evaluate TRACKS TRUTH``: score a track set against ground truth."""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
from pathlib import Path

from seedtrack.data.csvio import write_table
from seedtrack.data.outputset import MANIFEST, output_set
from seedtrack.data.trackfile import FORMATS, read_tracks

from ..error_plot import draw_error_plot, write_png
from ..errors import UsageError
from ..outputs import refuse_replacing_inputs
from ..scoring import DEFAULT_TOLERANCE, assess
from ..settings import EvaluateSettings
from . import settings_of

# The files --out DIR receives.
EVALUATION_FILES = ("evaluation.json", "wrong_tracks.csv", "errors.png")


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
    parser.add_argument("truth", type=Path, nargs="?", default=None, metavar="TRUTH", help="true tracks, in any of the same formats")
    # The older form, kept working: TRUTH as an option.
    parser.add_argument("--truth", dest="truth_option", type=Path, default=None, metavar="TRUTH", help="TRUTH given as an option instead")
    parser.add_argument("--tol", type=float, default=DEFAULT_TOLERANCE, metavar="PX", help=f"matching distance in pixels (default {DEFAULT_TOLERANCE:g})")
    parser.add_argument("--format", choices=sorted(FORMATS), default=None, help="format of TRACKS (default: from the extension and contents)")
    parser.add_argument("--truth-format", choices=sorted(FORMATS), default=None, help="format of TRUTH (default: from the extension and contents)")
    parser.add_argument("--out", type=Path, default=None, metavar="DIR", help="folder for evaluation.json, wrong_tracks.csv and errors.png")
    parser.set_defaults(run=run)


def evaluate(tracks_path: Path, truth_path: Path, settings: EvaluateSettings = EvaluateSettings()):
    """Read both files and compute every measure.

    Returns
    -------
    measures : dict
        The file names, then :func:`seedtrack.scoring.assess`'s scores by name, in report order.
    clear, wrong, hint
        As :func:`seedtrack.scoring.assess` returns them.
    """
    result, truth = read_tracks(tracks_path, settings.format), read_tracks(truth_path, settings.truth_format)
    scores, clear, wrong, hint = assess(result, truth, settings.tol, truth_path)
    return {"tracks": str(tracks_path), "truth": str(truth_path), **dataclasses.asdict(scores)}, clear, wrong, hint


def format_table(measures: dict) -> str:
    """The measures as a two-column text table."""
    width = max(len(name) for name in measures)
    lines = []
    for name, value in measures.items():
        text = f"{value:.6f}" if isinstance(value, float) else str(value)
        lines.append(f"{name:<{width}}  {text}")
    return "\n".join(lines)


def truth_of(args: argparse.Namespace) -> Path:
    """TRUTH, given after TRACKS or as ``--truth``.

    Raises
    ------
    UsageError
        If it is given both ways or neither.
    """
    if (args.truth is None) == (args.truth_option is None):
        raise UsageError("give TRUTH once: after TRACKS (or as --truth TRUTH)")
    return args.truth if args.truth is not None else args.truth_option


def run(args: argparse.Namespace) -> int:
    args.truth = truth_of(args)
    settings = settings_of(EvaluateSettings, args)
    refuse_replacing_inputs([args.tracks, args.truth], [args.out / name for name in (*EVALUATION_FILES, MANIFEST)] if args.out is not None else [])
    measures, clear, wrong, hint = evaluate(args.tracks, args.truth, settings)
    print(format_table(measures))
    if hint is not None:
        print(hint, file=sys.stderr)
    if args.out is not None:
        with output_set(args.out, "seedtrack evaluate", [args.tracks, args.truth]) as files:
            # JSON has no NaN: a measure undefined for empty input is written as null.
            clean = {k: None if isinstance(v, float) and math.isnan(v) else v for k, v in measures.items()}
            files.path("evaluation.json").write_text(json.dumps(clean, indent=2) + "\n")
            write_table(files.path("wrong_tracks.csv"), wrong)
            series = {"missed": clear.frame_misses, "false positives": clear.frame_false_positives, "ID switches": clear.frame_switches}
            title = f"errors per frame: {args.tracks.name} against {args.truth.name}, tolerance {args.tol:g} px"
            write_png(files.path("errors.png"), draw_error_plot(clear.frames, series, title))
        print(f"wrote {args.out / 'evaluation.json'}, {args.out / 'wrong_tracks.csv'}, {args.out / 'errors.png'}")
    return 0
