"""``seedtrack run INPUT --out DIR``: detect, track and draw a recorded clip."""

from __future__ import annotations

import argparse
from pathlib import Path

from tracking.goa import GOAConfig

from ..errors import UsageError
from ..pipeline import run_pipeline
from .detect import add_detection_options, detection_settings


def add_tracker_options(parser: argparse.ArgumentParser) -> None:
    """Options of the GOA-updown tracker, shared by every command that tracks."""
    group = parser.add_argument_group("tracker")
    group.add_argument(
        "--max-speed",
        type=float,
        default=None,
        metavar="PX",
        help="largest speed in pixels/frame (d_max); default: no limit, the motion model decides",
    )
    group.add_argument(
        "--phi-max",
        type=float,
        default=0.1,
        metavar="X",
        help="largest smoothness cost of a link (IM2, 0..1.1); also the cost of a missed or false point (default 0.1)",
    )


def tracker_config(args: argparse.Namespace) -> GOAConfig:
    """The tracker configuration the options ask for.

    Raises
    ------
    UsageError
        If the options make no sense.
    """
    try:
        return GOAConfig(phi_max=args.phi_max, d_max=args.max_speed)
    except ValueError as error:
        raise UsageError(str(error)) from None


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "run",
        help="detect, track and draw a clip",
        description="Detect blobs in every frame of INPUT, link them into tracks with GOA-updown, and write "
        "DIR/detections.csv, DIR/tracks.csv and DIR/overlay.mp4.",
    )
    parser.add_argument("input", type=Path, metavar="INPUT", help="video file, image folder or glob pattern")
    parser.add_argument("--out", type=Path, required=True, metavar="DIR", help="output folder (created if missing)")
    add_detection_options(parser)
    add_tracker_options(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    settings = detection_settings(args)
    config = tracker_config(args)
    detections, tracks = run_pipeline(args.input, args.out, settings, config)
    measured = sum(len(c["x"]) for c in detections.columns)
    print(
        f"{len(detections.columns)} frames, {measured} detections, {tracks.n_tracks} tracks; "
        f"wrote {args.out / 'detections.csv'}, {args.out / 'tracks.csv'}, {args.out / 'overlay.mp4'}"
    )
    return 0
