"""Today's linkers, trackpy and laptrack, behind the same call as our trackers (optional).

They get the same points and the same speed limit: trackpy's ``search_range`` and laptrack's
cutoffs are the speed limit in pixels/frame. A peer that gives up (trackpy raises
SubnetOversizeException when a search region holds too many candidates) raises
:class:`PeerFailure`, which the experiments record as a failed run rather than a crash.
Stone Soup runs when it is installed (it is in the ``peers`` extra too): a constant-velocity
Kalman tracker with global nearest-neighbour association, the textbook tracker of the paper's
MHT row (see :func:`stonesoup_tracker`). Installed with the ``peers`` extra (trackpy, laptrack,
pandas, stonesoup).
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
    """trackpy's ``link`` as a tracker: ``mode`` "plain", "adaptive" (adaptive search),
    "predict" (``NearestVelocityPredict``) or "predict-adaptive" (both); a particle may vanish
    for ``memory`` frames."""
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


def trackpy_predict_given(frames: Sequence[np.ndarray], max_speed: float, given: np.ndarray) -> Tracks:
    """trackpy's ``NearestVelocityPredict`` given the first links (the paper's protocol): it links
    frames 1 onwards, its velocity field started from the given links' velocities at their frame-1
    points (``initial_guess_positions``, ``initial_guess_vels``), and frame 0 joins on.

    Returns
    -------
    Tracks
        Frame 0's points on the tracks of their given frame-1 partners.
    """
    import trackpy

    trackpy.quiet()
    frames = [np.asarray(f, float).reshape(-1, 2) for f in frames]
    linked = given[(given[:, 0] >= 0) & (given[:, 1] >= 0)]
    start = frames[1][linked[:, 1]]
    predictor = trackpy.predict.NearestVelocityPredict(
        initial_guess_positions=start, initial_guess_vels=start - frames[0][linked[:, 0]], pos_columns=["x", "y"]
    )
    table = _table(frames[1:])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        warnings.simplefilter("ignore", FutureWarning)
        try:
            result = predictor.link_df(table, max_speed, pos_columns=["x", "y"])
        except Exception as error:  # trackpy signals giving up with several exception types
            raise PeerFailure(f"{type(error).__name__}: {error}") from None
    later = result[result["frame"] == 0]
    partner = {(float(x), float(y)): int(p) for x, y, p in zip(later["x"], later["y"], later["particle"])}
    first = np.full(frames[0].shape[0], -1, np.int64)
    first[linked[:, 0]] = [partner.get((float(x), float(y)), -1) for x, y in start]
    fresh = int(result["particle"].max()) + 1 if len(result) else 0
    unlinked = first < 0
    first[unlinked] = fresh + np.arange(int(unlinked.sum()))
    return Tracks.from_rows(
        np.concatenate((first, result["particle"].to_numpy())),
        np.concatenate((np.zeros(first.size, np.int64), result["frame"].to_numpy() + 1)),
        np.concatenate((frames[0][:, 0], result["x"].to_numpy())),
        np.concatenate((frames[0][:, 1], result["y"].to_numpy())),
    )


def _trackpy_link(table, mode: str, max_speed: float, memory: int):
    import trackpy

    try:
        if mode == "predict":
            return trackpy.predict.NearestVelocityPredict().link_df(table, max_speed, memory=memory)
        if mode == "predict-adaptive":
            return trackpy.predict.NearestVelocityPredict().link_df(
                table, max_speed, memory=memory, adaptive_stop=ADAPTIVE_STOP_FRACTION * max_speed, adaptive_step=ADAPTIVE_STEP
            )
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


# Stone Soup's constant-velocity model: per-frame velocity change as a share of the speed limit
# (PSMG-like motion changes its velocity by about a tenth of the speed a frame, and the limit is
# twice the speed), the measurement noise in pixels, the Mahalanobis distance beyond which a
# detection is not associated, and the frames a track coasts on predictions before it is deleted.
STONESOUP_VELOCITY_SHARE = 0.1
STONESOUP_NOISE = 0.5
STONESOUP_GATE = 3.0
STONESOUP_COAST = GAP_FRAMES


def stonesoup_tracker(frames: Sequence[np.ndarray], max_speed: float, first_frame: int = 0) -> Tracks:
    """Stone Soup's ``MultiTargetTracker`` with a constant-velocity Kalman filter, global nearest
    neighbour (``GNNWith2DAssignment`` over Mahalanobis distances) and tracks started from two
    associated detections (``MultiMeasurementInitiator``, prior velocity spread ``max_speed`` / 2).

    Parameters
    ----------
    frames : sequence of ndarray, each (M_k, 2)
        Positions per frame, pixels; frame k is at time k seconds.
    max_speed : float
        Speed limit, pixels/frame: sets the prior velocity spread and the process noise
        (velocity change of 0.1 max_speed per frame).
    first_frame : int
        0-based frame index of ``frames[0]``.

    Returns
    -------
    Tracks
        Each track's measured points (coasting predictions are left out; gaps are filled by
        interpolation as for the other peers).
    """
    from datetime import datetime, timedelta

    from stonesoup.dataassociator.neighbour import GNNWith2DAssignment
    from stonesoup.deleter.time import UpdateTimeStepsDeleter
    from stonesoup.hypothesiser.distance import DistanceHypothesiser
    from stonesoup.initiator.simple import MultiMeasurementInitiator
    from stonesoup.measures import Mahalanobis
    from stonesoup.models.measurement.linear import LinearGaussian
    from stonesoup.models.transition.linear import CombinedLinearGaussianTransitionModel, ConstantVelocity
    from stonesoup.predictor.kalman import KalmanPredictor
    from stonesoup.tracker.simple import MultiTargetTracker
    from stonesoup.types.detection import Detection
    from stonesoup.types.state import GaussianState
    from stonesoup.types.update import Update
    from stonesoup.updater.kalman import KalmanUpdater

    q = (STONESOUP_VELOCITY_SHARE * max_speed) ** 2
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(q), ConstantVelocity(q)])
    measurement = LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=np.eye(2) * STONESOUP_NOISE**2)
    predictor = KalmanPredictor(transition)
    updater = KalmanUpdater(measurement)
    hypothesiser = DistanceHypothesiser(predictor, updater, measure=Mahalanobis(), missed_distance=STONESOUP_GATE)
    associator = GNNWith2DAssignment(hypothesiser)
    deleter = UpdateTimeStepsDeleter(STONESOUP_COAST + 1)
    spread = (max_speed / 2.0) ** 2
    prior = GaussianState([[0], [0], [0], [0]], np.diag([STONESOUP_NOISE**2, spread, STONESOUP_NOISE**2, spread]))
    initiator = MultiMeasurementInitiator(
        prior_state=prior, measurement_model=measurement, deleter=UpdateTimeStepsDeleter(1),
        data_associator=GNNWith2DAssignment(DistanceHypothesiser(predictor, updater, Mahalanobis(), missed_distance=STONESOUP_GATE)),
        updater=updater, min_points=2,
    )
    start = datetime(2000, 1, 1)

    def detections():
        for k, points in enumerate(frames):
            time = start + timedelta(seconds=k)
            yield time, {Detection(np.array([[x], [y]]), timestamp=time, measurement_model=measurement) for x, y in np.asarray(points, float).reshape(-1, 2)}

    tracker = MultiTargetTracker(initiator=initiator, deleter=deleter, detector=detections(), data_associator=associator, updater=updater)
    seen = set()
    try:
        for _, current in tracker:
            seen |= set(current)
    except Exception as error:  # any failure inside the peer is the peer's, not ours
        raise PeerFailure(f"{type(error).__name__}: {error}") from None
    ids, frame, x, y = [], [], [], []
    for number, track in enumerate(sorted(seen, key=lambda t: (t.states[0].timestamp, float(t.states[0].state_vector[0, 0])))):
        for state in track.states:
            if isinstance(state, Update):
                point = state.hypothesis.measurement.state_vector
                ids.append(number)
                frame.append(first_frame + round((state.timestamp - start).total_seconds()))
                x.append(float(point[0, 0]))
                y.append(float(point[1, 0]))
    if not ids:
        return Tracks.from_rows(np.empty(0), np.empty(0), np.empty(0), np.empty(0))
    return Tracks.from_rows(np.array(ids), np.array(frame), np.array(x), np.array(y))


# Stone Soup's multi-frame assignment: the frames of its sliding window (its example's 3), the
# detection probability (PSMG hides a point in at most a few per cent of frames; misses are what
# the window must bridge), the clutter density per square pixel (PSMG has no false points; a
# small density keeps "false alarm" a possible explanation of a far detection) and the gate, the
# probability that the true detection falls inside it.
MFA_WINDOW = 3
MFA_DETECTION = 0.95
MFA_CLUTTER = 1e-6
MFA_GATE = 0.999


def stonesoup_mfa(frames: Sequence[np.ndarray], max_speed: float, first_frame: int = 0, given: np.ndarray | None = None) -> Tracks:
    """Stone Soup's multi-frame assignment (``MFADataAssociator`` over a sliding window of
    ``MFA_WINDOW`` frames, ``MFAHypothesiser`` over a ``PDAHypothesiser``) with a
    constant-velocity Kalman filter: the MHT family's maintained descendant.

    Like the paper's GOA it keeps a fixed set of tracks: one per point of the first frame, started
    with no velocity and a velocity spread of ``max_speed`` / 2 (self-initialised), or, with
    ``given``, one per given first link, started at its frame-1 point with its velocity. A track
    that finds no detection within its gate coasts (a missed detection); each track's points are
    those of its best hypothesis once the window has passed the last frame.

    Parameters
    ----------
    frames : sequence of ndarray, each (M_k, 2)
        Positions per frame, pixels; frame k is at time k seconds.
    max_speed : float
        Speed limit, pixels/frame: the prior velocity spread and the process noise (velocity
        change of 0.1 max_speed per frame), as for :func:`stonesoup_tracker`.
    first_frame : int
        0-based frame index of ``frames[0]``.
    given : ndarray of int, shape (n, 2), optional
        The first two frames' correspondences (indices into ``frames[0]`` and ``frames[1]``).

    Returns
    -------
    Tracks
        Measured points only.

    Example
    -------
    >>> frames = [np.array([[10.0 + 3 * k, 10.0], [10.0 + 3 * k, 50.0]]) for k in range(5)]
    >>> stonesoup_mfa(frames, 6.0).n_tracks
    2
    """
    from datetime import datetime, timedelta

    from stonesoup.dataassociator.mfa import MFADataAssociator
    from stonesoup.hypothesiser.mfa import MFAHypothesiser
    from stonesoup.hypothesiser.probability import PDAHypothesiser
    from stonesoup.models.measurement.linear import LinearGaussian
    from stonesoup.models.transition.linear import CombinedLinearGaussianTransitionModel, ConstantVelocity
    from stonesoup.predictor.kalman import KalmanPredictor
    from stonesoup.types.detection import Detection
    from stonesoup.types.mixture import GaussianMixture
    from stonesoup.types.numeric import Probability
    from stonesoup.types.state import TaggedWeightedGaussianState
    from stonesoup.types.track import Track
    from stonesoup.types.update import GaussianMixtureUpdate
    from stonesoup.updater.kalman import KalmanUpdater

    frames = [np.asarray(f, float).reshape(-1, 2) for f in frames]
    q = (STONESOUP_VELOCITY_SHARE * max_speed) ** 2
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(q), ConstantVelocity(q)])
    measurement = LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=np.eye(2) * STONESOUP_NOISE**2)
    updater = KalmanUpdater(measurement)
    hypothesiser = MFAHypothesiser(PDAHypothesiser(
        KalmanPredictor(transition), updater, MFA_CLUTTER, prob_detect=Probability(MFA_DETECTION), prob_gate=Probability(MFA_GATE)))
    associator = MFADataAssociator(hypothesiser, slide_window=MFA_WINDOW)
    start = datetime(2000, 1, 1)
    noise, spread = STONESOUP_NOISE**2, (max_speed / 2.0) ** 2
    if given is None:
        begin, held = 0, [[(0, i)] for i in range(frames[0].shape[0])]
        states = [(frames[0][i], np.zeros(2), np.diag([noise, spread, noise, spread])) for i in range(frames[0].shape[0])]
    else:
        begin, held = 1, [[(0, int(a)), (1, int(b))] for a, b in given if a >= 0 and b >= 0]
        states = [(frames[1][b], frames[1][b] - frames[0][a], np.diag([noise, 2 * noise, noise, 2 * noise])) for (_, a), (_, b) in held]
    tracks = [
        Track([GaussianMixture([TaggedWeightedGaussianState(
            [[p[0]], [v[0]], [p[1]], [v[1]]], covar, timestamp=start + timedelta(seconds=begin), weight=Probability(1), tag=[])])])
        for p, v, covar in states
    ]
    scans = list(range(begin + 1, len(frames)))
    try:
        # The window's last frames are decided by n-scan pruning only once it has moved past
        # them: empty scans after the last frame let it.
        for k in scans + [None] * (MFA_WINDOW - 1):
            time = start + timedelta(seconds=(k if k is not None else scans[-1] + 1) if scans else begin)
            points = frames[k] if k is not None else np.empty((0, 2))
            detections = [Detection(np.array([[x], [y]]), timestamp=time, measurement_model=measurement) for x, y in points]
            if not tracks:
                break
            for track, hypotheses in associator.associate(tracks, detections, time).items():
                components = [updater.update(h) if h else h.prediction for h in hypotheses]
                track.append(GaussianMixtureUpdate(components=components, hypothesis=hypotheses))
    except Exception as error:  # any failure inside the peer is the peer's, not ours
        raise PeerFailure(f"{type(error).__name__}: {error}") from None
    ids, frame, x, y = [], [], [], []
    for number, (track, points) in enumerate(zip(tracks, held)):
        best = max(track.state.components, key=lambda c: float(c.weight)) if len(track) > 1 else None
        history = list(best.tag[: len(scans)]) if best is not None else []
        points = points + [(k, index - 1) for k, index in zip(scans, history) if index > 0]
        for k, index in points:
            ids.append(number)
            frame.append(first_frame + k)
            x.append(frames[k][index, 0])
            y.append(frames[k][index, 1])
    return Tracks.from_rows(np.array(ids, np.int64), np.array(frame, np.int64), np.array(x, float), np.array(y, float))


PEERS: dict[str, Callable[[Sequence[np.ndarray], float, int], Tracks]] = {
    "trackpy": trackpy_linker("plain"),
    "trackpy-adaptive": trackpy_linker("adaptive"),
    "trackpy-predict": trackpy_linker("predict"),
    "laptrack": _laptrack,
}
if importlib.util.find_spec("stonesoup") is not None:
    PEERS["stonesoup"] = stonesoup_tracker
    PEERS["stonesoup-mfa"] = stonesoup_mfa
# The peers that can be given the first two frames' correspondences (the paper's protocol):
# ``run(frames, max_speed, given) -> Tracks``.
GIVEN_PEERS: dict[str, Callable[[Sequence[np.ndarray], float, np.ndarray], Tracks]] = {
    "trackpy-predict": trackpy_predict_given,
}
if "stonesoup-mfa" in PEERS:
    GIVEN_PEERS["stonesoup-mfa"] = lambda frames, max_speed, given: stonesoup_mfa(frames, max_speed, 0, given)
