"""A motion model for the whole range from random walks to smooth motion, fitted to the data.

Each point's next velocity is taken to be ``persistence`` times its last one (0 for a random
walk, negative for velocity that reverses, as of points swinging about fixed sites, 1 for
motion that keeps its velocity) plus Gaussian noise whose variance per axis grows
with the speed: ``noise**2 + (relative * speed)**2`` (a random walk has only the first term;
speed and direction steps of PSMG-like motion are proportional to the speed, the second). A
candidate link costs its squared Mahalanobis distance from that prediction, scaled so that
``gate`` sigmas cost phi_max: one optimal assignment of such costs is the most likely set of
links (global nearest neighbour, as a Kalman tracker with a known model would make them).

The parameters are measured, not set: :func:`fit_statistics` regresses each link's velocity on
the velocity before it, over the tracks of a first pass, leaving out the links that fit worst
(the wrong links a first pass makes). A head with no velocity yet is scored against the drift
with the spread of all measured velocities.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Iterable

import numpy as np
from scipy.spatial import cKDTree

from .motion import Candidates, IndividualModel
from .tracks import NO_MEASUREMENT, Tracks

# Sigmas from the prediction at which a link costs phi_max (the weight of a slave). Under a 2-D
# Gaussian, a true link falls beyond 3.5 sigma with probability exp(-3.5**2 / 2) = 0.2%.
DEFAULT_GATE_SIGMAS = 3.5
# Links whose squared change exceeds this many times its variance (per axis, halved: an
# exponential variable of mean 1 for Gaussian noise; 4.5 is 3 sigma) are left out of the fit as
# a first pass's wrong links; the variance of those kept is divided by the share of an
# exponential's mean that lies below the cut, so that clean Gaussian noise is not underestimated.
_CUT = 4.5
_KEPT_MEAN = (1.0 - (1.0 + _CUT) * np.exp(-_CUT)) / (1.0 - np.exp(-_CUT))
_ROUNDS = 5
# The first cut's variance comes from this quantile of the squared changes (an exponential's
# quantile q is -log(1 - q) times its mean), not the median: it stands while up to 75% of a first
# pass's chains are wrong. A first pass can link more wrongly than rightly (dishes 15% missed,
# 200 frames: 42% of chains right on seed 1000), and a median then gave the wrong links'
# variance, kept nearly all chains, and fitted persistence 0.70 and noise 0.51 x speed.
_START_QUANTILE = 0.25
# Noise is never taken below this, pixels/frame per axis (positions are rarely better), nor below
# what positions on a grid can hold (:func:`grid_step`).
_MIN_NOISE = 0.1
# Degrees of freedom of the heavy-tailed likelihood a join is weighed by (_tail).
_TAIL_DOF = 4.0
# Runs of filled-in points longer than this are not counted as misses (_miss_chance).
_SHORT_GAP = 3
# Longest gap, frames spanned, for which returns are measured (_returns): the default max_gap + 1.
_RETURN_GAPS = 11
# Least triplets (three consecutive measured points on one track) that a fit needs.
_MIN_TRIPLETS = 10
_FASTEST = 0.99


@dataclass(frozen=True)
class MotionStatistics:
    """How velocity carries over from frame to frame, measured on tracks.

    Attributes
    ----------
    persistence : float
        Share of a point's last velocity kept into the next frame (0 random walk, 1 smooth,
        negative down to -1 for velocity that reverses).
    noise : float
        Per-axis standard deviation of the velocity change at speed 0, pixels/frame.
    relative : float
        Per-axis standard deviation of the velocity change per pixel/frame of speed.
    drift : tuple of float
        Mean velocity (x, y), pixels/frame.
    spread : float
        Per-axis standard deviation of the velocities about the drift, pixels/frame (scores
        the first link of a head that has no velocity yet).
    triplets : int
        Three-frame chains the fit used.
    turn : float
        Angle by which a velocity turns from one frame to the next, radians (a turning dish:
        its angular speed; 0 when turns are at random).
    fastest : float
        99th percentile of the speeds about the drift on the chains that fit the model,
        pixels/frame (wrong links seldom chain smoothly, so this is the true motion's).
    along, across : tuple of float or None
        (noise, relative) of the velocity change along the last velocity and across it, as
        ``noise`` and ``relative`` are per axis (pixels/frame, per pixel/frame of speed): speed
        steps and turns differ (PSMG-like motion: speed steps of a fixed size, turns that grow
        with the speed). None: both are ``noise`` and ``relative``.
    missed : float or None
        Chance that a tracked point is missed in a frame, measured on the tracks (their filled-in
        share); a link across missed frames pays for each. None: gaps pay nothing for it.
    sudden : float
        Share of velocity changes the smooth model does not explain beyond its own Gaussian tail
        (bounces off a wall, collisions, a first pass's wrong links).
    density : float or None
        Measured points per frame per square pixel. With ``sudden`` and ``missed``, a link to any
        velocity no faster than the last is weighed against a miss (see
        :meth:`PersistentModel.cost`). None: no such links.
    ended : float or None
        Chance that a track ends in a frame (its point gone for good: out of view, out of focus,
        or a first pass's track that lost its point), measured on the tracks. With ``missed`` it
        tells a track missed for a few frames from one gone (:meth:`chance_there`).
    started : float or None
        Tracks that start after the first frame, per frame per square pixel of the view,
        measured on the tracks: how likely a point is a new object rather than one seen before
        (:meth:`PersistentModel.join_costs`). None: not measured.
    returns : tuple of float or None
        Per gap of g = 2, 3, ... frames: the chance that where a run of measured points ends, a
        run starts g frames later near it beyond what the start rate puts there (see
        :func:`measured_chains`). Where objects vanish for a while (beads out of focus), a miss
        is seldom alone, and a join across g frames is likelier than independent misses say.
        None: not measured.
    """

    persistence: float
    noise: float
    relative: float
    drift: tuple[float, float]
    spread: float
    triplets: int
    turn: float = 0.0
    fastest: float = 0.0
    along: tuple[float, float] | None = None
    across: tuple[float, float] | None = None
    missed: float | None = None
    sudden: float = 0.0
    density: float | None = None
    ended: float | None = None
    started: float | None = None
    returns: tuple[float, ...] | None = None

    def gap_growth(self, gap: np.ndarray) -> np.ndarray:
        """Factor by which the variance of a velocity averaged over ``gap`` frames (its
        gap-normalised velocity across missed frames) differs from one frame's."""
        # A random walk's varies g times less (its steps average out), a velocity random walk's
        # (g + 1)(2g + 1) / 6g times more (its velocity errors add up); persistence weighs the two.
        # A reversing velocity's errors are carried over as a persistent one's are, with their sign.
        kept = abs(self.persistence)
        return (1.0 - kept) / gap + kept * (gap + 1.0) * (2.0 * gap + 1.0) / (6.0 * gap)

    def chance_there(self, missed: np.ndarray) -> np.ndarray:
        """Chance that a track whose point was missed in its last ``missed`` frames is still
        there (its point missed, not gone), from the measured miss chance and the chance
        ``ended`` that a track ends in a frame; without ``ended``, the miss chance to that power.

        Example
        -------
        >>> stats = MotionStatistics(0.0, 1.5, 0.0, (0.0, 0.0), 1.5, 100, missed=0.1, ended=0.005)
        >>> stats.chance_there(np.array([0, 1, 2, 3])).round(2).tolist()
        [1.0, 0.95, 0.64, 0.15]
        """
        missed = np.asarray(missed, dtype=float)
        if self.missed is None:
            return np.ones(missed.shape)
        if self.ended is None:
            return self.missed**missed
        kept = (1.0 - self.ended) * self.missed
        there = kept**missed
        return there / (there + self.ended * (1.0 - there) / (1.0 - kept))

    @property
    def weighs_sudden_changes(self) -> bool:
        """Whether links to sudden velocity changes are weighed against a miss: some were
        measured, and so were the miss chance and the point density they are set against."""
        return self.sudden > 0 and self.missed is not None and bool(self.density)

    def describe(self) -> str:
        """One line for the user."""
        # With little velocity kept, its turning is noise and says nothing.
        turning = f", turning {np.degrees(self.turn):.1f} deg/frame" if self.persistence >= 0.1 else ""
        return (
            f"velocity persistence {self.persistence:.2f} (-1 reversing, 0 random walk, 1 smooth){turning}, noise {self.noise:.2f} px/frame + {self.relative:.2f} x speed "
            f"(per axis, {self.triplets} chains)"
        )


def fit_statistics(tracks: Tracks) -> MotionStatistics | None:
    """Fit :class:`MotionStatistics` to the measured links of ``tracks``.

    Parameters
    ----------
    tracks : Tracks
        A first pass's tracks; only consecutive measured points count (no interpolated ones).

    Returns
    -------
    MotionStatistics or None
        None when the tracks hold fewer than 10 three-frame chains.

    Example
    -------
    >>> t = np.arange(8.0)[:, None]
    >>> xy = np.stack([3.0 * t * [np.cos(a), np.sin(a)] for a in (0.0, 2.0, 4.0)])
    >>> stats = fit_statistics(Tracks.from_dense(xy, np.zeros((3, 8), np.int64)))
    >>> round(stats.persistence, 2), abs(round(stats.turn, 2))
    (1.0, 0.0)
    """
    chains = measured_chains(tracks)
    return None if chains is None else fit_chains(chains)


@dataclass(frozen=True)
class Chains:
    """Three-frame chains of measured points (two links in a row), what the motion is fitted on.

    Attributes
    ----------
    before, after : ndarray of float, shape (T, 2)
        Each chain's first and second velocity, about the drift, pixels/frame.
    drift : ndarray of float, shape (2,)
        Median velocity (x, y) of all measured links, pixels/frame.
    spread : float
        Robust per-axis spread of the links' velocities about the drift, pixels/frame.
    missed : float or None
        Chance that a tracked point is missed in a frame (see :class:`MotionStatistics`).
    density : float or None
        Measured points per frame per square pixel of the box they fill.
    resolution : float
        Step of the grid the positions lie on, pixels (:func:`grid_step`); 0 for none.
    localisation : float
        Given localisation error of the positions, pixels per axis (standard deviation); 0 for
        none known.
    returns : tuple of float or None
        Measured returns per gap (see :class:`MotionStatistics`).
    """

    before: np.ndarray
    after: np.ndarray
    drift: np.ndarray
    spread: float
    missed: float | None = None
    density: float | None = None
    ended: float | None = None
    started: float | None = None
    resolution: float = 0.0
    localisation: float = 0.0
    returns: tuple[float, ...] | None = None


def measured_chains(tracks: Tracks, localisation: float = 0.0) -> Chains | None:
    """The three-frame chains of ``tracks`` (see :func:`fit_statistics`), None when fewer than 10;
    ``localisation`` (pixels per axis) is the positions' given localisation error.

    Apart from the fit so that a caller can let the tracks go before it: on a million points
    their arrays were 41 MB of the fit's peak.

    Example
    -------
    >>> xy = np.stack([np.column_stack((np.arange(4.0), np.zeros(4)))] * 5) + np.arange(5.0)[:, None, None] * [0, 10]
    >>> chains = measured_chains(Tracks.from_dense(xy, np.zeros((5, 4), np.int64)))
    >>> chains.before.shape, chains.drift.tolist()
    ((10, 2), [1.0, 0.0])
    """
    # From the point arrays, not the dense (tracks x frames) views, which would outlive the call
    # in the tracks' cache: a link joins a measured point to the track's measured point in the
    # next frame; in track-then-frame order, as the points are.
    measured = tracks.point_measurement != NO_MEASUREMENT
    missed = _miss_chance(tracks.point_interpolated)
    # Tracks that end before the clip does, per frame a track runs (Laplace's rule as above).
    last = np.zeros(tracks.n_tracks, np.int64)
    np.maximum.at(last, tracks.point_track, tracks.point_column)
    ended = (np.count_nonzero(last < tracks.n_frames - 1) + 1.0) / (measured.size + 2.0)
    seen = tracks.point_xy[measured]
    resolution = grid_step(seen)
    box = np.prod(np.maximum(np.ptp(seen, axis=0), 1.0)) if seen.size else 1.0
    density = float(seen.shape[0] / (max(tracks.n_frames, 1) * box))
    first = np.full(tracks.n_tracks, tracks.n_frames, np.int64)
    np.minimum.at(first, tracks.point_track, tracks.point_column)
    started = float((np.count_nonzero((first > 0) & (first < tracks.n_frames)) + 1.0) / (max(tracks.n_frames - 1, 1) * box))
    del seen
    link = (tracks.point_track[1:] == tracks.point_track[:-1]) & (tracks.point_column[1:] == tracks.point_column[:-1] + 1)
    link &= measured[1:] & measured[:-1]
    start = np.flatnonzero(link)
    velocities = tracks.point_xy[start + 1] - tracks.point_xy[start]
    # Two links in a row: the second starts where the first ends.
    chained = np.zeros(start.size, bool)
    inside = start + 1 < link.size
    chained[inside] = link[start[inside] + 1]
    if np.count_nonzero(chained) < _MIN_TRIPLETS:
        return None
    drift = np.median(velocities, axis=0)
    # Robust to a first pass's absurd links: the median squared speed about the drift, per axis
    # (an exponential variable's median is ln 2 of its mean for Gaussian velocities).
    about = velocities - drift
    spread = float(np.sqrt(np.median(np.einsum("ij,ij->i", about, about)) / (2.0 * np.log(2.0))))
    # Chains in place, so that a million of them hold no more copies than the fit needs.
    del about, start, link, measured
    b_all, a_all = velocities[chained], velocities[np.flatnonzero(chained) + 1]
    del velocities
    b_all -= drift
    a_all -= drift
    returns = _returns(tracks, spread, box)
    return Chains(b_all, a_all, drift, spread, missed, density, ended, started, resolution, localisation, returns)


def _returns(tracks: Tracks, spread: float, box: float) -> tuple[float, ...]:
    """Per gap g = 2 .. ``_RETURN_GAPS`` frames: the share of the ends of runs of measured points
    (a track's end, or where its filled-in points begin) near which a run starts g frames later,
    beyond the starts the measured start rate puts there by chance.

    Near: within 3 sqrt(2 g) ``spread`` (pixels/frame per axis, the velocities' spread about the
    drift), where a point that moves at random is found after g frames; an object on a smooth
    path is farther and shows none, and its joins are weighed on independent misses. Counted on
    the runs, not on the tracks' joins: a first pass's joins of one object to another (objects
    that leave while others enter) are then starts at the start rate, no excess. The excess less
    two of its Poisson sigmas, so that chance alone gives none.

    Example
    -------
    A point seen in frames 0-3 and 6-9 at rest, another in 0-9 far away:

    >>> xy = np.zeros((2, 10, 2)); xy[1] += 50.0
    >>> measurement = np.zeros((2, 10), np.int64); measurement[0, 4:6] = NO_MEASUREMENT
    >>> xy[0, 4:6] = np.nan
    >>> [round(float(r), 2) for r in _returns(Tracks.from_dense(xy, measurement), 0.3, 2500.0)[:3]]
    [0.0, 0.95, 0.0]
    """
    measured = tracks.point_measurement != NO_MEASUREMENT
    track, column, xy = tracks.point_track[measured], tracks.point_column[measured], tracks.point_xy[measured]
    opens = np.r_[True, (track[1:] != track[:-1]) | (column[1:] != column[:-1] + 1)]
    first = np.flatnonzero(opens)
    last = np.r_[first[1:] - 1, track.size - 1]
    start_column, end_column = column[first], column[last]
    n = tracks.n_frames
    rate = np.count_nonzero(start_column > 0) / (max(n - 1, 1) * box)
    # One search for all frames: the frame is a third coordinate, frames farther apart than any
    # radius, so that only starts of the one frame asked for lie within it.
    apart = 2.0 * 3.0 * spread * np.sqrt(2.0 * _RETURN_GAPS) + 1.0
    starts = cKDTree(np.column_stack((xy[first], start_column * apart)))
    returns = []
    for gap in range(2, _RETURN_GAPS + 1):
        radius = 3.0 * spread * np.sqrt(2.0 * gap)
        ends = last[end_column + gap < n]
        found = int(np.sum(starts.query_ball_point(np.column_stack((xy[ends], (column[ends] + gap) * apart)), radius, return_length=True)))
        chance = ends.size * rate * np.pi * radius**2
        returns.append(min(max(found - chance - 2.0 * float(np.sqrt(chance)), 0.0) / max(ends.size, 1), 1.0))
    return tuple(returns)


def grid_step(xy: np.ndarray) -> float:
    """Step of the grid that every position lies on, pixels: 1 for whole pixels, 0.5, 0.25,
    0.2 or 0.1 for positions rounded to those; 0 when they lie on none of them.

    Example
    -------
    >>> grid_step(np.array([[3.0, 4.0], [7.0, -2.0]])), grid_step(np.array([[3.5, 4.0]])), grid_step(np.array([[3.14, 4.0]]))
    (1.0, 0.5, 0.0)
    """
    # Judged on at most 100,000 coordinates spread over all of them: on a million points a
    # scaled copy of every one would add 16 MB to the fit's peak.
    xy = np.ravel(xy)[:: max(np.size(xy) // 100_000, 1)]
    for per_pixel in (1, 2, 4, 5, 10):
        scaled = xy * per_pixel
        if xy.size and np.all(np.abs(scaled - np.round(scaled)) < 1e-6 * np.maximum(1.0, np.abs(scaled))):
            return 1.0 / per_pixel
    return 0.0


def _miss_chance(interpolated: np.ndarray) -> float:
    """Chance that a tracked point is missed in a frame: the share of the points filled in, of
    those in runs of at most ``_SHORT_GAP`` frames.

    A join of two objects across a long gap fills in many points: a first pass that joined where
    objects leave and others enter measured a miss chance of 0.16 on a scene with none missed,
    which then made the next pass's joins cheap. True misses come mostly one or two at a time
    (at a miss chance of 0.15, 99.7% of the missed points).

    Example
    -------
    >>> round(_miss_chance(np.array(([False] * 6 + [True] + [False] * 2 + [True] * 5) * 10)), 3)
    0.077
    """
    padded = np.concatenate(([False], interpolated, [False]))
    edges = np.flatnonzero(np.diff(padded.astype(np.int8)))
    lengths = edges[1::2] - edges[::2]
    short = int(lengths[lengths <= _SHORT_GAP].sum())
    # Laplace's rule on the points: tracks with no gap at all still leave a chance.
    return (short + 1.0) / (interpolated.size + 2.0)


def fit_chains(chains: Chains) -> MotionStatistics:
    """Fit :class:`MotionStatistics` to three-frame chains (see :func:`fit_statistics`).

    Example
    -------
    >>> before = np.tile([[1.0, 0.0], [2.0, 0.0]], (10, 1))
    >>> stats = fit_chains(Chains(before, before.copy(), np.zeros(2), 1.0))
    >>> round(stats.persistence, 2), stats.triplets
    (1.0, 20)
    """
    b_all, a_all, drift, spread = chains.before, chains.after, chains.drift, chains.spread
    triplets = b_all.shape[0]
    # Positions rounded to a grid of step q are each off by a variance q**2 / 12 per axis, and a
    # velocity change (x2 - 2 x1 + x0) by 6 times that. Below this floor whole-pixel walkers,
    # many of whose changes are exactly 0, were fitted 0.1 px of noise, a point 0.5 px off its
    # prediction cost more than a miss, and one walker became two tracks taking turns.
    # A localisation error sigma per axis, independent from point to point, puts 6 sigma**2 on
    # each velocity change in the same way.
    floor = max(_MIN_NOISE, chains.resolution / np.sqrt(2.0), np.sqrt(6.0) * chains.localisation)
    speed2 = np.einsum("ij,ij->i", b_all, b_all)
    # First round: links whose change is within the cut of the median change (as if the noise
    # did not depend on the speed), so a first pass's wrong links cannot steer the start.
    keep = np.ones(triplets, bool)
    variance = None
    for round_ in range(_ROUNDS):
        # Persistence and turning about the drift (the similarity transform that best maps each
        # velocity to the next: a rigid turn, as of a dish, is kept), then the variance model by
        # least squares on the squared change.
        if variance is None:
            # At the start, the median over chains of each one's own transform: where a first
            # pass links wrongly as often as rightly, a least-squares start would be the wrong
            # links' (a dish 15% missed: persistence 0.8 and noise 0.4 x speed against 1.0 and 0.01).
            # Every chain is kept in this round.
            moving = speed2 > 0
            b, a = b_all[moving], a_all[moving]
            along = float(np.median(np.einsum("ij,ij->i", b, a) / speed2[moving])) if moving.any() else 0.0
            across = float(np.median((b[:, 0] * a[:, 1] - b[:, 1] * a[:, 0]) / speed2[moving])) if moving.any() else 0.0
        else:
            b, a = b_all[keep], a_all[keep]
            norm = max(float(np.einsum("ij,ij->", b, b)), 1e-12)
            along = float(np.einsum("ij,ij->", b, a)) / norm
            across = float(np.sum(b[:, 0] * a[:, 1] - b[:, 1] * a[:, 0])) / norm
        persistence, turn = min(float(np.hypot(along, across)), 1.0), float(np.arctan2(across, along))
        if along <= 0:
            # Velocity that reverses (points swinging about fixed sites) is measured as such: a
            # persistence clipped to 0 called it a random walk, predicted the point at rest and
            # took its noise from the whole swing (issue 29).
            persistence, turn = max(along, -1.0), 0.0
        del b, a
        change = _turned(b_all, turn)
        change *= persistence
        np.subtract(a_all, change, out=change)
        squared = np.einsum("ij,ij->i", change, change) / 2.0
        del change
        if variance is None:
            variance = np.full(squared.shape, max(float(np.quantile(squared, _START_QUANTILE)) / -np.log1p(-_START_QUANTILE), floor**2))
        else:
            # The last round's variances are replaced below; freed first, they are not held
            # through the least-squares fit (the fit's peak).
            del variance
            noise2, relative2 = _non_negative_fit(speed2[keep], squared[keep])
            noise2, relative2 = noise2 / _KEPT_MEAN, relative2 / _KEPT_MEAN
            variance = np.maximum(noise2 + relative2 * speed2, floor**2)
            fitted = keep
        keep = squared / variance <= _CUT
        if keep.sum() < _MIN_TRIPLETS:
            keep = squared <= np.quantile(squared, 0.5)
    fastest = float(np.quantile(np.sqrt(speed2[keep]), _FASTEST)) if keep.any() else 0.0
    # Gaussian changes fall beyond the cut with probability exp(-cut); the excess is the share of
    # changes the smooth model does not explain.
    sudden = max(float(np.mean(~keep)) - float(np.exp(-_CUT)), 0.0)
    along, across = _components(b_all, a_all, speed2, fitted & (speed2 > 0), persistence, turn, floor)
    return MotionStatistics(
        persistence,
        max(float(np.sqrt(noise2)), floor),
        float(np.sqrt(relative2)),
        (float(drift[0]), float(drift[1])),
        max(spread, floor),
        triplets,
        turn,
        fastest,
        along,
        across,
        chains.missed,
        sudden,
        chains.density,
        chains.ended,
        chains.started,
        chains.returns,
    )


def _components(before_all: np.ndarray, after_all: np.ndarray, speed2_all: np.ndarray, use: np.ndarray, persistence: float, turn: float, floor: float = _MIN_NOISE):
    """(noise, relative) of the velocity changes along and across the velocity before them, on
    the chains ``use`` marks (those the isotropic fit kept, with a velocity before them: a chain
    at rest has no direction) and scaled as that fit is. Both share its noise at speed 0 (a
    point at rest has no direction; fitted apart, a turn after a near stop was a dozen sigmas
    across) and each has its own growth with the speed."""
    if np.count_nonzero(use) < _MIN_TRIPLETS:
        return None, None
    # Taken apart and freed as soon as used: on 10,000 walkers x 100 frames each of these arrays
    # is 8 to 16 MB, and all of them at once made this the peak of `seedtrack track`.
    before = before_all[use]
    change = _turned(before, turn)
    change *= persistence
    np.subtract(after_all[use], change, out=change)
    speed2 = speed2_all[use]
    unit = before / np.sqrt(speed2)[:, None]
    del before
    parts = (change[:, 0] * unit[:, 0] + change[:, 1] * unit[:, 1], change[:, 1] * unit[:, 0] - change[:, 0] * unit[:, 1])
    del change, unit
    raw, _ = _non_negative_fit(speed2, parts[0] * parts[0])
    weight = max(float(np.dot(speed2, speed2)), 1e-12)
    noise = max(float(np.sqrt(raw / _KEPT_MEAN)), floor)
    return tuple((noise, float(np.sqrt(max(float(np.dot(speed2, part * part - raw)) / weight, 0.0) / _KEPT_MEAN))) for part in parts)


def _turned(v: np.ndarray, angle: float) -> np.ndarray:
    """Vectors (N, 2) turned by ``angle`` radians (x right, y down: clockwise on screen)."""
    c, s = np.cos(angle), np.sin(angle)
    turned = np.empty_like(v, dtype=float)
    # Column by column in place: on a million chains the temporaries would be the fit's peak.
    np.multiply(v[:, 0], c, out=turned[:, 0])
    turned[:, 0] -= s * v[:, 1]
    np.multiply(v[:, 0], s, out=turned[:, 1])
    turned[:, 1] += c * v[:, 1]
    return turned


def _predicted(about: np.ndarray, gap: np.ndarray, span: np.ndarray, persistence: float, turn: float) -> np.ndarray:
    """Predicted mean velocity about the drift over the next ``gap`` frames (P, 2), from velocities
    ``about`` (P, 2) that are means over ``span`` frames: on a turning dish a velocity measured
    across a missed frame points half a turn behind the seed's last one, and the mean over a
    gap of g frames half a turn per missed frame ahead of the next one (at rim speed 42 and
    11 degrees a frame, 4 px/frame each: about the whole gate).

    Each mean is turned by half a turn per frame it spans beyond one (its length is kept, so no
    prediction is longer than ``persistence`` times the velocity), then carried over the gap:
    the mean over k = 1..g of (persistence e^(i turn))^k."""
    return _predictions(about, gap, span, persistence, (turn,))[0]


def _predictions(about: np.ndarray, gap: np.ndarray, span: np.ndarray, persistence: float, turns: Iterable[float]) -> list[np.ndarray]:
    """:func:`_predicted` for each of ``turns`` (radians), the gap and span looked up once."""
    if about.shape[0] == 0:
        return [about for _ in turns]
    # The (gap, span) pairs as one number each, looked up in a table of the few present: np.unique
    # over rows cost more than the rest of the prediction.
    wide = span.max() + 1
    key = gap * wide + span
    present = np.flatnonzero(np.bincount(key))
    complex_about = about[:, 0] + 1j * about[:, 1]
    # As Python numbers, the cache's keys hash several times faster.
    factors = list(zip((present // wide).tolist(), (present % wide).tolist()))
    predictions = []
    for turn in turns:
        table = np.empty(present[-1] + 1, complex)
        table[present] = [_carried(persistence, turn, g, m) for g, m in factors]
        # Times a whole array, not a scalar: numpy's loops for the two round differently.
        turned = complex_about * table[key]
        # The (x, y) pairs are the complex numbers' own (real, imaginary) pairs: no copy.
        predictions.append(turned.view(float).reshape(-1, 2))
    return predictions


@functools.lru_cache(maxsize=1024)
def _carried(persistence: float, turn: float, gap: int, span: int) -> complex:
    """:func:`_predicted`'s factor for one gap and span (frames), asked for at every step of a
    pass with the same few arguments."""
    step = persistence * np.exp(1j * turn)
    return np.mean(step ** np.arange(1, gap + 1)) * np.exp(0.5j * (span - 1) * turn)


def _tail(squared: np.ndarray) -> np.ndarray:
    """Twice the negative log-likelihood (up to a constant) of a residual ``squared`` sigmas
    from its prediction under Student's t with ``_TAIL_DOF`` degrees of freedom: real velocity
    changes have longer tails than a Gaussian's (the final pass's gate is 9 sigmas for them), and
    weighed on a Gaussian, true joins 5 sigmas out were refused where seeds are missed often. Seen
    on a reporting clip (a dish of 80 seeds 15% missed, bench_must_show.py's seed 1001: track
    error 0.075 before issue 29, 0.30 weighed on a Gaussian, 0.19 on this), so that figure is no
    longer held out; on tuning seeds 0-7 the degrees of freedom (1, 2, 4) changed nothing."""
    return (_TAIL_DOF + 2.0) * np.log1p(squared / _TAIL_DOF)


def _non_negative_fit(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """Least-squares c0, c1 >= 0 of y = c0 + c1 x."""
    design = np.column_stack((np.ones_like(x), x))
    c0, c1 = np.linalg.lstsq(design, y, rcond=None)[0]
    if c1 < 0:
        return float(max(np.mean(y), 0.0)), 0.0
    if c0 < 0:
        return 0.0, float(max(np.dot(x, y) / max(np.dot(x, x), 1e-12), 0.0))
    return float(c0), float(c1)


@dataclass(frozen=True)
class PersistentModel(IndividualModel, key="persistent"):
    """The individual model of :class:`MotionStatistics`: cost of a link from its prediction.

    The default link cost: registered as "persistent" beside IM1-IM3
    (:data:`seedtrack.tracking.motion.INDIVIDUAL_MODELS`), built by that name from the
    statistics a first pass measured (``IndividualModel(name="persistent", statistics=...)``).
    Three-frame first links are still scored by IM2's direction and speed (``w1``, ``w2``),
    which suits a first link whatever the scale of the motion.

    Attributes
    ----------
    statistics : MotionStatistics
    gate : float
        Sigmas at which a link costs phi_max.
    w1, w2 : float
        IM2 weights used to score first links over three frames.
    speed_scale : float or None
        Speed that costs phi_max in the nearest-neighbour share of a first link's score,
        pixels/frame; None for the speed limit (or the farthest candidate), as for IM2.
    """

    statistics: MotionStatistics
    gate: float = DEFAULT_GATE_SIGMAS
    w1: float = 0.1
    w2: float = 0.9
    speed_scale: float | None = None
    name: str = "persistent"

    def __post_init__(self) -> None:
        self._check_name()

    def cost(self, candidates: Candidates, phi_max: float, d_max: float) -> np.ndarray:
        """``phi_max`` times the squared distance of each candidate velocity from its prediction
        in units of ``gate`` sigmas (d_max is not used: a speed limit only removes links).

        A pass does not say which way it runs in time, and backwards a velocity turns the other
        way: the prediction turned either way that fits better is taken.

        Example
        -------
        >>> stats = MotionStatistics(1.0, 0.5, 0.0, (0.0, 0.0), 2.0, 100)
        >>> pairs = Candidates(np.array([0]), np.array([0]), np.array([[3.0, 0.5]]), np.array([1]), np.array([[3.0, 0.0]]))
        >>> float(PersistentModel(stats, gate=1.0).cost(pairs, 0.1, 10.0)[0])
        0.1
        """
        squared, spread, one_frame, gap = self._parts(candidates)
        cost = phi_max * (squared + spread) / self.gate**2
        back = np.flatnonzero(gap > 1) if self._decides_joins else ()
        if len(back):
            # A head back from slaves takes a point only where that is likelier than its track
            # having ended and the point being a new object (the measured end chance and start
            # rate), as gap closing decides (:meth:`join_costs`): otherwise a head on slaves took
            # the point of an object that entered 30 px away six frames later (issue 29).
            join = self._join_terms(squared[back], spread[back], one_frame[back], gap[back])
            cost[back[join > self._new_terms(one_frame[back])]] = np.inf
        return cost

    @property
    def _decides_joins(self) -> bool:
        s = self.statistics
        return s.ended is not None and s.started is not None and s.missed is not None

    def _parts(self, candidates: Candidates) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Per candidate: squared distance from the prediction in sigmas, the spread and miss
        terms of a gap (see :meth:`cost`), the one-frame variance per axis and the gap."""
        s = self.statistics
        drift = np.asarray(s.drift)
        previous = candidates.previous_velocity
        known = ~np.isnan(previous[:, 0])
        about = np.where(known[:, None], previous - drift, 0.0)
        speed2 = np.einsum("ij,ij->i", about, about)
        gap = candidates.gap.astype(float)
        growth = s.gap_growth(gap)
        variance = np.where(known, s.noise**2 + s.relative**2 * speed2, s.spread**2 + s.noise**2) * growth
        span = np.ones(gap.shape, np.int64) if candidates.previous_span is None else candidates.previous_span
        moved = candidates.velocity - drift
        squared = None
        for prediction in _predictions(about, candidates.gap, span, s.persistence, {s.turn, -s.turn}):
            residual = moved - prediction
            residual = np.einsum("ij,ij->i", residual, residual)
            squared = residual if squared is None else np.minimum(squared, residual)
        if squared is None:
            squared = np.full(known.shape, np.inf)
        # The measurement is a position: its density across a gap is spread over the g^2 growth
        # times larger variance of the displacement, which a link over one frame does not pay
        # (twice the log of that ratio, in units of the squared distance). Without it a head back
        # from a slave wins a point at the same distance from two heads, and two tracks take
        # turns at one walker by the view's edge.
        squared = squared / variance
        if s.weighs_sudden_changes:
            # A sudden change: any velocity no faster than the last (a bounce off a wall reverses
            # a component and, where the wall stops it, shortens the step: many sigmas of the
            # smooth model; without this its head took slaves and ran on while a new track
            # started on the bounced point). Its chance, the measured share of sudden changes
            # spread evenly over the disc of the last speed (plus a sigma, Gaussian beyond), is
            # weighed against the head's point being missed and this one being any other point
            # (the measured point density): such a link costs phi_max, as a slave does, where the
            # two are as likely, less where the change is likelier.
            reach = np.sqrt(speed2) + np.sqrt(variance)
            away = np.hypot(*moved.T)
            turned = np.maximum(away - reach, 0.0) ** 2 / variance + 2.0 * np.log(np.pi * reach**2)
            turned += self.gate**2 - 2.0 * np.log(s.sudden / (s.missed * s.density))
            squared = np.where(known, np.minimum(squared, np.maximum(turned, 0.0)), squared)
        spread = 2.0 * np.log(gap * gap * growth)
        # Each missed frame is a miss of the measured chance: a head back from slaves pays for
        # them against heads that missed nothing. Without it tracks on slaves took walkers'
        # points where no point is ever missed (sigma 3, tuning seeds 0-11: 12 of the 61 links
        # only seedtrack got wrong against trackpy, 5 with it). Charging instead only the chance
        # that the track is gone (-2 ln chance_there) gained on Brownian points 10% missed
        # (strict merit 0.568 -> 0.581, tuning seeds 0-9) but lost on generated beads with
        # satellites (bench_beads.py, link error 0.0291 -> 0.0320).
        if s.missed is not None:
            spread -= 2.0 * (gap - 1.0) * np.log(s.missed)
        return squared, spread, variance / growth, gap

    def join_costs(self, bridge: Candidates, leaving: Candidates) -> np.ndarray | None:
        """Twice the negative log of the odds that track ends are the same objects as later
        track starts, per candidate join (negative: the join is the likelier), or None when the
        statistics do not hold the rates to weigh them by.

        A join across g frames explains the start's first point by the end's motion (its
        uncertainty grown over the g frames, :meth:`cost`, each missed frame a miss of the
        measured chance) and its first step by the bridge's velocity; the alternative is that
        the track ended there (the measured chance ``ended`` a frame) and a new object appeared
        where the start is (the measured rate ``started`` per frame and square pixel) with a
        first step drawn from the spread of all velocities.

        Parameters
        ----------
        bridge : Candidates
            From each end to each start: displacement, frames spanned and the end's velocity.
        leaving : Candidates
            The start's first velocity, after the bridge's (gap 1).

        Example
        -------
        >>> stats = MotionStatistics(1.0, 0.3, 0.0, (0.0, 0.0), 3.0, 100, missed=0.01, ended=0.01, started=1e-5)
        >>> end = np.array([[3.0, 0.0]])
        >>> near = Candidates(np.array([0]), np.array([0]), np.array([[9.0, 0.0]]), np.array([3]), end)
        >>> far = Candidates(np.array([0]), np.array([0]), np.array([[9.0, 40.0]]), np.array([3]), end)
        >>> out = Candidates(np.array([0]), np.array([0]), end, np.array([1]), end)
        >>> model = PersistentModel(stats)
        >>> bool(model.join_costs(near, out)[0] < 0), bool(model.join_costs(far, out)[0] < 0)
        (True, False)
        """
        s = self.statistics
        if not self._decides_joins:
            return None
        squared, spread, one_frame, gap = self._parts(bridge)
        join = self._join_terms(squared, spread, one_frame, gap)
        squared, spread, one_frame, _ = self._parts(leaving)
        join += _tail(squared) + spread + 2.0 * np.log(2.0 * np.pi * one_frame)
        spread2 = s.spread**2 + s.noise**2
        first = leaving.velocity - np.asarray(s.drift)
        new = np.einsum("ij,ij->i", first, first) / spread2 + 2.0 * np.log(2.0 * np.pi * spread2)
        new -= 2.0 * np.log(s.ended) + 2.0 * np.log(s.started)
        return join - new

    def within_gate(self, candidates: Candidates) -> np.ndarray:
        """Boolean per candidate: its cost (:meth:`cost`) within the gate, the misses of a gap
        charged as :meth:`join_costs` charges them: no more than the measured returns say
        where objects are seen to come back after that many frames, and a head back from
        slaves vetoed as :meth:`cost` vetoes it.

        Example
        -------
        A seed hidden for 5 frames where nothing else is ever missed: beyond the gate on
        independent misses, within it where the runs showed such returns.

        >>> stats = MotionStatistics(1.0, 0.5, 0.0, (0.0, 0.0), 2.0, 100, missed=4e-4, ended=4e-4, started=2e-7)
        >>> pairs = Candidates(np.array([0]), np.array([0]), np.array([[18.0, 0.5]]), np.array([6]), np.array([[3.0, 0.0]]))
        >>> back = MotionStatistics(1.0, 0.5, 0.0, (0.0, 0.0), 2.0, 100, missed=4e-4, ended=4e-4, started=2e-7, returns=(0.0, 0.0, 0.0, 0.0, 0.9))
        >>> PersistentModel(stats, gate=9.0).within_gate(pairs).tolist(), PersistentModel(back, gate=9.0).within_gate(pairs).tolist()
        ([False], [True])
        """
        squared, spread, one_frame, gap = self._parts(candidates)
        inside = squared + spread - self._returned(gap) <= self.gate**2
        back = np.flatnonzero(inside & (gap > 1)) if self._decides_joins else ()
        if len(back):
            # The veto of :meth:`cost` too: a join no likelier than an end and a new start.
            inside[back] = self._join_terms(squared[back], spread[back], one_frame[back], gap[back]) <= self._new_terms(one_frame[back])
        return inside

    def _join_terms(self, squared: np.ndarray, spread: np.ndarray, one_frame: np.ndarray, gap: np.ndarray) -> np.ndarray:
        """Twice the negative log-likelihood that a track end continues to a point ``gap`` frames
        later (squared sigmas, the gap's spread and miss terms of :meth:`cost`), its track not
        ending in between."""
        s = self.statistics
        join = _tail(squared) + spread + 2.0 * np.log(2.0 * np.pi * one_frame) - 2.0 * gap * np.log1p(-s.ended)
        return join - self._returned(gap)

    def _returned(self, gap: np.ndarray) -> np.ndarray:
        """What the measured returns take off the charge of ``gap - 1`` independent misses
        (twice the negative log-likelihood; 0 where none were measured).

        Where the runs show objects coming back near where they were lost, a join across g
        frames is weighed by that measured return (a run ending: a track's end or a miss)
        when it is likelier than g - 1 independent misses (bulk water: beads drift out of
        focus for several frames; weighed on independent misses, 0.05 ** 5 against an end,
        tracks of a bead were cut at every such gap)."""
        s = self.statistics
        if not s.returns or s.missed is None or s.ended is None:
            return np.zeros(np.shape(gap))
        index = np.clip(gap.astype(np.int64) - 2, 0, len(s.returns) - 1)
        back = np.where((gap >= 2) & (gap <= len(s.returns) + 1), np.asarray(s.returns)[index], 0.0)
        independent = -2.0 * (gap - 1.0) * np.log(s.missed) - 2.0 * gap * np.log1p(-s.ended)
        measured = -2.0 * np.log(np.maximum(back * (s.ended + (1.0 - s.ended) * s.missed), 1e-300))
        return np.maximum(independent - measured, 0.0)

    def _new_terms(self, one_frame: np.ndarray) -> np.ndarray:
        """The same for the track ending and the point being a new object, its next step drawn
        from the spread of all velocities rather than from this track's motion (the log of the
        ratio of their variances)."""
        s = self.statistics
        return -2.0 * np.log(s.ended * s.started) + 2.0 * np.log((s.spread**2 + s.noise**2) / one_frame)

    def likely_there(self, missed: np.ndarray) -> np.ndarray:
        """Boolean per head: after ``missed`` frames in a row without its point, the point is
        more likely missed than gone (:meth:`MotionStatistics.chance_there` above 1/2).

        Example
        -------
        >>> stats = MotionStatistics(0.0, 1.5, 0.0, (0.0, 0.0), 1.5, 100, missed=0.1, ended=0.005)
        >>> PersistentModel(stats).likely_there(np.array([0, 1, 2, 3])).tolist()
        [True, True, True, False]
        """
        return self.statistics.chance_there(missed) > 0.5

    def gate_radius(self, speed: np.ndarray, has_history: np.ndarray, phi_max: float) -> np.ndarray:
        """Per-head speed beyond which no candidate can cost under phi_max, pixels/frame."""
        s = self.statistics
        drift = float(np.hypot(*s.drift))
        # |v| <= |prediction| + gate sigma, with the prediction and speed taken about the drift
        # at their largest (speed + drift) so the bound holds whatever the direction.
        about = speed + drift
        moving = drift + abs(s.persistence) * about + self.gate * np.sqrt(s.noise**2 + s.relative**2 * about**2)
        still = drift + self.gate * np.sqrt(s.spread**2 + s.noise**2)
        if s.weighs_sudden_changes:
            # A sudden change to any velocity up to the last speed and a sigma, plus fewer
            # sigmas than the gate's beyond it (its chance is weighed against a miss's, above).
            moving = np.maximum(moving, drift + about + (1.0 + self.gate) * np.sqrt(s.noise**2 + s.relative**2 * about**2))
        return np.where(has_history, moving, still) * (1 + 1e-9) + 1e-9


__all__ = ["Chains", "MotionStatistics", "PersistentModel", "fit_chains", "fit_statistics", "grid_step", "measured_chains"]
