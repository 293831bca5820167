"""``seedtrack correct TRACKS.csv EDITS.txt --out TRUTH.csv``: apply a corrections file."""

from __future__ import annotations

import argparse
from pathlib import Path

from seedtrack.data.corrections import apply_corrections, read_corrections
from seedtrack.data.trackfile import FORMATS, read_calibration, read_tracks, write_tracks

from ..errors import output_file
from ..outputs import refuse_replacing_inputs
from ..wording import counted


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "correct",
        description="Apply the edits in EDITS.txt (one a line: join A B FRAME, swap A B FRAME, split A FRAME "
        "[NEW_ID], delete A [FRAME], move A FRAME X Y, add A FRAME X Y; # comments) to TRACKS and write the "
        "result. Every line is checked; on any error nothing is written.",
    )
    parser.add_argument("tracks", type=Path, metavar="TRACKS", help="tracks to correct (any track format)")
    parser.add_argument("edits", type=Path, metavar="EDITS", help="corrections file")
    parser.add_argument("--out", type=output_file, required=True, metavar="TRUTH", help="corrected tracks (.csv, .txt, .xml, .geff or .npy)")
    parser.add_argument("--format", choices=sorted(FORMATS), default=None, help="format of TRACKS (default: from the extension and contents)")
    parser.add_argument("--out-format", choices=sorted(FORMATS), default=None, help="format of the output (default: from its extension)")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    refuse_replacing_inputs([args.tracks, args.edits], [args.out])
    tracks = read_tracks(args.tracks, args.format)
    edits = read_corrections(args.edits)
    corrected = apply_corrections(tracks, edits, args.edits)
    # A calibrated TrackMate truth stays in its units.
    write_tracks(args.out, corrected, format=args.out_format, units=read_calibration(args.tracks, args.format))
    print(f"applied {counted(len(edits), 'edit')}: {counted(tracks.n_tracks, 'track')} in, {corrected.n_tracks} out; wrote {args.out}")
    return 0
