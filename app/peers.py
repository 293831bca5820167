"""Today's linkers, trackpy and laptrack, behind the same call as our trackers (optional).

They get the same points and the same speed limit: trackpy's ``search_range`` and laptrack's
cutoffs are the speed limit in pixels/frame. A peer that gives up (trackpy raises
SubnetOversizeException when a search region holds too many candidates) raises
:class:`PeerFailure`, which the experiments record as a failed run rather than a crash.
Installed with the ``peers`` extra (trackpy, laptrack, pandas).
"""

from __future__ import annotations

import importlib.util
import warnings
from typing import Callable, Sequence

import numpy as np

from seedtrack.tracking.tracks import Tracks

# laptrack closes gaps of up to this many frames, as IPAN's post-processing does.
GAP_FRAMES = 2
# trackpy's adaptive search shrinks the range by this factor down to this fraction of it.
ADAPTIVE_STEP = 0.95
ADAPTIVE_STOP_FRACTION = 0.1


class PeerFailure(RuntimeError):
    """A peer linker gave up on the data (e.g. trackpy's SubnetOversizeException)."""


def peers_available() -> bool:
    """True when trackpy, laptrack and pandas can be imported."""
    return all(importlib.util.find_spec(name) is not None for name in ("trackpy", "laptrack", "pandas"))


def _table(frames: Sequence[np.ndarray]):
    import pandas as pd

    counts = [len(f) for f in frames]
    points = np.concatenate([np.asarray(f, float).reshape(-1, 2) for f in frames]) if frames else np.empty((0, 2))
    return pd.DataFrame({"frame": np.repeat(np.arange(len(frames)), counts), "x": points[:, 0], "y": points[:, 1]})


def _tracks(table, id_column: str, first_frame: int) -> Tracks:
    return Tracks.from_rows(
        table[id_column].to_numpy(), table["frame"].to_numpy() + first_frame, table["x"].to_numpy(), table["y"].to_numpy()
    )


def trackpy_linker(mode: str, memory: int = 0) -> Callable[[Sequence[np.ndarray], float, int], Tracks]:
    """trackpy's ``link`` as a tracker: ``mode`` "plain", "adaptive" (adaptive search) or
    "predict" (``NearestVelocityPredict``); a particle may vanish for ``memory`` frames."""
    def run(frames: Sequence[np.ndarray], max_speed: float, first_frame: int = 0) -> Tracks:
        import trackpy

        trackpy.quiet()
        table = _table(frames)
        # trackpy's own use of pandas APIs due to change is for its maintainers, not our users.
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            warnings.simplefilter("ignore", FutureWarning)
            return _tracks(_trackpy_link(table, mode, max_speed, memory), "particle", first_frame)

    return run


def _trackpy_link(table, mode: str, max_speed: float, memory: int):
    import trackpy

    try:
        if mode == "predict":
            return trackpy.predict.NearestVelocityPredict().link_df(table, max_speed, memory=memory)
        if mode == "adaptive":
            return trackpy.link(
                table, max_speed, memory=memory, adaptive_stop=ADAPTIVE_STOP_FRACTION * max_speed, adaptive_step=ADAPTIVE_STEP
            )
        return trackpy.link(table, max_speed, memory=memory)
    except Exception as error:  # trackpy signals giving up with several exception types
        raise PeerFailure(f"{type(error).__name__}: {error}") from None


def _laptrack(frames: Sequence[np.ndarray], max_speed: float, first_frame: int = 0) -> Tracks:
    from laptrack import LapTrack

    # laptrack compares squared distances; a gap of g frames may span (g + 1) times the speed.
    linker = LapTrack(
        metric="sqeuclidean",
        cutoff=max_speed**2,
        gap_closing_metric="sqeuclidean",
        gap_closing_cutoff=((GAP_FRAMES + 1) * max_speed) ** 2,
        gap_closing_max_frame_count=GAP_FRAMES,
    )
    table = _table(frames)
    try:
        linked, _, _ = linker.predict_dataframe(table, ["x", "y"], only_coordinate_cols=False)
    except Exception as error:  # any failure inside the peer is the peer's, not ours
        raise PeerFailure(f"{type(error).__name__}: {error}") from None
    return _tracks(linked, "track_id", first_frame)


PEERS: dict[str, Callable[[Sequence[np.ndarray], float, int], Tracks]] = {
    "trackpy": trackpy_linker("plain"),
    "trackpy-adaptive": trackpy_linker("adaptive"),
    "trackpy-predict": trackpy_linker("predict"),
    "laptrack": _laptrack,
}
