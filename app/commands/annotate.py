"""``seedtrack annotate INPUT [TRACKS] --out DIR``: make or fix ground truth in the browser."""

from __future__ import annotations

import argparse
import sys
import webbrowser
from pathlib import Path

from seedtrack.data.atomic import output_folder
from seedtrack.data.csvio import read_table
from seedtrack.data.trackfile import FORMATS, read_tracks
from seedtrack.tracking.tracks import Tracks

from ..annotate.frames import FrameCache
from ..annotate.server import AnnotateServer
from ..annotate.session import CORRECTIONS, SESSION_FILES, TRACKS, Session
from ..errors import UsageError
from ..outputs import refuse_replacing_inputs
from ..wording import CLIP_INPUT_HELP


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "annotate",
        description="Serve a page on this machine that shows INPUT with TRACKS (or no tracks, to track by hand) "
        "and turns clicks into edits: select a track, click the point it should have (a link, a swap from that "
        "frame on, a moved or added point), split, delete, undo, and jump to the places the tracker was least "
        "sure of. Every edit is saved at once to DIR/corrections.txt (for `seedtrack correct`); DIR/tracks.csv follows a moment later and at the end. "
        "The first line printed is the page's address, with its secret token; stop with Ctrl-C.",
    )
    parser.add_argument("input", type=Path, metavar="INPUT", help=CLIP_INPUT_HELP)
    parser.add_argument("tracks", type=Path, nargs="?", default=None, metavar="TRACKS", help="tracks to correct (any track format); none: track by hand")
    parser.add_argument("--out", type=Path, required=True, metavar="DIR", help="folder for corrections.txt and tracks.csv (an earlier session's edits there are resumed)")
    parser.add_argument("--detections", type=Path, default=None, metavar="CSV", help="detections.csv (frame,x,y,...): points a click snaps to")
    parser.add_argument("--compare", type=Path, default=None, metavar="OTHER", help="a second result for INPUT (any track format): the links where it disagrees with TRACKS are doubtful places")
    parser.add_argument("--format", choices=sorted(FORMATS), default=None, help="format of TRACKS and OTHER (default: from the extension and contents)")
    parser.add_argument("--host", default="127.0.0.1", metavar="H", help="address to listen on (default 127.0.0.1: this machine only)")
    parser.add_argument("--port", type=int, default=0, metavar="N", help="port to listen on (default: any free one)")
    parser.add_argument("--no-browser", action="store_true", help="print the address but do not open a browser")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    if not 0 <= args.port <= 65535:
        raise UsageError(f"--port must be in 0..65535, got {args.port}")
    refuse_replacing_inputs([args.input, args.tracks, args.detections, args.compare], [args.out / name for name in SESSION_FILES])
    start = read_tracks(args.tracks, args.format) if args.tracks is not None else Tracks.from_rows([], [], [], [])
    detections = read_table(args.detections, required=("frame", "x", "y")) if args.detections is not None else None
    other = read_tracks(args.compare, args.format) if args.compare is not None else None
    frames = FrameCache(args.input)
    with output_folder(args.out) as folder:
        session = Session(start, folder, args.tracks)
    try:
        server = AnnotateServer(session, frames, detections, other, host=args.host, port=args.port)
    except OSError as error:
        raise UsageError(f"cannot listen on {args.host}:{args.port} ({error.strerror})") from None
    print(server.url, flush=True)
    print(f"saving every edit to {args.out / CORRECTIONS} and {args.out / TRACKS}; stop with Ctrl-C", file=sys.stderr, flush=True)
    if not args.no_browser:
        webbrowser.open(server.url)
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        pass
    finally:
        server.server_close()
        # An edit being saved finishes first, and tracks.csv catches up with the edits.
        session.close()
        frames.close()
    print(f"stopped; {len(session.edits)} edits in {args.out / CORRECTIONS}", file=sys.stderr)
    return 0
