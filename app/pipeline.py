"""The run pipeline: frames -> detections -> tracks -> files and an overlay clip.

Frames are streamed twice (once to detect, once to draw) rather than held in memory, so the
clip's length does not bound what can be processed.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from data.csvio import write_table
from data.errors import DataError
from data.frames import open_frames
from data.trackfile import write_tracks
from data.video import write_video
from detection.blobs import MEASUREMENT_COLUMNS, BlobOptions, detect_blobs
from tracking.goa import GOAConfig, goa_updown, pass_steps
from tracking.tracks import Tracks

from .render import FalseDetections, TrackLayer, View, annotate_frames, track_legend
from .progress import progress_bar


@dataclass(frozen=True)
class Detections:
    """Measurements of every processed frame.

    Attributes
    ----------
    frame_indices : ndarray of int, shape (n_frames,)
        0-based index in the clip of each processed frame.
    columns : list of dict of str to ndarray
        Per processed frame, the detector's columns (``x``, ``y``, ``area``, ...).
    """

    frame_indices: np.ndarray
    columns: list[dict[str, np.ndarray]]

    @property
    def points(self) -> list[np.ndarray]:
        """Per frame, an (M_k, 2) array of (x, y) positions, pixels."""
        return [np.column_stack((c["x"], c["y"])) for c in self.columns]

    def to_rows(self) -> dict[str, np.ndarray]:
        """Columns of ``detections.csv``: frame, x, y, area, then the detector's other columns."""
        names = list(dict.fromkeys(("x", "y", "area", *MEASUREMENT_COLUMNS)))
        counts = [len(c["x"]) for c in self.columns]
        rows = {"frame": np.repeat(self.frame_indices, counts).astype(np.int64)}
        for name in names:
            rows[name] = np.concatenate([c[name] for c in self.columns]) if self.columns else np.empty(0)
        return rows


def detect_clip(path: Path, options: BlobOptions) -> tuple[Detections, float]:
    """Detect blobs in every frame of a clip, with a progress bar.

    Returns
    -------
    Detections
    float
        The clip's frame rate, frames per second.

    Raises
    ------
    DataError
        If the clip cannot be read or holds no frame.
    """
    indices: list[int] = []
    columns: list[dict[str, np.ndarray]] = []
    with open_frames(path) as source:
        with progress_bar(source.frame_count, "detecting") as bar:
            for index, image in source:
                indices.append(index)
                columns.append(detect_blobs(image, options))
                bar.update(1)
        if not indices:
            raise DataError(path, source.stopped_early or "no frame could be read")
        return Detections(np.array(indices), columns), source.fps


def track_detections(detections: Detections, config: GOAConfig) -> Tracks:
    """Link the detections into tracks with GOA-updown, with a progress bar."""
    with progress_bar(pass_steps(len(detections.columns)), "tracking", unit="step") as bar:
        return goa_updown(detections.points, config, progress=bar.update)


def render_overlay(path: Path, tracks: Tracks, detections: Detections, out: Path, fps: float, trail: int = 10) -> None:
    """Write an H.264 clip of the input with the tracks drawn over it (see :mod:`app.render`).

    Detections that no track holds are marked as false detections.
    """
    with open_frames(path) as source:
        view = View.of(source.size)
        layer = TrackLayer(tracks, view, trail=trail, frame_indices=detections.frame_indices)
        rows = detections.to_rows()
        false = FalseDetections(rows["frame"], rows["x"], rows["y"], tracks, view, frame_indices=detections.frame_indices)
        frames = annotate_frames(source, view, [layer], false_detections=false, legend=track_legend(True))
        with progress_bar(source.frame_count, "rendering") as bar:
            write_video(out, (image for _, image in frames), fps, progress=bar)


def prepare_output_folder(folder: Path) -> None:
    """Create the output folder if needed.

    Raises
    ------
    DataError
        If it cannot be created or is not a writable folder.
    """
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise DataError(folder, f"cannot create output folder ({error.strerror})") from None
    if not folder.is_dir():
        raise DataError(folder, "exists and is not a folder")


def run_pipeline(clip: Path, out: Path, options: BlobOptions, config: GOAConfig) -> tuple[Detections, Tracks]:
    """Detect, track, and write ``detections.csv``, ``tracks.csv`` and ``overlay.mp4`` to ``out``.

    Each file is written whole or not at all, in that order, so an interruption keeps what was
    finished.
    """
    prepare_output_folder(out)
    detections, fps = detect_clip(clip, options)
    write_table(out / "detections.csv", detections.to_rows())
    tracks = track_detections(detections, config)
    write_tracks(out / "tracks.csv", tracks, detections.frame_indices)
    render_overlay(clip, tracks, detections, out / "overlay.mp4", fps)
    return detections, tracks
