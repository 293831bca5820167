"""``seedtrack run INPUT --out DIR``: detect, track and draw a recorded clip."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..errors import UsageError
from ..parallel import default_workers
from ..pipeline import run_pipeline
from ..wording import CLIP_INPUT_HELP, counted
from .detect import add_detection_options, detection_settings
from .tracker_options import add_tracker_options, add_verbose_option, tracking_settings


def add_workers_option(parser: argparse.ArgumentParser) -> None:
    """``--workers N``: threads working on one clip (the files do not depend on it)."""
    parser.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help=f"threads detecting and drawing at once (beside them, with N > 1, an encoder process); the files are the same for any N "
        f"(default: the cores this program may use, here {default_workers()})",
    )


def workers_count(args: argparse.Namespace) -> int:
    """The ``--workers`` asked for, or the cores available.

    Raises
    ------
    UsageError
        If --workers is below 1.
    """
    if args.workers is None:
        return default_workers()
    if args.workers < 1:
        raise UsageError(f"--workers must be a whole number >= 1, got {args.workers}")
    return args.workers


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "run",
        description="Detect blobs in every frame of INPUT, link them into tracks with GOA-updown (tracks open "
        "and end anywhere in the clip unless --fixed-count), and write DIR/detections.csv, DIR/tracks.csv and "
        "DIR/overlay.mp4.",
    )
    parser.add_argument("input", type=Path, metavar="INPUT", help=CLIP_INPUT_HELP)
    parser.add_argument("--out", type=Path, required=True, metavar="DIR", help="output folder (created if missing)")
    add_detection_options(parser)
    add_tracker_options(parser)
    add_verbose_option(parser)
    add_workers_option(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    detections, tracks = run_pipeline(args.input, args.out, detection_settings(args), tracking_settings(args), workers_count(args), args.verbose)
    print(
        f"{counted(detections.frame_indices.size, 'frame')}, {counted(int(detections.counts.sum()), 'detection')}, {counted(tracks.n_tracks, 'track')}; "
        f"wrote {args.out / 'detections.csv'}, {args.out / 'tracks.csv'}, {args.out / 'overlay.mp4'}"
    )
    return 0
