"""The default motion model: measured on a first pass, then used to track (random to smooth).

Instead of calling the motion smooth or random on a threshold and tracking with one of two
fixed models, the default tracks twice. A first pass with the smooth-motion default (or the
random-walk model, when the unambiguous links say the steps turn at random; see
:func:`seedtrack.tracking.regime.choose_motion`) gives tracks, most of whose links are right
whatever the motion. :func:`seedtrack.tracking.persistence.fit_statistics` measures on them how
much of each velocity carries over, how it turns and how much noise there is, robustly to the
first pass's wrong links; the final pass scores every link by its likelihood under those
statistics (:class:`seedtrack.tracking.persistence.PersistentModel`), in a frame of reference
moving with the drift. A persistence near 0 is a random walk tracked by distance about the
drift, near 1 smooth motion tracked by distance from the predicted position, and everything in
between is the blend the data show. The statistics are then measured once more, on the tracks
they gave, and the points tracked again with those (``REFITS``): where the first pass is poor the
first statistics are too wide, but the tracks they give are mostly right.

The statistics need enough chains, not every point: the first pass and the refit's pass run on a
sample of at most ``SAMPLE_POINTS`` points (:func:`measuring_sample`: the middle frames, and a
window of the view about its centre where even ``SAMPLE_FRAMES`` frames hold more), and only the
last pass tracks every point. A clip no larger than the sample is measured on all of it.

The speed limit only removes links. Without one from the user, the final pass is limited to
twice the fastest speed (99th percentile) on the chains that fit the statistics.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Callable, Sequence

import numpy as np

from .goa import GOAConfig
from .mixture import MixtureModel, fit_states
from .motion import IndividualModel, SpeedLimits
from .persistence import MotionStatistics, PersistentModel, fit_chains, measured_chains
from .repair import resolve_crossings
from .regime import MotionFit, choose_motion, fit_motion, track_without_drift
from .tracks import NO_MEASUREMENT, Tracks

# The measured speed limit is this many times the fastest speed that fits the motion.
SPEED_MARGIN = 2.0
# The first pass's speed limit is this many times the fastest unambiguous step, where those show
# the fastest speed (regime.MotionChoice.clear_speed).
FIRST_PASS_MARGIN = 3.0
# Sigmas from the prediction at which a link costs as much as a slave, chosen on the tuning seeds
# of tests/benchmarks/bench_held_out.py among 6, 9 and 12: real velocity changes have longer tails
# than a Gaussian (speed steps along the track, turns across it), and a true link beyond the gate
# leaves its point to a new track; 6 lost such links on fast smooth motion and on dishes with
# seeds missed, 12 let wrong links in where seeds are missed often and points come and go.
MEASURED_MOTION_GATE_SIGMAS = 9.0
# The nearest-neighbour share of a first link's score costs phi_max at this many times the
# measured speed limit. At the limit itself (twice the fastest speed) a rim seed of a turning dish
# at 42 px/frame pays 0.16 phi_max for its true first link, and a link to a slow neighbour 9 px
# away 0.03: on dishes of 400 seeds (tuning seeds 0-5 of bench_held_out's) 58 of 2400 seeds were
# wrong, and 133 once the fitted noise came closer to the true one, mostly after wrong first
# links; at twice the limit none.
FIRST_LINK_SCALE = 2.0
# Rounds of measuring the statistics again on the final pass's tracks and tracking again. On a
# dish with 15% of the seeds missed the first pass links wrongly half the time and some clips'
# statistics came out wide (noise 0.16 to 0.39 x speed against 0.00 on the true tracks), tracking
# with track error 0.5 to 0.9; after one more round the tuning seeds 0-5 all had 0.05 to 0.11
# (mean 0.135 -> 0.092), and noisy fast smooth motion (100 points, 12 px/frame, tuning seeds 0-8)
# went from strict merit 0.50 to 0.74. Each round is one more pass.
REFITS = 1
# Slaves in a row a head keeps in the passes at velocity persistence 0, a random walk. There a head
# that lost its point predicts nothing but its last position, so GOA's frame-by-frame contest
# between a head back from slaves and the heads beside it knows no more than gap closing, which
# joins every end to a later start across max_gap at once; in footage where beads drift in and out
# of focus, heads kept for ten slaves took the points of beads that came into view and two tracks
# took turns at one bead (bulk water, our detections: 879 of 1218 confident tracks with 10, 951
# with 3, 957 with 2, 955 with 1). 3 is trackpy's memory, and on random walkers (bench_motion.py,
# sigma 1.5, 5% missed) 3 and 10 link as well (link error 0.0077 and 0.0079), 1 worse (0.0089).
# Smooth motion's heads predict across the gap and keep max_gap (a dish 15% missed fell from strict
# merit 0.88 to 0.60 with 3); in between, the slaves grow with the persistence (head_slaves), so
# that no line of persistence flips how long heads last.
RANDOM_WALK_SLAVES = 3

# Points the motion is measured on (the first pass and the refits' passes), at most: the
# statistics need enough chains, not every point. On walkers and PSMG (tuning seeds 0 and 1)
# every size from 2,500 measured the same; a dish with 15% of its seeds missed over 300 frames
# lost its tracks on one seed or both measured on 10,000 points or fewer, none on 20,000 or on all
# (docs/speed-linking.md).
SAMPLE_POINTS = 20_000
# Frames a sample spans, at least (all of a shorter clip): where fewer frames would hold
# SAMPLE_POINTS, a window of the view is cut from this many instead, so that tracks run long
# enough to measure on (chains, misses, ends) whatever the density. Tumbling runs of 1,000 points
# over 60 frames (tuning seeds 0-3) measured on 20 frames: one seed of four kept the first pass's
# absurd speeds (limit about 200 px/frame for motion at 4) and lost its tracks (link error 0.13);
# on 40 frames, a window of half the view, the four tracked as measured on all 60 (link error
# 0.0125 against 0.0126), in a sixth of the CPU.
SAMPLE_FRAMES = 40

Track = Callable[[list[np.ndarray], GOAConfig], Tracks]


def track_measured_motion(frames: Sequence[np.ndarray], config: GOAConfig, track: Track, measure: Track | None = None) -> tuple[Tracks, MotionFit]:
    """``track(frames, config)`` with the motion model measured on a first pass.

    Parameters
    ----------
    frames : sequence of ndarray, each (M_k, 2)
        Measurement positions (x, y) per frame, pixels.
    config : GOAConfig
        What the user set; its individual model is replaced by the measured one, and its
        ``d_max`` (pixels/frame, None for none) only removes links in the final pass.
    track : callable
        ``track(frames, config) -> Tracks``, e.g. open GOA-updown; column k of its tracks must be
        ``frames[k]``.
    measure : callable, optional
        As ``track``, for the passes on a sample of the clip (:func:`measuring_sample`) when it
        is not the whole clip; None: ``track``. For a tracker given what only the whole clip's
        frames mean (the first two frames' links).

    Returns
    -------
    tracks : Tracks
    fit : MotionFit
        The final pass's configuration and drift, and what was measured (``measured`` None when
        the first pass had too few three-frame chains to measure on; its tracks are kept).

    Example
    -------
    >>> from seedtrack.data.psmg import PSMGSpec, generate_psmg
    >>> from seedtrack.tracking.goa import goa_updown
    >>> frames, truth = generate_psmg(PSMGSpec(trajectories=10, random_seed=2))
    >>> tracks, fit = track_measured_motion(frames, GOAConfig(), goa_updown)
    >>> tracks.n_tracks
    10
    """
    frames = [np.asarray(f, dtype=float).reshape(-1, 2) for f in frames]
    sample = measuring_sample(frames)
    if sample is frames or measure is None:
        measure = track
    first, first_fit = first_pass(sample, config, measure)
    chains = measured_chains(first, config.localisation_error)
    if chains is None and sample is not frames:
        # Fewer than ten chains in tens of thousands of points: measured on them all, as a clip
        # that small would be.
        sample, measure = frames, track
        first, first_fit = first_pass(sample, config, measure)
        chains = measured_chains(first, config.localisation_error)
    if chains is None:
        return first, first_fit
    # The first pass's tracks are not needed any more: freed, they add neither to the fit's peak
    # nor to the final pass's.
    del first
    statistics = fit_chains(chains)
    # Motion states are fitted only on a final pass's tracks: a first pass's wrong links, where
    # it makes many (a dish 5% missed), chain consistently and were fitted as a state of their own.
    states = None
    del chains
    # A given speed limit only removes links: every pass runs as with none, so that what is
    # measured and what is linked do not depend on it, and the links that break it are cut at
    # the end. GOA is greedy in time: removing links it would not have made still changed what it
    # made later (a dish of 400 seeds lost seeds to the true limit, tracked again under it).
    unlimited = replace(config, d_max=None)
    # Each pass but the last tracks the sample, to measure on; the last tracks every point. With
    # the whole clip as the sample this is the first pass, then 1 + REFITS final passes.
    for _ in range(REFITS):
        tracks = _final_pass(sample, measured_config(unlimited, statistics, states), statistics, measure)
        chains = measured_chains(tracks, config.localisation_error)
        del tracks
        # Too few chains to measure on (rare after a first pass had enough): the same statistics
        # again, so that the passes, and the progress calls, are as announced.
        if chains is not None:
            statistics = fit_chains(chains)
            states = _states(chains, statistics, config)
        del chains
    del sample
    tracks = _final_pass(frames, measured_config(unlimited, statistics, states), statistics, track)
    fitted = measured_config(config, statistics, states)
    given = config.d_max is not None
    if given and fitted.d_max < measured_config(unlimited, statistics).d_max:
        tracks = without_faster_links(tracks, config.d_max)
    drift = statistics.drift
    limit = f"speed limit {fitted.d_max:.2f} px/frame" + (" (given)" if given else " (measured)")
    measured = f"{statistics.describe()}, drift ({drift[0]:.2f}, {drift[1]:.2f}) px/frame; {limit}"
    if states is not None:
        measured += f"; motion states per track: {fitted.individual.describe()}"
    return tracks, MotionFit(first_fit.choice, fitted, drift, measured)


def sample_frames(counts: Sequence[int]) -> range:
    """The frames the motion is measured on, from the points in each (``counts``): the longest run
    about the middle of the clip that holds at most ``SAMPLE_POINTS`` points, and at least
    ``SAMPLE_FRAMES`` frames (the whole clip when shorter); 0-based frame indices.

    Example
    -------
    >>> sample_frames([100] * 1000), sample_frames([1000] * 100), sample_frames([1000] * 10)
    (range(400, 600), range(30, 70), range(0, 10))
    """
    n = len(counts)
    held = np.concatenate(([0], np.cumsum(counts, dtype=np.int64)))
    lengths = np.arange(1, n + 1)
    starts = (n - lengths) // 2
    # Each run holds the one before (it starts at or one before it and ends at or one after it),
    # so the points held grow with the length.
    length = max(min(SAMPLE_FRAMES, n), int(np.count_nonzero(held[starts + lengths] - held[starts] <= SAMPLE_POINTS)))
    start = (n - length) // 2
    return range(start, start + length)


def measuring_sample(frames: list[np.ndarray]) -> list[np.ndarray]:
    """The points the motion is measured on: the frames :func:`sample_frames` chooses, and where
    they hold more than ``SAMPLE_POINTS`` points, those inside the smallest square about the
    centre of their bounding box that holds that many (pixels; the view may cut it). ``frames``
    itself when that is all of it.

    Example
    -------
    >>> grid = np.stack(np.meshgrid(np.arange(200.0), np.arange(200.0)), axis=-1).reshape(-1, 2)
    >>> sample = measuring_sample([grid] * 10)
    >>> len(sample), sample[0].shape[0], sample[0].min(axis=0).tolist()
    (10, 2116, [77.0, 77.0])
    """
    counts = [f.shape[0] for f in frames]
    block = sample_frames(counts)
    if sum(counts) <= SAMPLE_POINTS:
        return frames
    chosen = frames[block.start : block.stop]
    if sum(counts[block.start : block.stop]) <= SAMPLE_POINTS:
        return chosen
    low = np.min([f.min(axis=0) for f in chosen if f.shape[0]], axis=0)
    high = np.max([f.max(axis=0) for f in chosen if f.shape[0]], axis=0)
    centre = (low + high) / 2.0
    reach = [np.max(np.abs(f - centre), axis=1) for f in chosen]
    joined = np.concatenate(reach)
    half = np.partition(joined, SAMPLE_POINTS - 1)[SAMPLE_POINTS - 1]
    return [f[r <= half] for f, r in zip(chosen, reach)]


def _states(chains, statistics: MotionStatistics, config: GOAConfig):
    """The scene's motion states and their shares where ``config`` allows them per track (the
    default) and the chains show tracks keeping more than one
    (:func:`seedtrack.tracking.mixture.fit_states` decides), else None."""
    if config.motion_states != "track":
        return None
    states = fit_states(chains, statistics)
    return states if len(states[0]) > 1 else None


def _final_pass(frames: list[np.ndarray], fitted: GOAConfig, statistics: MotionStatistics, track: Track) -> Tracks:
    """``track`` with the measured model in the frame moving with the drift, near crossings then
    decided over five frames (under the scene-wide statistics: not with motion states per track,
    whose pairings it undid; a mix of smooth movers, walkers and oscillators, tuning seeds 0-2,
    strict merit of the walkers 0.48, 0.46, 0.25 without it, 0.25, 0.31, 0.06 with it)."""
    tracks = track_without_drift(frames, statistics.drift, lambda moved: track(moved, fitted))
    return tracks if isinstance(fitted.individual, MixtureModel) else resolve_crossings(tracks, statistics)


def first_pass(frames: list[np.ndarray], config: GOAConfig, track: Track) -> tuple[Tracks, MotionFit]:
    """Tracks to measure the motion on, and how they were made: the smooth-motion default or,
    where the unambiguous links show a random walk, nearest neighbour about the drift, with no
    speed limit from the user (a given limit would reshape the costs of this pass; the final
    pass applies it).

    Example
    -------
    >>> from seedtrack.data.psmg import PSMGSpec, generate_psmg
    >>> from seedtrack.tracking.goa import goa_updown
    >>> frames, _ = generate_psmg(PSMGSpec(trajectories=10, random_seed=2))
    >>> tracks, fit = first_pass(frames, GOAConfig(), goa_updown)
    >>> fit.choice.individual_model, tracks.n_tracks
    ('im2', 10)
    """
    choice = choose_motion(frames, "auto")
    fitted, drift = fit_motion(replace(config, d_max=None), choice)
    if choice.individual_model == "im2" and choice.clear_speed is not None:
        # Smooth motion slow for its spacing: the unambiguous steps show its fastest speed, and
        # the first pass is held to a few times it. Without a limit it joined an object's last
        # point to the first point of one that entered far away (160 px a frame where the
        # fastest was 5), and the motion measured on those tracks let the next passes join too.
        fitted = replace(fitted, d_max=max(FIRST_PASS_MARGIN * choice.clear_speed, 1.0))
    return track_without_drift(frames, drift, lambda moved: track(moved, fitted)), MotionFit(choice, fitted, drift)


def measured_config(config: GOAConfig, statistics: MotionStatistics, states=None) -> GOAConfig:
    """``config`` with the measured model (drift removed: the final pass runs in a frame moving
    with it) and the speed limit about the drift, pixels/frame: twice the fastest measured speed
    when ``config`` has none, else the given one plus the drift's speed. ``states``: motion
    states and their shares (:func:`seedtrack.tracking.mixture.fit_states`) for the model of
    motion states per track.

    Example
    -------
    >>> stats = MotionStatistics(1.0, 0.3, 0.1, (3.0, 4.0), 2.0, 100, fastest=10.0)
    >>> measured_config(GOAConfig(), stats).d_max, measured_config(GOAConfig(d_max=12.0), stats).d_max
    (20.0, 17.0)
    """
    measured = max(SPEED_MARGIN * statistics.fastest, 1.0)
    model = IndividualModel(name="persistent", statistics=replace(statistics, drift=(0.0, 0.0)), gate=MEASURED_MOTION_GATE_SIGMAS, speed_scale=FIRST_LINK_SCALE * measured)
    if states is not None:
        still = tuple(replace(s, drift=(0.0, 0.0)) for s in states[0])
        model = IndividualModel(name="mixture", statistics=model.statistics, gate=model.gate, speed_scale=model.speed_scale, states=still, shares=states[1])
    if config.d_max is None:
        return replace(config, individual=model, d_max=measured)
    # The user's limit is on speeds in the image; about the drift a speed up to limit + |drift|
    # can still be one, and only the faster ones are certainly impossible. It only removes
    # links: above the measured limit it changes nothing.
    return replace(config, individual=model, d_max=min(measured, config.d_max + float(np.hypot(*statistics.drift))))


def head_slaves(config: GOAConfig, max_gap: int) -> int | None:
    """Slaves in a row a head keeps in a pass with ``config``: from ``RANDOM_WALK_SLAVES`` at
    velocity persistence 0 (a random walk's head predicts nothing across a gap but its last
    position) up to ``max_gap`` frames at persistence 1, in proportion, for a measured model
    (:func:`measured_config`); None (``max_gap``) for any other model.

    Example
    -------
    >>> stats = MotionStatistics(0.1, 0.3, 0.1, (0.0, 0.0), 0.5, 100, fastest=2.0)
    >>> head_slaves(measured_config(GOAConfig(), stats), 10), head_slaves(GOAConfig(), 10)
    (4, None)
    """
    if not isinstance(config.individual, PersistentModel) or max_gap <= RANDOM_WALK_SLAVES:
        return None
    persistence = min(max(config.individual.statistics.persistence, 0.0), 1.0)
    return RANDOM_WALK_SLAVES + int(round((max_gap - RANDOM_WALK_SLAVES) * persistence))


def without_faster_links(tracks: Tracks, limit: float) -> Tracks:
    """``tracks`` split wherever consecutive measured points of a track are farther apart than
    ``limit`` (pixels/frame, gap-normalised, in the image; speeds at the limit pass whatever the
    rounding); the positions filled in across such a link are dropped.

    Example
    -------
    >>> xy = np.array([[[0.0, 0.0], [3.0, 4.0], [np.nan, np.nan], [23.0, 4.0]]])
    >>> split = without_faster_links(Tracks.from_dense(xy, np.array([[0, 0, -1, 0]])), 6.0)
    >>> split.n_tracks, split.point_track.tolist()
    (2, [0, 0, 1])
    """
    measured = np.flatnonzero(tracks.point_measurement != NO_MEASUREMENT)
    same = tracks.point_track[measured[1:]] == tracks.point_track[measured[:-1]]
    gap = tracks.point_column[measured[1:]] - tracks.point_column[measured[:-1]]
    velocity = (tracks.point_xy[measured[1:]] - tracks.point_xy[measured[:-1]]) / np.maximum(gap, 1)[:, None]
    cut = same & ~SpeedLimits(d_max=limit).admits(velocity)
    if not cut.any():
        return tracks
    keep = np.ones(tracks.point_track.size, bool)
    start = np.zeros(tracks.point_track.size, bool)
    for a, b in zip(measured[:-1][cut], measured[1:][cut]):
        keep[a + 1 : b] = False
        start[b] = True
    start[1:] |= tracks.point_track[1:] != tracks.point_track[:-1]
    start[0] = True
    track = np.cumsum(start)[keep] - 1
    return Tracks(
        tracks.n_frames, track, tracks.point_column[keep], tracks.point_xy[keep], tracks.point_measurement[keep],
        tracks.point_interpolated[keep], tracks.first_frame,
    )


__all__ = ["track_measured_motion", "first_pass", "sample_frames", "measuring_sample", "SAMPLE_POINTS", "SAMPLE_FRAMES", "measured_config", "head_slaves", "without_faster_links", "MEASURED_MOTION_GATE_SIGMAS", "SPEED_MARGIN", "FIRST_LINK_SCALE", "REFITS", "RANDOM_WALK_SLAVES"]
