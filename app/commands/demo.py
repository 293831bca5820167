"""``seedtrack demo --out DIR``: generate a rotating-dish clip, track it, score it."""

from __future__ import annotations

import argparse
from pathlib import Path

from seedtrack.data.atomic import output_folder
from seedtrack.data.dish import DishSpec, write_dish_clip
from seedtrack.data.trackfile import read_tracks
from seedtrack.tracking.evaluation import evaluate_tracks

from ..errors import UsageError, in_option_names
from ..pipeline import DetectSettings, run_pipeline
from ..settings import check_tolerance
from .tracker_options import add_tracker_options, add_verbose_option, tracking_settings


def add_parser(subparsers) -> None:
    defaults = DishSpec()
    parser = subparsers.add_parser(
        "demo",
        description="Generate a synthetic rotating-dish clip with known truth (DIR/clip.mp4, DIR/truth.csv), "
        "run the same pipeline as 'seedtrack run' on it, and print the track error.",
    )
    parser.add_argument("--out", type=Path, required=True, metavar="DIR", help="output folder (created if missing)")
    parser.add_argument("--seeds", type=int, default=defaults.seeds, help=f"number of seeds (default {defaults.seeds})")
    parser.add_argument("--frames", type=int, default=defaults.frames, help=f"frames (default {defaults.frames})")
    parser.add_argument(
        "--rim-speed", type=float, default=defaults.rim_speed, metavar="PX", help=f"speed at the dish rim, pixels/frame (default {defaults.rim_speed:g})"
    )
    parser.add_argument("--random-seed", type=int, default=defaults.random_seed, metavar="N", help=f"seed of the generator (default {defaults.random_seed})")
    parser.add_argument(
        "--hidden-probability", type=float, default=defaults.hidden_probability, metavar="P", help=f"probability that a seed is hidden in a frame (default {defaults.hidden_probability:g})"
    )
    parser.add_argument("--tol", type=float, default=1.0, metavar="PX", help="matching distance to the truth, pixels (default 1)")
    add_tracker_options(parser)
    add_verbose_option(parser)
    parser.set_defaults(run=run)


# Fewer frames than this open no track: a track opens on three measured frames in a row.
_MIN_FRAMES = 3


def run(args: argparse.Namespace) -> int:
    tracking = tracking_settings(args)
    check_tolerance(args.tol)
    if args.seeds < 1:
        raise UsageError(f"--seeds must be at least 1, got {args.seeds}")
    if args.frames < _MIN_FRAMES:
        raise UsageError(f"--frames must be at least {_MIN_FRAMES} (a track opens on three frames in a row), got {args.frames}")
    try:
        spec = DishSpec(
            seeds=args.seeds,
            frames=args.frames,
            rim_speed=args.rim_speed,
            random_seed=args.random_seed,
            hidden_probability=args.hidden_probability,
        )
    except ValueError as error:
        raise UsageError(in_option_names(str(error), ("seeds", "frames", "rim_speed", "random_seed", "hidden_probability"))) from None
    with output_folder(args.out):
        scene = write_dish_clip(spec, args.out)
        run_pipeline(args.out / "clip.mp4", args.out, DetectSettings(), tracking, verbose=args.verbose)
    result = read_tracks(args.out / "tracks.csv")
    scores, _ = evaluate_tracks(result, scene.truth, args.tol)
    print(
        f"{scores.correct_tracks} of {scores.true_tracks} seeds tracked correctly over all {spec.frames} frames "
        f"(track error {scores.track_error:.3f}, link error {scores.link_error:.3f}); "
        f"clip, truth and results in {args.out}"
    )
    return 0
