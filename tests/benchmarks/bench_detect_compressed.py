"""Recall, precision and position error of ``seedtrack detect`` on compressed clips, beside trackpy.

Run as ``python tests/benchmarks/bench_detect_compressed.py [CLIPS]``. Clips of Gaussian spots of
known position are written as a folder of 8-bit PNGs (lossless), as MJPG .avi at JPEG qualities
95, 75 and 50 (OpenCV's writer), as XVID .avi and mp4v .mp4 (OpenCV's writer through FFmpeg) and
as H.264 .mp4 at x264 crf 18 and 28 (:func:`seedtrack.data.video.write_video`), read back as the
command reads them, and detected:

- seedtrack: ``seedtrack detect``'s defaults (:func:`seedtrack.pipeline.detect_clip`, nothing
  given); its least mass and noise floor are printed.
- seedtrack ``--min-mass 200``: the least mass given, half way (on a log scale) between the
  heaviest false maximum (60) and the lightest spot (560) of the tuning clip (*sparse*, seed 0)
  through all these codecs.
- trackpy.locate: diameter 9 (2 round(3 sigma) + 1 for the spots' sigma of about 1.5 px, as the
  spot benchmarks give it), its default ``minmass``, as a user would first run it.

Two generators, both of little noise (about 1.2 and 1.5 grey levels), which compression takes off:
*sparse* (:mod:`seedtrack.data.sparsespots`: 12 spots of sigma 1.5 to 2.5 px and peaks of 60 to
120 grey levels wandering over 320 x 200, on 11 grey levels, 20 frames), whose random seed 0 was
looked at while the least mass was made robust to compression; and *field*
(:mod:`seedtrack.data.spotfield`: 40 spots of sigma 1.5 px a frame at SNR 8 on 320 x 240, a new
field every frame, Poisson noise on 2 photons plus read noise of 0.5, one grey level a photon),
never looked at then. Reported on seeds 1000.. of both. A found point is matched one to one to a true centre
within 2 px.
"""

from __future__ import annotations

import sys
import tempfile
import warnings
from pathlib import Path

import cv2
import numpy as np
import trackpy

from seedtrack.data.frames import open_frames
from seedtrack.data.sparsespots import SparseSpotSpec, make_sparse_spots
from seedtrack.data.spotfield import SpotFieldSpec, make_spot_field
from seedtrack.data.video import write_video
from seedtrack.pipeline import DetectSettings, detect_clip
from seedtrack.tracking.metrics import match_frame

TOLERANCE_PX = 2.0
TRACKPY_DIAMETER = 9
REPORTING_SEED = 1000
FPS = 10.0
CODECS = ("png", "mjpg-95", "mjpg-75", "mjpg-50", "xvid", "mp4v", "h264-crf18", "h264-crf28")


def sparse_clip(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """(frames, true xy per frame) of the *sparse* generator."""
    spec = SparseSpotSpec(
        width=320, height=200, frames=20, spots=12, sigma_range=(1.5, 2.5), peak_range=(60.0, 120.0),
        background=(1.0, 1.0), gain=1.0, read_noise=0.5, offset=10.0, random_seed=seed,
    )
    clip = make_sparse_spots(spec)
    return clip.frames, clip.xy


def field_clip(seed: int) -> tuple[np.ndarray, list[np.ndarray]]:
    """(frames, true xy per frame) of the *field* generator: a new field each frame."""
    fields = [
        make_spot_field(
            SpotFieldSpec(width=320, height=240, spots=40, touching_pairs=0, rings=0, snr=8.0, background=2.0, read_noise=0.5, random_seed=seed * 100 + k)
        )
        for k in range(20)
    ]
    frames = np.stack([np.clip(f.image + 10, 0, 255).round().astype(np.uint8) for f in fields])
    return frames, [f.xy for f in fields]


def write(frames: np.ndarray, codec: str, folder: Path) -> Path:
    """The clip written with ``codec`` under ``folder``; its path."""
    if codec == "png":
        path = folder / "png"
        path.mkdir()
        for k, frame in enumerate(frames):
            cv2.imwrite(str(path / f"frame{k:03d}.png"), frame)
        return path
    if codec.startswith("h264"):
        path = folder / f"{codec}.mp4"
        write_video(path, frames, FPS, crf=int(codec.split("crf")[1]))
        return path
    height, width = frames.shape[1:]
    if codec.startswith("mjpg"):
        path = folder / f"{codec}.avi"
        writer = cv2.VideoWriter(str(path), cv2.CAP_OPENCV_MJPEG, cv2.VideoWriter_fourcc(*"MJPG"), FPS, (width, height))
        writer.set(cv2.VIDEOWRITER_PROP_QUALITY, int(codec.split("-")[1]))
    else:
        path = folder / f"{codec}.{'avi' if codec == 'xvid' else 'mp4'}"
        writer = cv2.VideoWriter(str(path), cv2.CAP_FFMPEG, cv2.VideoWriter_fourcc(*codec.upper() if codec == "xvid" else codec), FPS, (width, height))
    if not writer.isOpened():
        raise RuntimeError(f"OpenCV cannot write {codec}")
    for frame in frames:
        writer.write(cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR))
    writer.release()
    return path


def score(found: list[np.ndarray], truth) -> dict[str, float]:
    true = hits = total = 0
    errors = []
    for points, xy in zip(found, truth):
        rows, cols = match_frame(points, xy, TOLERANCE_PX)
        errors.extend(np.hypot(*(points[rows] - xy[cols]).T))
        true, hits, total = true + len(xy), hits + len(rows), total + len(points)
    errors = np.array(errors)
    return {
        "per_frame": total / len(truth),
        "recall": hits / true,
        "precision": hits / max(total, 1),
        "rms": float(np.sqrt(np.mean(errors**2))) if errors.size else float("nan"),
    }


GIVEN_MIN_MASS = 200.0


def seedtrack_points(path: Path, min_mass: float | None = None) -> tuple[list[np.ndarray], str]:
    result = detect_clip(path, DetectSettings(min_mass=min_mass), say=None)
    found = result.detections
    points = [np.column_stack((t["x"], t["y"])) for t in (found.frame(k) for k in range(len(found.frame_indices)))]
    spots = result.choice.spots
    return points, f"mass {spots.min_mass:.3g}, floor {spots.floor:.3g}" if spots is not None else "blob detector"


def trackpy_points(path: Path) -> list[np.ndarray]:
    with open_frames(path) as source, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return [
            trackpy.locate(cv2.cvtColor(image, cv2.COLOR_BGR2GRAY) if image.ndim == 3 else image, TRACKPY_DIAMETER)[["x", "y"]].to_numpy()
            for _, image in source
        ]


def main() -> None:
    trackpy.quiet()
    cv2.setLogLevel(0) if hasattr(cv2, "setLogLevel") else None
    clips = int(sys.argv[1]) if len(sys.argv) > 1 else 1
    print(f"{clips} reporting clip(s) per generator, seeds {REPORTING_SEED}..; match within {TOLERANCE_PX:g} px")
    print(f"{'generator':<8} {'codec':<11} {'detector':<10} {'per frame':>9} {'recall':>7} {'precision':>9} {'RMS px':>7}  settings")
    for name, make in (("sparse", sparse_clip), ("field", field_clip)):
        for codec in CODECS:
            rows = {"seedtrack": [], "given mass": [], "trackpy": []}
            said = []
            truths = []
            for k in range(clips):
                frames, truth = make(REPORTING_SEED + k)
                truths.extend(truth)
                with tempfile.TemporaryDirectory() as folder:
                    path = write(frames, codec, Path(folder))
                    points, settings = seedtrack_points(path)
                    rows["seedtrack"].extend(points)
                    rows["given mass"].extend(seedtrack_points(path, GIVEN_MIN_MASS)[0])
                    rows["trackpy"].extend(trackpy_points(path))
                said.append(settings)
            for detector, found in rows.items():
                result = score(found, truths)
                print(
                    f"{name:<8} {codec:<11} {detector:<10} {result['per_frame']:>9.1f} {result['recall']:>7.3f} {result['precision']:>9.3f} "
                    f"{result['rms']:>7.3f}  { {'seedtrack': '; '.join(said), 'given mass': f'--min-mass {GIVEN_MIN_MASS:g}'}.get(detector, 'minmass default')}"
                )


if __name__ == "__main__":
    main()
