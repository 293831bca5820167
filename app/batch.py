"""Many clips, one ``run`` each, spread over the workers of a Dask cluster.

Each clip is one task: the worker runs :func:`seedtrack.pipeline.run_pipeline` on it into
``DIR/<clip name>/`` (so the files are those ``seedtrack run`` writes) and then, last, writes a
marker ``DIR/.done/<clip name>.json``; a rerun skips every clip whose marker names the same input
and options. The client only hands out paths and collects one short result per clip, so the
workers must see the inputs and DIR under the same paths (one machine, or a shared file system).
"""

from __future__ import annotations

import contextlib
import dataclasses
import glob
import io
import json
import os
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from seedtrack.data.atomic import atomic_path
from seedtrack.data.csvio import write_table
from seedtrack.data.errors import DataError

from .errors import UsageError, one_line as printable
from .pipeline import DetectSettings, run_pipeline
from .points import TrackingSettings

STATUSES = ("done", "failed", "skipped")
BATCH_COLUMNS = ("input", "status", "frames", "tracks", "seconds", "error")
MARKERS = ".done"


@dataclass(frozen=True)
class RunOptions:
    """Everything ``seedtrack run`` is told besides the input and the output folder.

    Attributes
    ----------
    detection : DetectSettings
    tracking : TrackingSettings
    """

    detection: DetectSettings = DetectSettings()
    tracking: TrackingSettings = TrackingSettings()

    def fingerprint(self) -> str:
        """A text that differs whenever the options differ (what a marker is checked against)."""
        return repr(self)


@dataclass(frozen=True)
class ClipResult:
    """One row of ``batch.csv``.

    Attributes
    ----------
    input : str
        The clip as given.
    status : {"done", "failed", "skipped"}
    frames, tracks : int
        Frames processed and tracks written (0 for a failure).
    seconds : float
        Wall time the clip took on its worker (0 when skipped).
    error : str
        The one-line error of a failure, else empty.
    said : str
        What the run said on how it detected and tracked (its detector and motion lines, joined
        by "; "), for the command's line per clip; not in ``batch.csv``.
    """

    input: str
    status: str
    frames: int = 0
    tracks: int = 0
    seconds: float = 0.0
    error: str = ""
    said: str = ""


def clip_names(inputs: Sequence[Path]) -> list[str]:
    """The output folder name of each input: a file's name without its suffix, a folder's name,
    a glob pattern's folder.

    Raises
    ------
    UsageError
        If two inputs would write to the same folder.

    Example
    -------
    >>> clip_names([Path("day1/a.mp4"), Path("day1/b.avi"), Path("stacks/c"), Path("images/d/*.png")])
    ['a', 'b', 'c', 'd']
    """
    names = [path.parent.name if glob.has_magic(str(path)) else path.name if path.is_dir() else path.stem for path in inputs]
    seen: dict[str, Path] = {}
    for name, path in zip(names, inputs):
        if name in ("", ".", "..", MARKERS):
            raise UsageError(f"{path} gives no usable output folder name; rename it or run it on its own")
        if name in seen:
            raise UsageError(f"{seen[name]} and {path} would both write to DIR/{name}/; run them in separate batches")
        seen[name] = path
    return names


def absolute_options(options: RunOptions) -> RunOptions:
    """The options with a mask image's path made absolute, for workers in other folders."""
    roi = options.detection.roi
    if isinstance(roi, Path):
        return dataclasses.replace(options, detection=dataclasses.replace(options.detection, roi=roi.absolute()))
    return options


def finished(marker: Path, clip: str, options: RunOptions) -> ClipResult | None:
    """The result a marker records, if it is of this clip with these options."""
    try:
        record = json.loads(marker.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if record.get("input") != clip or record.get("options") != options.fingerprint():
        return None
    return ClipResult(record["shown"], "skipped", int(record["frames"]), int(record["tracks"]))


# Clips share module state (the renderer's scratch layers, standard output): a worker with
# several threads runs one clip at a time.
_ONE_CLIP_AT_A_TIME = threading.Lock()


def run_clip(clip: str, shown: str, folder: str, marker: str, options: RunOptions) -> ClipResult:
    """Run one clip as ``seedtrack run`` would, then write its marker; on a worker.

    Errors of the clip (unreadable, bad options for it, or any other failure) become a failed
    result with a one-line error rather than an exception, so that one clip cannot stop the
    others. What the run prints on standard output (its detector and motion lines) comes back
    in the result; its progress bars are not shown.
    """
    said = io.StringIO()
    with _ONE_CLIP_AT_A_TIME, contextlib.redirect_stdout(said), contextlib.redirect_stderr(io.StringIO()):
        start = time.perf_counter()
        try:
            detections, tracks = run_pipeline(
                Path(clip), Path(folder), options.detection, options.tracking, workers=1
            )
        except Exception as error:  # noqa: BLE001 - any failure of one clip is that clip's result
            expected = isinstance(error, (DataError, UsageError))
            # Named as the user gave it, not as the absolute path the worker was sent.
            message = one_line(error, with_type=not expected).replace(clip, shown)
            return ClipResult(shown, "failed", seconds=time.perf_counter() - start, error=message)
        seconds = time.perf_counter() - start
        lines = "; ".join(line for line in said.getvalue().splitlines() if line.strip())
        result = ClipResult(shown, "done", len(detections.frame_indices), tracks.n_tracks, seconds, said=lines)
        record = {"input": clip, "shown": shown, "options": options.fingerprint(), "frames": result.frames, "tracks": result.tracks}
        Path(marker).parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(marker) as temporary:
            temporary.write_text(json.dumps(record, indent=1) + "\n", encoding="utf-8")
        return result


def one_line(error: BaseException, with_type: bool = False) -> str:
    """An exception's message on one line (``Type: message`` for an unexpected one)."""
    # Printed and written to batch.csv: a binary file's bytes quoted in it as escapes.
    text = printable(" ".join(str(error).split())) or type(error).__name__
    return f"{type(error).__name__}: {text}" if with_type and text != type(error).__name__ else text


def write_batch_table(path: Path, results: Sequence[ClipResult]) -> None:
    """Write ``batch.csv``: input, status, frames, tracks, seconds (two decimals), error."""
    columns = {name: [getattr(result, name) for result in results] for name in BATCH_COLUMNS}
    columns["seconds"] = [f"{seconds:.2f}" for seconds in columns["seconds"]]
    write_table(path, {name: np.array(values, dtype=object) for name, values in columns.items()})


def run_batch(
    client,
    inputs: Sequence[Path],
    out: Path,
    options: RunOptions,
    on_result: Callable[[ClipResult], None] = lambda result: None,
) -> list[ClipResult]:
    """Run every input on the Dask ``client``'s cluster into ``out/<clip name>/``.

    ``out/batch.csv`` is rewritten (atomically) after every clip, listing the clips finished so
    far in the order given, so that it is current even after an interruption.

    Parameters
    ----------
    client : distributed.Client
    inputs : sequence of Path
        Videos, image folders or patterns; each names its folder (see :func:`clip_names`).
    out : Path
        Output folder, created if missing.
    options : RunOptions
    on_result : callable
        Called with each clip's result as it arrives (done, failed or skipped).

    Returns
    -------
    list of ClipResult
        In the order of ``inputs``.

    Raises
    ------
    UsageError
        If two inputs would share a folder.
    """
    from distributed import as_completed

    names = clip_names(inputs)
    out.mkdir(parents=True, exist_ok=True)
    options = absolute_options(options)
    results: dict[int, ClipResult] = {}

    def record(index: int, result: ClipResult) -> None:
        results[index] = result
        write_batch_table(out / "batch.csv", [results[i] for i in sorted(results)])
        on_result(result)

    futures = {}
    for index, (path, name) in enumerate(zip(inputs, names)):
        clip, marker = os.fspath(path.absolute()), out.absolute() / MARKERS / f"{name}.json"
        done = finished(marker, clip, options)
        if done is not None and all((out / name / file).is_file() for file in ("detections.csv", "tracks.csv", "overlay.mp4")):
            record(index, done)
            continue
        # pure=False: a clip may have changed on disk since a previous task of the same name.
        future = client.submit(run_clip, clip, str(path), os.fspath(out.absolute() / name), os.fspath(marker), options, pure=False)
        futures[future] = index
    try:
        for future in as_completed(futures):
            index = futures[future]
            try:
                result = future.result()
            except Exception as error:  # noqa: BLE001 - a worker lost with the clip fails that clip only
                result = ClipResult(str(inputs[index]), "failed", error=one_line(error, with_type=True))
            record(index, result)
    finally:
        for future in futures:
            future.cancel()
    return [results[i] for i in sorted(results)]
