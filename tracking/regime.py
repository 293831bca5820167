"""Choose the motion model from the measurements alone: smooth motion or a random walk.

GOA's default individual model (IM2, Sethi-Jain smooth motion) with no speed limit is right
for objects whose direction persists from frame to frame (seeds on a turning dish). For
Brownian beads, random walkers or static points that only jitter, consecutive steps are
unrelated (or anti-correlated), IM2's direction and speed terms reward chance alignments and
tracks jump between neighbours. There the nearest-neighbour model IM1 with a speed limit works,
as trackpy's search range does.

:func:`choose_motion` tells the two apart without knowing the motion: it keeps only links that
cannot be wrong whatever the motion (mutual nearest neighbours between consecutive frames, much
closer than either point's nearest neighbour within its own frame), chains them over three
frames and measures how much the direction of motion persists. Steps that turn at random mean
a random walk: IM1, with a speed limit estimated from those same steps. Otherwise, or when too
few links are unambiguous to tell (dense or fast scenes), the smooth-motion default is kept.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Callable, Iterator, NamedTuple, Sequence

import numpy as np
from scipy.spatial import cKDTree

from .goa import GOAConfig
from .motion import IndividualModel, smooth_motion_cost
from .tracks import Tracks

# A link is unambiguous when its length is below this fraction of the within-frame
# nearest-neighbour distance of both its points: any other pairing is then at least
# (1 - fraction) / fraction times longer.
_CLEAR_FRACTION = 0.4
# Median cosine of the turning angle: about 1 for smooth motion, 0 for a random walk, negative
# for points that jitter about fixed positions. The median, not the mean, because in fast
# smooth scenes some "unambiguous" links are still wrong (a point lands where another was)
# and their chains turn at random. Between 0 and 1 drift and diffusion mix; below this the
# speed limit holds both, which IM1 with the estimated limit does.
_PERSISTENT = 0.5
# IM1 is chosen only if the unambiguous links are real, not coincidences: in a fast scene a
# point often lands where another one was, and such links turn at random like a random walk.
# The same count between frame k and frame k + 1 turned half a turn about its centre (no
# motion links these) says how many coincidences to expect; a random walk has under 0.25 as
# many of them as real links, a fast turning dish about as many.
_MAX_COINCIDENCE = 0.4
# Smooth motion whose steps vary so much that the smooth-motion model (IM2 at its default
# phi_max 0.1) would break tracks is better tracked by nearest neighbour within a speed limit:
# flow with diffusion gives a 90th percentile of about 0.08, smooth PSMG scenes under 0.02.
_ROUGH_QUANTILE = 0.9
_ROUGH_COST = 0.05
_IM2 = IndividualModel("im2")
# Fewer triplets than this (or than this fraction of the mean points per frame) cannot tell.
_MIN_TRIPLETS = 30
_MIN_TRIPLET_FRACTION = 0.05
# Speed limit = drift + this many sigmas of the per-axis step noise. 4 would already keep all
# but exp(-8) = 3e-4 of the Gaussian steps, but the limit also scales IM1's cost against the
# phi_max of a missed point: on random walkers 5 sigma linked better than 4 (IDF1 0.979 against
# 0.967 at sigma 1.5 px, 0.947 against 0.942 with 5% missed) and no worse than 6 to 10.
_SIGMAS = 5.0
# The unambiguous steps tell the motion's fastest speed (this quantile of their lengths) when that
# is below this share of their median bound: the bound then cut few of them short.
_CLEAR_QUANTILE = 0.99
_UNCUT_SHARE = 0.5
# Positions are rarely better than a tenth of a pixel; the limit never falls below this.
_MIN_SPEED = 1.0


@dataclass(frozen=True)
class MotionChoice:
    """The motion model chosen for a set of measurements.

    Attributes
    ----------
    individual_model : {"im2", "im1"}
        GOA individual model: "im2" smooth motion, "im1" nearest neighbour.
    speed_limit : float or None
        Speed limit, pixels/frame (GOA's d_max), about the drift: 5 sigma of the per-axis step
        noise (at least 1); None for no limit ("im2", or "im1" asked for with no step to measure).
    persistence : float
        Median cosine of the turning angle between consecutive unambiguous steps (1 straight
        on, 0 random walk, negative for jitter about a fixed position); NaN when there were
        none.
    triplets : int
        Number of unambiguous three-frame chains measured.
    drift : tuple of float
        Median step (x, y), pixels/frame, of random motion; (0, 0) otherwise.
    reason : str
        One line saying why, for the user.
    clear_speed : float or None
        99th percentile of the unambiguous steps' lengths, pixels/frame, where they are not held
        short by the spacing they must be under (then it is the motion's own fastest speed);
        None where they are, or where too few steps are unambiguous to tell.
    """

    individual_model: str
    speed_limit: float | None
    persistence: float
    triplets: int
    reason: str
    drift: tuple[float, float] = (0.0, 0.0)
    clear_speed: float | None = None


@dataclass(frozen=True)
class MotionFit:
    """How the points move and the tracker configuration fitted to it.

    Attributes
    ----------
    choice : MotionChoice
        What :func:`seedtrack.tracking.regime.choose_motion` measured.
    config : GOAConfig
        The configuration asked for, fitted to the motion (see
        :func:`seedtrack.tracking.regime.fit_motion`).
    drift : tuple of float
        Common step (x, y), pixels/frame, removed before tracking; (0, 0) for none.
    measured : str or None
        What a first pass measured of the motion (velocity persistence, turning, noise, drift)
        and the speed limit, when the model was measured on one (:mod:`seedtrack.tracking.adaptive`).
    """

    choice: MotionChoice
    config: GOAConfig
    drift: tuple[float, float]
    measured: str | None = None

    @property
    def summary(self) -> str:
        """One line for the user: what was measured and how it is tracked."""
        limit = "no speed limit" if self.config.d_max is None else f"speed limit {self.config.d_max:.2f} px/frame"
        if self.measured is not None:
            return f"motion: {self.choice.reason}; measured on a first pass: {self.measured}"
        if any(self.drift):
            limit += f" about the drift ({self.drift[0]:.2f}, {self.drift[1]:.2f}) px/frame"
        return f"motion: {self.choice.reason}; tracking with {self.config.individual.name.upper()}, {limit}"


class _Frame(NamedTuple):
    """One frame's positions with the search tree and spacing every link test needs."""

    points: np.ndarray
    tree: cKDTree
    # Distance from each point to the nearest other point of its frame, pixels.
    spacing: np.ndarray

    @classmethod
    def of(cls, points: np.ndarray, spacing: np.ndarray | None = None) -> "_Frame":
        """The frame of ``points``, its ``spacing`` measured unless given (from an earlier look)."""
        tree = cKDTree(points)
        return cls(points, tree, _query(tree, points, tree.indices, k=2)[0][:, 1] if spacing is None else spacing)

    def reflected(self, axes: tuple[bool, bool]) -> "_Frame":
        """The frame mirrored about the centre of its bounding box along the axes chosen (x, y);
        both axes make a half turn.

        A reflection keeps every distance, so the spacing is kept rather than measured again.
        A frame of under two points links nothing, turned or not, and is left as it is.
        """
        if self.points.shape[0] < 2:
            return self
        turned = np.where(axes, self.points.min(axis=0) + self.points.max(axis=0) - self.points, self.points)
        return _Frame(turned, cKDTree(turned), self.spacing)


def _query(tree: cKDTree, points: np.ndarray, order: np.ndarray, k: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """``tree.query(points, k)``, the points asked in ``order`` (their own tree's, near after
    near) and the answers put back: each answer is the same in any order, and 100,000 points a
    frame asked in random order missed the cache, a third of the time."""
    distance, index = tree.query(points[order], k=k)
    back = np.empty_like(order)
    back[order] = np.arange(order.size)
    return distance[back], index[back]


def _rank(tree: cKDTree) -> np.ndarray:
    """Each point's place in ``tree``'s order (near after near)."""
    rank = np.empty_like(tree.indices)
    rank[tree.indices] = np.arange(tree.indices.size)
    return rank


def _indexed_pairs(frames: Sequence[np.ndarray], spacings: Sequence[np.ndarray] | None = None) -> Iterator[tuple[_Frame, _Frame]]:
    """Consecutive frames with their search trees, two trees alive at a time: all of a clip's
    at once took 3 kB a frame (60 MB for 20,000 frames). ``spacings``: each frame's, when
    already measured."""
    indexed = map(_Frame.of, frames, spacings if spacings is not None else [None] * len(frames))
    a = next(indexed, None)
    for b in indexed:
        yield a, b
        a = b


def _links(a: _Frame, b: _Frame) -> tuple[np.ndarray, np.ndarray]:
    """Links between two consecutive frames that no plausible motion could make wrong.

    Parameters
    ----------
    a, b : _Frame
        Frames k and k + 1 (positions (x, y) in pixels, with their trees and spacings).

    Returns
    -------
    link : ndarray of int, shape (M_a,)
        For each point of ``a`` the index of its point in ``b``, or -1: the two are mutual
        nearest neighbours and closer than 0.4 times the nearest other point of either frame
        to each of them.
    reach : ndarray of float, shape (M_a,)
        The longest step that would have been kept for each linked point (0.4 times that
        spacing), pixels; NaN where unlinked. Needed to undo the bias against long steps.
    """
    link = np.full(a.points.shape[0], -1, dtype=np.int64)
    reach = np.full(a.points.shape[0], np.nan)
    if a.points.shape[0] < 2 or b.points.shape[0] < 2:
        return link, reach
    distance, forward = _query(b.tree, a.points, a.tree.indices)
    bound = _CLEAR_FRACTION * np.minimum(a.spacing, b.spacing[forward])
    near = np.flatnonzero(distance < bound)
    # Whether a point is the nearest of its nearest is asked only where it is near enough to be
    # kept: the links by chance are few, and their looks asked it of every point of the frame.
    # In the order of b's tree, as _query asks.
    asked = forward[near]
    order = np.argsort(_rank(b.tree)[asked], kind="stable")
    backward = np.empty_like(asked)
    backward[order] = a.tree.query(b.points[asked[order]])[1] if asked.size else asked
    keep = near[backward == near]
    link[keep] = forward[keep]
    reach[keep] = bound[keep]
    return link, reach


def unambiguous_triplets(frames: Sequence[np.ndarray], links: Sequence[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Consecutive step pairs of unambiguous links chained over three frames.

    Parameters
    ----------
    frames : sequence of ndarray, each (M_k, 2)
        Positions (x, y) per frame, pixels.
    links : sequence of ndarray
        The unambiguous links (:func:`_links`) of each pair of consecutive frames.

    Returns
    -------
    first, second : ndarray, shape (T, 2)
        Step from frame k to k + 1 and from k + 1 to k + 2 of each chain, pixels.
    """
    first, second = [], []
    for k in range(len(frames) - 2):
        start = np.flatnonzero(links[k] >= 0)
        middle = links[k][start]
        end = links[k + 1][middle]
        ok = end >= 0
        start, middle, end = start[ok], middle[ok], end[ok]
        first.append(frames[k + 1][middle] - frames[k][start])
        second.append(frames[k + 2][end] - frames[k + 1][middle])
    if not first:
        return np.empty((0, 2)), np.empty((0, 2))
    return np.concatenate(first), np.concatenate(second)


MOTIONS = ("auto", "smooth", "random")


def choose_motion(frames: Sequence[np.ndarray], motion: str = "auto") -> MotionChoice:
    """Decide from the measurements whether motion is smooth or a random walk.

    Parameters
    ----------
    frames : sequence of ndarray, each (M_k, 2)
        Measurement positions (x, y) per frame, pixels, consecutive frames.
    motion : {"auto", "smooth", "random"}
        "auto" decides; "smooth" and "random" say what the motion is, and "random" then only
        estimates the speed limit.

    Returns
    -------
    MotionChoice
        "im2" with no speed limit (the smooth-motion default) when the direction of motion
        persists or when too few links are unambiguous to tell; otherwise "im1" with the median
        step (the drift) and a speed limit about it of 5 sigma of the per-axis step noise (at
        least 1 pixel/frame), both estimated from the unambiguous steps (no limit if there are none).
    """
    if motion not in MOTIONS:
        raise ValueError(f"motion must be one of {', '.join(MOTIONS)}, got {motion!r}")
    if motion == "smooth":
        return MotionChoice("im2", None, float("nan"), 0, "smooth motion, as asked")
    frames = [np.asarray(f, dtype=float).reshape(-1, 2) for f in frames]
    links, reaches, spacings = [], [], []
    for a, b in _indexed_pairs(frames):
        link, reach = _links(a, b)
        links.append(link)
        reaches.append(reach)
        spacings.append(a.spacing)
    if links:
        # Kept for the looks at chance links below: measured again, they were half of each look.
        spacings.append(b.spacing)
    real = sum(int(np.count_nonzero(link >= 0)) for link in links)
    if motion == "random":
        if real == 0:
            return MotionChoice("im1", None, float("nan"), 0, "random motion, as asked; no unambiguous step to estimate a speed limit from")
        return _random(frames, links, reaches, float("nan"), 0, "random motion, as asked")
    first, second = unambiguous_triplets(frames, links)
    triplets = first.shape[0]
    clear = _clear_speed(frames, links, reaches)
    mean_points = float(np.mean([f.shape[0] for f in frames])) if frames else 0.0
    needed = max(_MIN_TRIPLETS, int(np.ceil(_MIN_TRIPLET_FRACTION * mean_points)))
    if triplets < needed:
        return MotionChoice(
            "im2", None, float("nan"), triplets,
            f"smooth-motion default: only {triplets} unambiguous 3-frame chains (need {needed}) to measure the motion",
            clear_speed=clear,
        )
    lengths = np.linalg.norm(first, axis=1) * np.linalg.norm(second, axis=1)
    moving = lengths > 0
    cosine = np.einsum("ij,ij->i", first[moving], second[moving]) / lengths[moving]
    persistence = float(np.median(cosine)) if cosine.size else 1.0
    rough = float(np.quantile(smooth_motion_cost(first, second, _IM2.w1, _IM2.w2), _ROUGH_QUANTILE))
    if persistence >= _PERSISTENT and rough <= _ROUGH_COST:
        return MotionChoice(
            "im2", None, persistence, triplets,
            f"smooth motion: steps keep their direction (median turning cosine {persistence:.2f} over {triplets} chains)",
            clear_speed=clear,
        )
    if persistence >= _PERSISTENT:
        why = (
            f"noisy motion: steps keep their direction (median turning cosine {persistence:.2f}) but vary too much "
            f"for the smooth-motion model ({_ROUGH_QUANTILE:.0%} of {triplets} chains cost up to {rough:.2f})"
        )
    elif persistence <= -_PERSISTENT:
        why = f"reversing motion: steps turn back (median turning cosine {persistence:.2f} over {triplets} chains)"
    else:
        why = f"random motion: steps turn at random (median turning cosine {persistence:.2f} over {triplets} chains)"
    # A half turn of frame k + 1 about its centre leaves no real link; what still links is chance.
    # A few points can be nearly their own half turn; the mirror images then tell, since a set is
    # rarely symmetric every way at once. Two points are their own half turn and, lying near an
    # axis, their own mirror image: below three points a frame on average, chance goes unmeasured,
    # and the minimum number of chains alone keeps the chance links of so sparse a scene from
    # counting.
    def chance(axes: tuple[bool, bool]) -> float:
        return sum(int(np.count_nonzero(_links(a, b.reflected(axes))[0] >= 0)) for a, b in _indexed_pairs(frames, spacings)) / real

    coincidence = chance((True, True)) if mean_points >= 3 else 0.0
    if coincidence > _MAX_COINCIDENCE:
        coincidence = min(coincidence, chance((True, False)), chance((False, True)))
    if coincidence > _MAX_COINCIDENCE:
        return MotionChoice(
            "im2", None, persistence, triplets,
            f"smooth-motion default: {why.split(':', 1)[0]} at first sight, but {coincidence:.0%} as many unambiguous "
            "links would arise by chance; the motion is too fast or crowded to tell",
        )
    return _random(frames, links, reaches, persistence, triplets, why)


def _clear_speed(frames: Sequence[np.ndarray], links: Sequence[np.ndarray], reaches: Sequence[np.ndarray]) -> float | None:
    """99th percentile of the unambiguous steps' lengths (pixels/frame) when it lies below half
    their median bound (so that the bound did not cut the steps short: the motion is slow for
    its spacing), else None; None also below _MIN_TRIPLETS steps."""
    lengths = [np.hypot(*(b[link[link >= 0]] - a[link >= 0]).T) for a, b, link in zip(frames[:-1], frames[1:], links)]
    if sum(x.size for x in lengths) < _MIN_TRIPLETS:
        return None
    fastest = float(np.quantile(np.concatenate(lengths), _CLEAR_QUANTILE))
    bound = float(np.median(np.concatenate([r[r >= 0] for r in reaches])))
    return fastest if fastest < _UNCUT_SHARE * bound else None


def _random(
    frames: Sequence[np.ndarray], links: Sequence[np.ndarray], reaches: Sequence[np.ndarray], persistence: float, triplets: int, why: str
) -> MotionChoice:
    steps = np.concatenate([b[link[link >= 0]] - a[link >= 0] for a, b, link in zip(frames[:-1], frames[1:], links)])
    reach = np.concatenate([r[r >= 0] for r in reaches])
    drift = np.median(steps, axis=0)
    lengths = np.linalg.norm(steps - drift, axis=1)
    # The steps are freed and the reach moved in place before the fit: on a million links 23 MB.
    del steps
    reach += np.linalg.norm(drift)
    sigma = step_sigma(lengths, reach)
    return MotionChoice(
        "im1", max(_MIN_SPEED, _SIGMAS * sigma), persistence, triplets,
        f"{why}, step sigma {sigma:.2f} px/axis, drift {np.linalg.norm(drift):.2f} px/frame",
        (float(drift[0]), float(drift[1])),
    )


def fit_motion(config: GOAConfig, choice: MotionChoice, keep_model: bool = False) -> tuple[GOAConfig, tuple[float, float]]:
    """The tracker configuration for the motion chosen, keeping what the user set.

    Random motion takes IM1 on squared distances (unless ``keep_model``) and nearest-neighbour
    first links, and the drift is to be removed from the positions before tracking
    (:func:`track_without_drift`), so that a track bridging a gap of g frames is looked for g
    drift steps downstream. Without a speed limit in ``config`` it also takes the estimated one,
    5 sigma of the noise about the drift, unless that is not above ``config.d_min``; a limit in
    ``config`` bounds the steps about the drift too. Smooth motion leaves ``config`` as is.

    Returns
    -------
    config : GOAConfig
    drift : tuple of float
        Median step (x, y) to remove, pixels/frame; (0, 0) for none.
    """
    if choice.individual_model != "im1":
        return config, (0.0, 0.0)
    changes: dict = {"initialisation": "im1"}
    if not keep_model:
        changes["individual"] = IndividualModel("im1", power=2)
    # An estimate at or below the user's smallest speed (d_min) would leave no speed to track:
    # what the user set wins, and the steps go unbounded.
    if config.d_max is None and choice.speed_limit is not None and choice.speed_limit > config.d_min:
        changes["d_max"] = choice.speed_limit
    return replace(config, **changes), choice.drift


def track_without_drift(
    frames: Sequence[np.ndarray], drift: tuple[float, float], track: Callable[[list[np.ndarray]], Tracks]
) -> Tracks:
    """Run ``track`` on the positions seen from a frame moving with ``drift`` (pixels/frame),
    and put the drift back into the tracks it returns (interpolated positions included: a
    straight line stays straight).

    ``frames[k]`` is moved by ``-k * drift``; ``track`` must return tracks whose column k is
    ``frames[k]``.
    """
    shift = np.asarray(drift, dtype=float)
    if not shift.any():
        return track(list(frames))
    tracks = track([np.asarray(f, dtype=float).reshape(-1, 2) - k * shift for k, f in enumerate(frames)])
    return tracks.shifted(drift)


def step_sigma(lengths: np.ndarray, reach: np.ndarray) -> float:
    """Per-axis standard deviation of 2D Gaussian steps seen only when shorter than a bound.

    Unambiguous links keep only steps shorter than a fraction of the local spacing, so long
    steps are under-represented; this is the maximum-likelihood sigma of a Rayleigh
    distribution truncated at each step's own bound.

    Parameters
    ----------
    lengths : ndarray, shape (N,)
        Step lengths, pixels.
    reach : ndarray, shape (N,)
        The bound each step was kept under, pixels (each ``lengths[i] < reach[i]``).

    Returns
    -------
    float
        sigma, pixels per axis.
    """
    squared, bound = lengths**2, np.maximum(reach, lengths) ** 2

    def negative_log_likelihood(log_sigma: float) -> float:
        variance = np.exp(2.0 * log_sigma)
        # In place, in the same operations and order as -expm1(-bound / 2v) and
        # log(v) + squared / 2v + log(max(kept, 1e-300)): two arrays rather than five.
        kept = np.divide(bound, -(2.0 * variance))
        np.expm1(kept, out=kept)
        np.negative(kept, out=kept)
        np.maximum(kept, 1e-300, out=kept)
        np.log(kept, out=kept)
        terms = np.divide(squared, 2.0 * variance)
        terms += np.log(variance)
        terms += kept
        return float(np.sum(terms))

    # Imported when used (random walks only): scipy.optimize is a seventh of run's imports.
    from scipy.optimize import minimize_scalar

    rms = float(np.sqrt(np.mean(squared) / 2.0)) or 1e-6
    high = float(np.sqrt(bound.max()))
    best = minimize_scalar(negative_log_likelihood, bounds=(np.log(rms / 2.0), np.log(max(high, rms) * 10.0)), method="bounded")
    return float(np.exp(best.x))
