"""``seedtrack review INPUT TRACKS.csv --out DIR``: PNG pages of frames with every track id."""

from __future__ import annotations

import argparse
from pathlib import Path

from seedtrack.data.atomic import output_folder
from seedtrack.data.frames import open_frames
from seedtrack.data.trackfile import FORMATS, read_tracks

from ..error_plot import write_png
from ..errors import UsageError
from ..progress import progress_bar
from ..review import draw_review_page
from ..rendering import check_fits
from ..wording import CLIP_INPUT_HELP, counted

DEFAULT_EVERY = 5


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "review",
        description="Write DIR/review_FFFFFF.png for every Nth frame of INPUT (and the last frame of the tracks): "
        "the frame enlarged, each track's position, recent path and id in large print.",
    )
    parser.add_argument("input", type=Path, metavar="INPUT", help=CLIP_INPUT_HELP)
    parser.add_argument("tracks", type=Path, metavar="TRACKS", help="tracks to review (any track format)")
    parser.add_argument("--out", type=Path, required=True, metavar="DIR", help="output folder (created if missing)")
    parser.add_argument("--every", type=int, default=DEFAULT_EVERY, metavar="N", help=f"draw every Nth frame (default {DEFAULT_EVERY})")
    parser.add_argument("--format", choices=sorted(FORMATS), default=None, help="format of TRACKS (default: from the extension and contents)")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    if args.every < 1:
        raise UsageError(f"--every must be at least 1, got {args.every}")
    tracks = read_tracks(args.tracks, args.format)
    last = tracks.first_frame + tracks.n_frames - 1
    wanted = set(range(tracks.first_frame, last + 1, args.every)) | {last}
    written = 0
    with open_frames(args.input) as whole:
        rows = tracks.to_rows()
        # Before the output folder exists: another clip's tracks leave nothing behind.
        check_fits(args.tracks, rows["frame"], rows["x"], rows["y"], whole, args.input)
    with open_frames(args.input, start=tracks.first_frame, end=last + 1) as source:
        with output_folder(args.out), progress_bar(source.frame_count, "review") as bar:
            for index, image in source.shown():
                if index in wanted:
                    page = draw_review_page(image, tracks, index - tracks.first_frame, index)
                    write_png(args.out / f"review_{index:06d}.png", page)
                    written += 1
                bar.update()
    print(f"wrote {counted(written, 'review page')} of {counted(tracks.n_tracks, 'track')} to {args.out}")
    return 0
