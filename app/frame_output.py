"""Write annotated frames where the user asked: an H.264 MP4, an animated GIF, one PNG, or a folder of PNGs.

Every file appears whole or not at all (written beside its name, then renamed), so an
interruption or an error leaves no partial file under the output name; a folder keeps the
frames finished before it.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Iterable

import cv2
import numpy as np
from PIL import Image

from seedtrack.data.atomic import atomic_path, output_folder
from seedtrack.data.errors import DataError
from seedtrack.data.video import write_video

from .error_plot import write_png
from .progress import progress_bar

KINDS = {".mp4": "mp4", ".gif": "gif", ".png": "png"}


def output_kind(out: str) -> str:
    """What ``out`` asks for: ``"mp4"``, ``"gif"``, ``"png"`` or ``"folder"``.

    A name ending in a slash, without an extension, or naming an existing folder is a folder.

    Raises
    ------
    DataError
        If the extension is not one of .mp4, .gif or .png.
    """
    path = Path(out)
    if out.endswith(("/", os.sep)) or path.is_dir() or not path.suffix:
        return "folder"
    kind = KINDS.get(path.suffix.lower())
    if kind is None:
        raise DataError(out, f"unsupported output extension {path.suffix!r}; use .mp4 (H.264), .gif, .png (one frame) or a folder")
    return kind


def write_frames(out: str, frames: Iterable[tuple[int, np.ndarray]], fps: float, total: int | None) -> int:
    """Write ``(frame_index, image)`` pairs (BGR uint8, all one size) as :func:`output_kind` says.

    Parameters
    ----------
    out : str
        Output file or folder; a folder receives ``frame_FFFFFF.png`` per 0-based frame index.
    frames : iterable of (int, ndarray)
    fps : float
        Frames per second of a clip or GIF.
    total : int or None
        Expected number of frames, for the progress bar.

    Returns
    -------
    int
        Number of frames written.

    Raises
    ------
    DataError
        If the output cannot be written, or there is no frame to write.
    """
    kind = output_kind(out)
    with progress_bar(total, "rendering") as bar:
        if kind == "mp4":
            try:
                return write_video(out, (image for _, image in frames), fps, progress=bar)
            except ValueError as error:
                raise DataError(out, str(error)) from None
        if kind == "gif":
            return _write_gif(Path(out), frames, fps, bar)
        if kind == "png":
            first = next(iter(frames), None)
            if first is None:
                raise DataError(out, "no frame to write")
            write_png(Path(out), first[1])
            bar.update(1)
            return 1
        folder = Path(out)
        count = 0
        with output_folder(folder):
            for index, image in frames:
                write_png(folder / f"frame_{index:06d}.png", image)
                count += 1
                bar.update(1)
        return count


def _write_gif(path: Path, frames: Iterable[tuple[int, np.ndarray]], fps: float, bar) -> int:
    with atomic_path(path) as temporary:
        # Each frame is reduced to its own 256-colour palette as it arrives (GIF needs every
        # frame before writing), which keeps memory at one byte per pixel.
        images = []
        for _, image in frames:
            rgb = Image.fromarray(cv2.cvtColor(image, cv2.COLOR_BGR2RGB))
            images.append(rgb.quantize(256, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE))
            bar.update(1)
        if not images:
            raise DataError(path, "no frame to write")
        # GIF delays are whole hundredths of a second.
        images[0].save(temporary, format="GIF", save_all=True, append_images=images[1:], duration=max(20, int(round(1000 / fps, -1))), loop=0)
    return len(images)
