"""``seedtrack detect INPUT --out detections.csv``: measure objects in every frame, no tracking.

The detection options are defined here once and shared by every command that detects.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import numpy as np

from seedtrack.data.atomic import atomic_path, check_target
from seedtrack.data.csvio import check_table_name, write_table
from seedtrack.data.errors import DataError
from seedtrack.data.frames import IMAGE_SUFFIXES
from seedtrack.detection.blobs import BACKGROUNDS, POLARITIES
from seedtrack.detection.choice import describe
from seedtrack.detection.roi import Circle

from ..errors import UsageError, output_file
from ..outputs import refuse_replacing_inputs
from ..parallel import default_workers
from ..drawing import SHIFT, draw_text, to_fixed
from ..pipeline import DETECTORS, DetectSettings, detect_clip
from ..review import review_zoom
from ..wording import CLIP_INPUT_HELP, counted
from . import settings_of

_FOUND_BGR = (0, 0, 255)
_ROI_BGR = (0, 200, 0)


def add_detection_options(parser: argparse.ArgumentParser) -> None:
    """Options of the detector and of the frames read, shared by every command that detects."""
    defaults = DetectSettings()
    group = parser.add_argument_group("detection")
    group.add_argument(
        "--detector",
        choices=DETECTORS,
        default="auto",
        help="blob: threshold and connected pixels, split where touching (seeds: dark, elongated, touching); "
        "spot: band-pass, local maxima and brightness centroids, Crocker and Grier (beads, particles: small, "
        "round, faint); auto: spot when the first frame's strongest objects are small and round, else blob "
        "(default auto)",
    )
    group.add_argument(
        "--diameter",
        type=int,
        default=None,
        metavar="PX",
        help="spot diameter, pixels, odd, a little larger than a spot (default: measured on the first frame)",
    )
    group.add_argument(
        "--min-mass",
        type=float,
        default=None,
        metavar="M",
        help="spot detector: least integrated brightness of a spot (the band-passed frame summed over its "
        "disc, grey levels times pixels; the 'least mass' the detector line and --preview print) (default: "
        "set from the noise measured on the first frame)",
    )
    group.add_argument(
        "--snr",
        type=float,
        default=None,
        metavar="R",
        help="spot detector: signal-to-background ratio, the least mass as a multiple of the typical mass of the "
        "background's own maxima (blur, compression blocks, uneven light); higher finds fewer, surer spots; "
        "the detector line and --preview print the ratio and count in use (default: where the first frame's "
        "masses show objects apart from background, else from the noise; --min-mass wins)",
    )
    group.add_argument(
        "--polarity",
        choices=POLARITIES,
        default=defaults.polarity,
        help="objects darker or lighter than the background; auto decides on the first frame (default auto)",
    )
    group.add_argument(
        "--background",
        choices=BACKGROUNDS,
        default=defaults.background,
        help="what contrast is measured against: local, a median over --background-size windows (uneven "
        "light); none, the frame's median grey; temporal, the per-pixel median over the clip (static "
        "camera and scene) (default local)",
    )
    group.add_argument(
        "--background-size",
        type=float,
        default=defaults.background_size,
        metavar="PX",
        help=f"window of the local background, pixels; well above an object's size (default {defaults.background_size:g})",
    )
    group.add_argument(
        "--threshold",
        default=defaults.threshold,
        metavar="otsu|adaptive|N",
        help="object pixels: otsu, Otsu's level among pixels above the noise; adaptive, local mean + 3 local "
        "standard deviations; N, a contrast of at least N grey levels (default otsu)",
    )
    group.add_argument("--min-area", type=float, default=defaults.min_area, metavar="PX", help=f"smallest object, pixels (default {defaults.min_area:g})")
    group.add_argument("--max-area", type=float, default=None, metavar="PX", help="largest object, pixels (default 1%% of the frame)")
    group.add_argument(
        "--roi",
        default="auto",
        metavar="auto|none|X,Y,R|MASK.png",
        help="where to look: auto, the dish if the frame clearly shows a large bright disc, else everywhere; "
        "none, everywhere; X,Y,R a circle in pixels; or a mask image of the frames' size, nonzero inside (default auto)",
    )
    group.add_argument(
        "--split",
        action=argparse.BooleanOptionalAction,
        default=defaults.split,
        help="split blobs of touching objects (default on)",
    )
    frames = parser.add_argument_group("frames")
    frames.add_argument("--start", type=int, default=0, metavar="F", help="first 0-based frame (default 0)")
    frames.add_argument("--end", type=int, default=None, metavar="F", help="0-based frame to stop before (default: the end)")
    frames.add_argument("--step", type=int, default=1, metavar="N", help="every Nth frame (default 1)")


def detection_settings(args: argparse.Namespace) -> DetectSettings:
    """The detection settings the options ask for (an OptionError names an option that makes no sense)."""
    return settings_of(DetectSettings, args)


def draw_preview(
    frame: np.ndarray, columns: dict[str, np.ndarray], roi: np.ndarray | None, circle: Circle | None, frame_index: int, detector: str = ""
) -> np.ndarray:
    """The frame enlarged, each detection ringed in red at its size and the region of interest
    outlined in green, with the frame index, the count and ``detector`` (which detector ran,
    its size and threshold) written in the corner.

    Returns
    -------
    ndarray of uint8, shape (zoom * H, zoom * W, 3) BGR
    """
    zoom = review_zoom(frame.shape[1])
    page = cv2.resize(frame, None, fx=zoom, fy=zoom, interpolation=cv2.INTER_NEAREST)

    def at(points: np.ndarray) -> np.ndarray:
        # Pixel centres sit at integer coordinates: pixel c covers [c - 0.5, c + 0.5).
        return to_fixed((points + 0.5) * zoom - 0.5)

    if circle is not None:
        centre = at(np.array([circle.x, circle.y]))
        cv2.circle(page, tuple(int(c) for c in centre), int(round(circle.r * zoom * (1 << SHIFT))), _ROI_BGR, 1, cv2.LINE_AA, SHIFT)
    elif roi is not None:
        outline, _ = cv2.findContours((roi > 0).astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
        cv2.drawContours(page, [c * zoom + zoom // 2 for c in outline], -1, _ROI_BGR, 1, cv2.LINE_AA)
    centres = at(np.column_stack((columns["x"], columns["y"])))
    radii = np.round((np.sqrt(columns["area"] / np.pi) + 1.5) * zoom * (1 << SHIFT)).astype(int)
    for (x, y), r in zip(centres, radii):
        cv2.circle(page, (int(x), int(y)), int(r), _FOUND_BGR, 1, cv2.LINE_AA, SHIFT)
    draw_text(page, f"frame {frame_index}: {len(columns['x'])} found", (8, 24), (255, 255, 255), 0.7, 1)
    if detector:
        draw_text(page, detector, (8, 52), (255, 255, 255), 0.6, 1)
    return page


def preview_caption(choice, settings: DetectSettings) -> str:
    """Which detector ran, with its size and threshold, in a few words for the preview."""
    if choice.spots is not None:
        return f"spot detector: {describe(choice.spots)}"
    options = settings.options
    threshold = options.threshold if isinstance(options.threshold, str) else f"{options.threshold:g} grey levels"
    return f"blob detector: threshold {threshold}, area {options.min_area_px or 0:g} px and up"


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "detect",
        description="Find objects in every frame of INPUT and write OUT (CSV: frame,x,y,area,mean_intensity,"
        "eccentricity,ep; 0-based frames, pixels, x right and y down, pixel centres at integer coordinates; "
        "ep each centre's localisation error, pixels per axis, which track and run take as the floor of the motion's noise). "
        "--preview draws what was found and the region of interest on one frame.",
    )
    parser.add_argument("input", type=Path, metavar="INPUT", help=CLIP_INPUT_HELP)
    parser.add_argument("--out", type=output_file, required=True, metavar="detections.csv", help="output CSV")
    parser.add_argument("--preview", type=output_file, default=None, metavar="PNG", help="write a preview image of one frame")
    parser.add_argument("--preview-frame", type=int, default=None, metavar="F", help="0-based frame of the preview (default: the first processed)")
    add_detection_options(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    settings = detection_settings(args)
    preview_frame = None
    if args.preview is not None:
        preview_frame = args.preview_frame if args.preview_frame is not None else settings.start
        if args.preview.suffix.lower() not in IMAGE_SUFFIXES:
            raise UsageError(f"--preview {args.preview}: name an image file ({', '.join(IMAGE_SUFFIXES)})")
    elif args.preview_frame is not None:
        raise UsageError("--preview-frame needs --preview PNG")
    # Found out now rather than after a long clip has been read.
    check_table_name(args.out)
    refuse_replacing_inputs([args.input, settings.roi if isinstance(settings.roi, Path) else None], [args.out, args.preview])
    for target in (args.out, args.preview):
        if target is not None:
            check_target(target)
    # As many detection threads as cores: the detections do not depend on the number.
    found = detect_clip(args.input, settings, preview_frame, workers=default_workers())
    rows = found.detections.to_rows()
    write_table(args.out, rows)
    frames = len(found.detections.frame_indices)
    message = (
        f"{counted(frames, 'frame')} ({found.fps:.4g} frames/s), {counted(len(rows['frame']), 'detection')} "
        f"({len(rows['frame']) / frames:.1f} per frame); wrote {args.out}"
    )
    if args.preview is not None:
        if found.preview is None:
            message += f"; no preview: frame {preview_frame} was not read"
        else:
            column = int(np.searchsorted(found.detections.frame_indices, preview_frame))
            page = draw_preview(found.preview, found.detections.frame(column), found.roi, found.circle, preview_frame, preview_caption(found.choice, settings))
            with atomic_path(args.preview) as temporary:
                if not cv2.imwrite(str(temporary), page):
                    raise DataError(args.preview, "cannot write the preview image")
            message += f", {args.preview}"
    print(message)
    return 0
