"""seedtrack against trackpy's confident tracks on real bead footage, default options.

Run as ``python tests/benchmarks/bench_bulk_water.py [CLIP]`` (default
``shared/data/bulk-water-240-479.mp4`` beside the checkout). The reference is trackpy as its tutorial runs it on
this recording: ``batch(frames, diameter=11, minmass=20, invert=True)``, ``link(search_range=5,
memory=3)``, ``filter_stubs(25)``: tracks of 25 frames or more, so real beads. Prints

- detection: the share of the confident tracks' positions that ``seedtrack run`` (defaults) has a
  detection for within 1 px;
- tracking: the share of confident tracks that one seedtrack track reproduces, meaning that a
  single seedtrack track lies within 1 px of at least 80% of the confident track's points (in
  the same frames; interpolated positions count, as they stand for the bead).

and, to tell the beads a person sees from trackpy's own background features: of the confident
tracks' positions inside the crops where beads were marked by looking (``bead_truth.py``), the
share that lie on a marked bead (within 3 px), and the share of each kind seedtrack detects.

And, to tell detection from linking apart: how many confident tracks seedtrack's detections hold
at 80% of their points within 1 px (the most any linker could reproduce from them); how many
trackpy's linker (its settings above) reproduces from seedtrack's detections; and how many
seedtrack's linker (``seedtrack.link``, track's defaults) reproduces from trackpy's own
detections (all of them, ``batch`` as above), where detection cannot be the cause.

With ``--beside OPTIONS`` it also measures ``seedtrack run`` with those options (such as
``--min-mass 6.7``, the earlier default's least mass), and with ``--write-docs`` writes the
figures of both into ``docs/detection.md``'s ``bulk-water-confident`` table.

With ``--context`` it also prints what the goal asks of any detector and linker other than the
reference itself: how many confident tracks trackpy reproduces with one of its settings changed to
another a user might pick (detection at noise_size 1.5, diameter 9 or 13, then linked as above;
linking trackpy's own detections at search_range 4 or memory 1), and laptrack (search and gap
closing as trackpy's: 5 px, 3 frames) on trackpy's detections.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd
import trackpy
from scipy.spatial import cKDTree

import seedtrack
from bead_truth import CROPS, SIDE, TRUTH_DIR
from tables import write_table
from seedtrack.data.csvio import read_table
from seedtrack.data.frames import open_frames
from seedtrack.detection.blobs import to_gray

# trackpy's clip in shared/data beside the checkout (or beside the folder of worktrees).
CLIP = next(
    (folder / "shared" / "data" / "bulk-water-240-479.mp4" for folder in Path(__file__).resolve().parents if (folder / "shared" / "data").is_dir()),
    Path("bulk-water-240-479.mp4"),
)
# A confident track is reproduced when one track holds this share of its points within 1 px.
REPRODUCED_SHARE = 0.8
TOLERANCE_PX = 1.0


# trackpy as its tutorial runs it on this recording.
LOCATE = {"diameter": 11, "minmass": 20}
LINK = {"search_range": 5, "memory": 3}


def grey_frames(clip: Path) -> list[np.ndarray]:
    with open_frames(clip) as source:
        return [to_gray(image) for _, image in source]


def trackpy_features(frames: list[np.ndarray], **changed) -> pd.DataFrame:
    trackpy.quiet()
    return trackpy.batch(frames, invert=True, processes=1, **(LOCATE | changed))


def confident_tracks(frames: list[np.ndarray]) -> tuple[pd.DataFrame, pd.DataFrame]:
    """trackpy's features and its confident tracks (frame, x, y, particle), as its tutorial makes them."""
    features = trackpy_features(frames)
    return features, trackpy.filter_stubs(trackpy.link(features, **LINK), 25)


def held(reference: pd.DataFrame, detections: dict[str, np.ndarray]) -> int:
    """Confident tracks with at least 80% of their points within 1 px of a detection."""
    hit = pd.Series(found_within(reference, detections) >= 0).groupby(reference["particle"].to_numpy()).mean()
    return int(np.sum(hit.to_numpy() >= REPRODUCED_SHARE))


def trackpy_linked(detections: dict[str, np.ndarray], **changed) -> dict[str, np.ndarray]:
    table = pd.DataFrame({name: detections[name] for name in ("frame", "x", "y")})
    linked = trackpy.link(table, **(LINK | changed))
    return {"frame": linked["frame"].to_numpy(), "x": linked["x"].to_numpy(), "y": linked["y"].to_numpy(), "track_id": linked["particle"].to_numpy()}


def seedtrack_linked(features: pd.DataFrame) -> dict[str, np.ndarray]:
    linked = seedtrack.link(features[["frame", "x", "y"]].reset_index(drop=True))
    return {name: linked[name].to_numpy() for name in ("frame", "x", "y", "track_id")}


def laptrack_linked(features: pd.DataFrame) -> dict[str, np.ndarray]:
    from laptrack import LapTrack

    reach, gap = LINK["search_range"], LINK["memory"]
    linker = LapTrack(
        metric="sqeuclidean", cutoff=reach**2, gap_closing_metric="sqeuclidean", gap_closing_cutoff=reach**2, gap_closing_max_frame_count=gap
    )
    linked, _, _ = linker.predict_dataframe(features[["frame", "x", "y"]].reset_index(drop=True), ["x", "y"], only_coordinate_cols=False)
    return {"frame": linked["frame"].to_numpy(), "x": linked["x"].to_numpy(), "y": linked["y"].to_numpy(), "track_id": linked["track_id"].to_numpy()}


def as_columns(features: pd.DataFrame) -> dict[str, np.ndarray]:
    return {name: features[name].to_numpy() for name in ("frame", "x", "y")}


def context(frames: list[np.ndarray], features: pd.DataFrame, reference: pd.DataFrame) -> None:
    """What the goal asks of anything but the reference: trackpy with one setting changed, laptrack."""
    total = reference["particle"].nunique()
    print("  the same confident tracks reproduced by trackpy with one setting changed, and by laptrack:")
    for changed in ({"noise_size": 1.5}, {"diameter": 9}, {"diameter": 13}):
        located = as_columns(trackpy_features(frames, **changed))
        count = reproduced(reference, trackpy_linked(located))[0]
        print(f"    trackpy, locate {changed}, linked as the reference: {count} of {total}, {count / total:.4f} (held {held(reference, located)})")
    detections = as_columns(features)
    for changed in ({"search_range": 4}, {"memory": 1}):
        count = reproduced(reference, trackpy_linked(detections, **changed))[0]
        print(f"    trackpy, the reference's detections, link {changed}: {count} of {total}, {count / total:.4f}")
    count = reproduced(reference, laptrack_linked(features))[0]
    print(f"    laptrack (5 px, gaps of 3 frames) on the reference's detections: {count} of {total}, {count / total:.4f}")


def found_within(reference: pd.DataFrame, table: dict[str, np.ndarray], ids: np.ndarray | None = None) -> np.ndarray:
    """Per reference point, the index of the nearest row of ``table`` in its frame within 1 px, or -1."""
    nearest = np.full(len(reference), -1)
    frames = reference["frame"].to_numpy()
    for frame in np.unique(frames):
        here = np.flatnonzero(table["frame"] == frame)
        wanted = np.flatnonzero(frames == frame)
        if here.size == 0:
            continue
        distance, index = cKDTree(np.column_stack((table["x"][here], table["y"][here]))).query(
            reference[["x", "y"]].to_numpy()[wanted], distance_upper_bound=TOLERANCE_PX
        )
        close = np.isfinite(distance)
        nearest[wanted[close]] = here[index[close]]
    return nearest


def on_marked_beads(reference: pd.DataFrame, detections: dict[str, np.ndarray]) -> pd.DataFrame:
    """Per confident-track position 3 px or more inside a marked crop of a marked frame: whether
    a marked bead lies within 3 px, and whether ``detections`` hold it within 1 px."""
    truth = pd.read_csv(TRUTH_DIR / "truth.csv")
    parts = []
    for (frame, crop), marks in truth.groupby(["frame", "crop"]):
        x0, y0 = CROPS[crop]
        inside = reference[
            (reference.frame == frame) & reference.x.between(x0 + 3, x0 + SIDE - 4) & reference.y.between(y0 + 3, y0 + SIDE - 4)
        ]
        distance, _ = cKDTree(marks[["x", "y"]].to_numpy()).query(inside[["x", "y"]].to_numpy(), distance_upper_bound=3.0)
        parts.append(pd.DataFrame({"bead": np.isfinite(distance), "found": found_within(inside, detections) >= 0}))
    return pd.concat(parts, ignore_index=True)


def reproduced(reference: pd.DataFrame, tracks: dict[str, np.ndarray]) -> tuple[int, int]:
    """(confident tracks reproduced by one seedtrack track, confident tracks)."""
    row = found_within(reference, tracks)
    track = np.where(row >= 0, tracks["track_id"][np.maximum(row, 0)], -1)
    table = pd.DataFrame({"particle": reference["particle"].to_numpy(), "track": track})
    length = table.groupby("particle").size()
    held = table[table.track >= 0].groupby(["particle", "track"]).size().groupby("particle").max()
    share = (held.reindex(length.index, fill_value=0) / length).to_numpy()
    return int(np.sum(share >= REPRODUCED_SHARE)), len(length)


def measured(clip: Path, reference: pd.DataFrame, options: list[str]) -> list[str]:
    """Run ``seedtrack run`` with ``options`` and print its figures; the column of the docs table."""
    with tempfile.TemporaryDirectory() as folder:
        start = time.perf_counter()
        result = subprocess.run([sys.executable, "-m", "seedtrack", "run", str(clip), "--out", folder, *options], capture_output=True, text=True)
        seconds = time.perf_counter() - start
        if result.returncode != 0:
            raise SystemExit(result.stderr)
        detections = read_table(Path(folder) / "detections.csv")
        tracks = read_table(Path(folder) / "tracks.csv")
    print(result.stdout.strip().splitlines()[0])
    frame_count = reference["frame"].nunique()
    per_frame, track_count = len(detections["x"]) / frame_count, len(np.unique(tracks["track_id"]))
    print(
        f"{clip.name}: trackpy's confident tracks: {reference['particle'].nunique()} tracks, "
        f"{len(reference)} positions ({len(reference) / frame_count:.0f} a frame); seedtrack run ({' '.join(options) or 'defaults'}, {seconds:.0f} s): "
        f"{per_frame:.0f} detections a frame, {track_count} tracks"
    )
    hit = (found_within(reference, detections) >= 0).mean()
    print(f"  positions of confident tracks with a seedtrack detection within {TOLERANCE_PX:g} px: {hit:.4f} (goal 0.95)")
    marked = on_marked_beads(reference, detections)
    beads, background = marked[marked.bead], marked[~marked.bead]
    print(
        f"  in the {len(pd.read_csv(TRUTH_DIR / 'truth.csv').groupby(['frame', 'crop']))} marked crops: {len(marked)} positions of confident tracks, "
        f"{len(beads)} on a bead marked by looking (seedtrack detects {beads.found.mean():.3f} within {TOLERANCE_PX:g} px), "
        f"{len(background)} on none ({background.found.mean():.3f})"
    )
    count, total = reproduced(reference, tracks)
    print(
        f"  confident tracks reproduced (one seedtrack track within {TOLERANCE_PX:g} px of >= {REPRODUCED_SHARE:.0%} of "
        f"their points): {count} of {total}, {count / total:.4f} (goal 0.90)"
    )
    column = [f"{per_frame:.0f}; {track_count:,}", f"{hit:.3f}", f"{beads.found.mean():.3f} of {len(beads)} / {background.found.mean():.3f} of {len(background)}", f"{count} ({count / total:.3f})"]
    for what, count in (
        ("held by seedtrack's detections (the most a linker could reproduce)", held(reference, detections)),
        ("reproduced by trackpy's linker on seedtrack's detections", reproduced(reference, trackpy_linked(detections))[0]),
    ):
        print(f"  confident tracks {what}: {count} of {total}, {count / total:.4f}")
        column.append(f"{count} ({count / total:.3f})")
    return column


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("clip", nargs="?", type=Path, default=CLIP)
    parser.add_argument("--context", action="store_true", help="also trackpy with one setting changed, and laptrack")
    parser.add_argument("--beside", metavar="OPTIONS", help="also `seedtrack run` with these options, e.g. '--min-mass 6.7'")
    parser.add_argument("--write-docs", action="store_true", help="write the table into docs/detection.md")
    args = parser.parse_args()
    clip = args.clip
    frames = grey_frames(clip)
    features, reference = confident_tracks(frames)
    columns = {"defaults": measured(clip, reference, [])}
    if args.beside:
        columns[f"`{args.beside}`"] = measured(clip, reference, args.beside.split())
    total = reference["particle"].nunique()
    linked = reproduced(reference, seedtrack_linked(features))[0]
    print(f"  confident tracks reproduced by seedtrack's linker on trackpy's own detections: {linked} of {total}, {linked / total:.4f}")
    if args.context:
        context(frames, features, reference)
    if args.write_docs:
        rows = [
            "detections a frame; tracks `run` makes",
            "confident positions with a detection within 1 px",
            "in the 30 crops marked by looking: confident positions on a marked bead / on none, share detected within 1 px",
            f"confident tracks reproduced by seedtrack's own tracks (of {total})",
            "held by seedtrack's detections at 80% of their points",
            "reproduced by trackpy's linker on seedtrack's detections",
        ]
        table = [[what, *(column[k] for column in columns.values())] for k, what in enumerate(rows)]
        table.append(["reproduced by seedtrack's linker on trackpy's own detections (no seedtrack detection)", *[f"{linked} ({linked / total:.3f})"] * len(columns)])
        write_table("detection.md", "bulk-water-confident", ["measured", *columns], table)


if __name__ == "__main__":
    main()
