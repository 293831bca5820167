"""``seedtrack synth psmg --out DIR``: synthetic point sets with ground truth."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

from seedtrack.data.csvio import write_table
from seedtrack.data.numbers import MAX_COORDINATE_PX, MAX_FRAME
from seedtrack.data.outputset import output_set
from seedtrack.data.psmg import PSMGSpec, generate_psmg
from seedtrack.data.trackfile import write_tracks

from ..errors import UsageError, option_name
from ..experiments import BASE
from ..wording import counted

# Option name -> PSMGSpec field, for the float parameters; the defaults are the base scene of
# ``seedtrack experiment``.
_FLOAT_OPTIONS = {
    "size": ("size", "side of the square view, pixels"),
    "mean_speed": ("mean_speed", "mean initial speed, pixels/frame"),
    "speed_sigma": ("speed_sigma", "standard deviation of the initial speed, pixels/frame"),
    "speed_step_sigma": ("speed_step_sigma", "standard deviation of the speed change per frame, pixels/frame"),
    "angle_step_sigma": ("angle_step_sigma", "standard deviation of the direction change per frame, degrees"),
    "occlusion": ("occlusion", "probability that a point is missed in a frame (single frames, never in the first or last three)"),
}


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "synth",
        description="Generate synthetic data with known truth, to test trackers on.",
    )
    kinds = parser.add_subparsers(dest="kind", required=True, metavar="KIND")
    psmg = kinds.add_parser(
        "psmg",
        help="random smooth point trajectories (Chetverikov's point set motion generator)",
        description="Draw point trajectories as Chetverikov's PSMG does (uniform start and direction, normal "
        "speed, Gaussian steps of speed and direction, speed clipped to [0, --max-speed]); keep only those that "
        "stay in the view for every frame (or, with --entry-exit, pass through it), and hide points at random. Write DIR/points.csv (frame,x,y; the "
        "measured points, shuffled within each frame) and DIR/truth.csv (track_id,frame,x,y,interpolated; "
        "interpolated=1 where the point was hidden; no row where it is out of view). Frames are 0-based, positions in pixels. The same "
        "options and --seed give the same files.",
    )
    psmg.add_argument("--out", type=Path, required=True, metavar="DIR", help="output folder (created if missing)")
    psmg.add_argument("--tracks", type=int, default=BASE.trajectories, metavar="N", help=f"number of trajectories (default {BASE.trajectories})")
    psmg.add_argument("--frames", type=int, default=BASE.frames, metavar="N", help=f"number of frames (default {BASE.frames})")
    for option, (name, text) in _FLOAT_OPTIONS.items():
        default = getattr(BASE, name)
        psmg.add_argument(option_name(option), type=float, default=default, help=f"{text} (default {default:g})")
    psmg.add_argument("--max-speed", type=float, default=None, metavar="PX", help="largest speed, pixels/frame (default twice --mean-speed)")
    psmg.add_argument("--max-gap", type=int, default=1, metavar="N", help="longest occlusion, frames; each lasts 1 to N (default 1)")
    psmg.add_argument(
        "--entry-exit",
        action="store_true",
        help="let points enter and leave the view (trajectories in view in at least 3 frames); default: every "
        "trajectory stays in view throughout",
    )
    psmg.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    psmg.set_defaults(run=run)


def psmg_spec(args: argparse.Namespace) -> PSMGSpec:
    """The generator settings the options ask for.

    Raises
    ------
    UsageError
        If a value is not finite or out of range.
    """
    values = {name: getattr(args, option) for option, (name, _) in _FLOAT_OPTIONS.items()}
    if args.max_speed is not None:
        values["max_speed"] = args.max_speed
    for name, value in values.items():
        if not math.isfinite(value):
            raise UsageError(f"{option_name(name)} must be a finite number, got {value:g}")
    if values["size"] > MAX_COORDINATE_PX:
        # Every reader refuses positions beyond this: points.csv would be unreadable.
        raise UsageError(f"--size must be at most {MAX_COORDINATE_PX:g} pixels, got {values['size']:g}")
    if args.max_speed is not None and not args.max_speed > 0:
        raise UsageError(f"--max-speed must be positive, got {args.max_speed:g}")
    if args.tracks < 1 or args.frames < 2:
        raise UsageError(f"need at least 1 track and 2 frames, got --tracks {args.tracks} --frames {args.frames}")
    if args.frames > MAX_FRAME + 1:
        # The files would hold frames that every reader refuses.
        raise UsageError(f"--frames must be at most {MAX_FRAME + 1}, got {args.frames}")
    try:
        return PSMGSpec(
            trajectories=args.tracks,
            frames=args.frames,
            max_gap=args.max_gap,
            entry_exit=args.entry_exit,
            random_seed=args.seed,
            **values,
        )
    except ValueError as error:
        raise UsageError(str(error)) from None


def run(args: argparse.Namespace) -> int:
    spec = psmg_spec(args)
    try:
        frames, truth = generate_psmg(spec)
    except ValueError as error:
        raise UsageError(f"{error}; use a larger --size or a lower --mean-speed") from None
    xy = np.concatenate(frames)
    frame = np.repeat(np.arange(len(frames)), [len(f) for f in frames])
    with output_set(args.out, "seedtrack synth", []) as files:
        write_table(files.path("points.csv"), {"frame": frame, "x": xy[:, 0], "y": xy[:, 1]})
        write_tracks(files.path("truth.csv"), truth)
    print(f"{counted(truth.n_tracks, 'trajectory', 'trajectories')}, {len(frames)} frames, {counted(frame.size, 'point')}; wrote {args.out / 'points.csv'}, {args.out / 'truth.csv'}")
    return 0
