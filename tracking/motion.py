"""Individual motion models (IM) and combined motion models (CM) of Veenman et al. (2001).

An individual model scores how well one candidate measurement continues one track head; a
combined model turns those scores into the edge weights that one frame's assignment sums.
Costs are computed for a whole frame's candidate pairs at once, as flat arrays.
"""

from __future__ import annotations

import abc
import functools
import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

# The reference code nudges zero-length vectors by 1e-3 px before normalising; adding it to
# the speeds does the same job without a sign choice and keeps the cost defined.
SPEED_EPSILON = 1e-3


@dataclass(frozen=True)
class Candidates:
    """Candidate (head, measurement) pairs of one frame step, as flat arrays.

    Attributes
    ----------
    head : ndarray of int, shape (P,)
        Track head index.
    measurement : ndarray of int, shape (P,)
        Index of the measurement in the next frame.
    displacement : ndarray of float, shape (P, 2)
        Measurement position minus the head's newest true measurement, pixels.
    gap : ndarray of int, shape (P,)
        Frames between the head's newest true measurement and the candidate (1 when the head
        holds no slaves).
    previous_velocity : ndarray of float, shape (P, 2)
        The head's velocity from its two newest true measurements, pixels/frame; NaN where the
        head has fewer than two.
    previous_span : ndarray of int, shape (P,), optional
        Frames between those two measurements (the previous velocity is gap-normalised over
        them); all 1 when not given.
    history : ndarray of float, shape (P, 5), optional
        The head's own history of velocity changes
        (:func:`seedtrack.tracking.mixture.add_chain_moments`); None when not kept.
    """

    head: np.ndarray
    measurement: np.ndarray
    displacement: np.ndarray
    gap: np.ndarray
    previous_velocity: np.ndarray
    previous_span: np.ndarray | None = None
    history: np.ndarray | None = None

    @functools.cached_property
    def velocity(self) -> np.ndarray:
        """Candidate velocity, gap-normalised, pixels/frame, shape (P, 2); read-only, worked
        out once (a step asked for it five times)."""
        velocity = self.displacement / self.gap[:, None]
        velocity.flags.writeable = False
        return velocity

    @property
    def has_history(self) -> np.ndarray:
        """Boolean (P,): the head has a velocity, so order-2 models apply."""
        return ~np.isnan(self.previous_velocity[:, 0])

    def subset(self, keep: np.ndarray) -> "Candidates":
        """The pairs selected by a boolean or index array."""
        # Indices once, and rows taken rather than fancy-indexed: a step made four subsets.
        keep = np.flatnonzero(keep) if keep.dtype == bool else keep
        subset = Candidates(
            head=self.head[keep],
            measurement=self.measurement[keep],
            displacement=self.displacement.take(keep, axis=0),
            gap=self.gap[keep],
            previous_velocity=self.previous_velocity.take(keep, axis=0),
            previous_span=None if self.previous_span is None else self.previous_span[keep],
            history=None if self.history is None else self.history[keep],
        )
        if "velocity" in self.__dict__:
            velocity = self.velocity.take(keep, axis=0)
            velocity.flags.writeable = False
            subset.__dict__["velocity"] = velocity
        return subset


# A speed at a limit stays within it whatever the last bits of the positions' differences: points
# moving at exactly the limit (a generator's largest speed) lost their links to rounding.
_ROUNDING = 1e-9


@dataclass(frozen=True)
class SpeedLimits:
    """The speed gate that every GOA link passes: d_min <= gap-normalised speed <= d_max.

    Also the scale of the IM1 fallback (heads without a velocity, and the first links): the
    speed that costs phi_max, which is d_max, or without one the fastest candidate of the
    step (at least 1 pixel/frame).

    Attributes
    ----------
    d_min : float
        Smallest speed, pixels/frame.
    d_max : float or None
        Largest speed, pixels/frame; None for no limit.

    Examples
    --------
    >>> SpeedLimits(d_max=5.0).admits(np.array([[3.0, 4.0], [3.0, 4.1]]))
    array([ True, False])
    """

    d_min: float = 0.0
    d_max: float | None = None

    def admits(self, velocity: np.ndarray) -> np.ndarray:
        """Boolean (P,): the velocities (P, 2), pixels/frame, whose speed is within the limits."""
        return self._admits_speed(_speeds(velocity))

    def _admits_speed(self, speed: np.ndarray) -> np.ndarray:
        ok = speed >= self.d_min * (1 - _ROUNDING)
        if self.d_max is not None:
            ok &= speed <= self.d_max * (1 + _ROUNDING)
        return ok

    def reach(self, radius: np.ndarray) -> np.ndarray:
        """A model's gate radius (pixels/frame per head) capped at d_max."""
        return radius if self.d_max is None else np.minimum(radius, self.d_max)

    def scale(self, velocity: np.ndarray) -> float:
        """Speed that costs phi_max under the IM1 fallback, pixels/frame: d_max, or the fastest
        of the velocities (P, 2) given, at least 1."""
        return self._scale_of_speeds(None if self.d_max is not None else _speeds(velocity))

    def _scale_of_speeds(self, speed: np.ndarray | None) -> float:
        if self.d_max is not None:
            return float(self.d_max)
        return max(float(speed.max(initial=0.0)), 1.0)


def _speeds(velocity: np.ndarray) -> np.ndarray:
    """Speed of each velocity (P, 2), pixels/frame."""
    return np.hypot(*np.asarray(velocity, dtype=float).reshape(-1, 2).T)


def nearest_neighbour_cost(candidates: Candidates, scale: float) -> np.ndarray:
    """IM1: gap-normalised distance divided by ``scale``.

    Parameters
    ----------
    candidates : Candidates
        The pairs to score.
    scale : float
        Distance that maps to cost 1, pixels/frame (d_max in the paper's code).

    Returns
    -------
    ndarray of float, shape (P,)
    """
    return np.hypot(*candidates.velocity.T) / scale


def smooth_motion_cost(previous_velocity: np.ndarray, velocity: np.ndarray, w1: float, w2: float) -> np.ndarray:
    """IM2, Sethi and Jain's smooth motion: change of direction and of speed.

    ``w1 * (1 - cos angle) + w2 * (1 - 2 sqrt(s0 s1) / (s0 + s1))``; the direction term lies
    in [0, 2] and the speed term in [0, 1], so the cost lies in [0, 2 w1 + w2]. A zero-length
    vector has no direction, so it contributes no direction term.

    Parameters
    ----------
    previous_velocity, velocity : ndarray of float, shape (P, 2)
        Velocities before and after the head, pixels/frame.
    w1, w2 : float
        Weights of the direction and speed terms.
    """
    speed0 = np.hypot(*previous_velocity.T)
    speed1 = np.hypot(*velocity.T)
    dot = np.einsum("ij,ij->i", previous_velocity, velocity)
    both_move = (speed0 > 0) & (speed1 > 0)
    cosine = np.divide(dot, speed0 * speed1, out=np.ones_like(dot), where=both_move)
    direction = 1.0 - np.clip(cosine, -1.0, 1.0)
    speed0 = speed0 + SPEED_EPSILON
    speed1 = speed1 + SPEED_EPSILON
    speed = 1.0 - 2.0 * np.sqrt(speed0 * speed1) / (speed0 + speed1)
    return w1 * direction + w2 * speed


def smooth_motion_speed_ratio_limit(phi_max: float, w2: float) -> float:
    """Largest speed ratio s1/s0 whose IM2 speed term alone stays within ``phi_max``.

    Used to gate candidates of heads with a velocity: a measurement farther than this ratio
    times the head's speed cannot pass the phi_max test, whatever its direction.

    Returns
    -------
    float
        The ratio, or ``inf`` when phi_max does not bound the speed term.
    """
    bound = phi_max / w2 if w2 > 0 else math.inf
    if bound >= 1.0:
        return math.inf
    # The speed term equals (1 - t)^2 / (1 + t^2) with t = sqrt(ratio); solve it for t.
    keep = 1.0 - bound
    t_max = (1.0 + math.sqrt(1.0 - keep * keep)) / keep
    return t_max * t_max


def proximal_uniformity_cost(candidates: Candidates) -> np.ndarray:
    """IM3, Rangarajan and Shah's proximal uniformity, normalised over the frame's pairs.

    The two terms (change of displacement, and displacement) are each divided by their sum over
    all the candidate pairs of the frame step, so the costs of one frame sum to 2.

    Returns
    -------
    ndarray of float, shape (P,)
        Cost per pair; pairs of heads with no velocity score on the displacement term alone.
    """
    displacement = candidates.velocity
    previous = np.where(candidates.has_history[:, None], candidates.previous_velocity, displacement)
    change = np.hypot(*(displacement - previous).T)
    distance = np.hypot(*displacement.T)
    change_total = change.sum()
    distance_total = distance.sum()
    cost = np.zeros_like(distance)
    if change_total > 0:
        cost += change / change_total
    if distance_total > 0:
        cost += distance / distance_total
    return cost


class _Registered(abc.ABC):
    """Models built by name: ``Base(name, **parameters)`` makes the registered model of that name.

    Each concrete model is a frozen dataclass whose first field is its ``name``; subclassing a
    base with ``key="..."`` registers it, so a new model needs no change to the code that uses
    models (``GOAConfig``, the trackers, the command's ``--individual-model`` choices).
    """

    _registry: ClassVar[dict[str, type]]
    _kind: ClassVar[str]
    _default: ClassVar[str]
    key: ClassVar[str]

    def __init_subclass__(cls, key: str | None = None, **kwargs) -> None:
        super().__init_subclass__(**kwargs)
        if key is None:  # a base: its own registry
            cls._registry = {}
        else:
            cls.key = key
            cls._registry[key] = cls

    def __new__(cls, *args, **kwargs):
        if "key" not in cls.__dict__:  # called on a base: build the model named
            name = args[0] if args else kwargs.get("name", cls._default)
            if name not in cls._registry:
                choices = ", ".join(sorted(cls._registry)[:-1]) + " or " + sorted(cls._registry)[-1]
                raise ValueError(f"unknown {cls._kind} {name!r}; choose {choices}")
            cls = cls._registry[name]
        return super().__new__(cls)

    def _check_name(self) -> None:
        if self.name != self.key:
            raise ValueError(f"{type(self).__name__} is {self.key!r}, not {self.name!r}")


class IndividualModel(_Registered):
    """An individual motion model: how well one candidate measurement continues one track head.

    ``IndividualModel("im1", power=2)`` builds the model registered as "im1"
    (:data:`INDIVIDUAL_MODELS`); the default is "im2".

    Examples
    --------
    >>> IndividualModel("im1", power=2)
    NearestNeighbour(name='im1', power=2)
    >>> IndividualModel().order
    2
    """

    _kind = "individual model"
    _default = "im2"
    name: str
    # 1 for models that need only the head position, 2 for those that need a velocity.
    order: ClassVar[int] = 2

    @abc.abstractmethod
    def cost(self, candidates: Candidates, phi_max: float, d_max: float) -> np.ndarray:
        """Individual cost of every candidate pair.

        Heads without a velocity cannot be scored by an order-2 model; they fall back to IM1
        scaled so that a move of d_max costs phi_max (the reference code's IM1 gate).

        Parameters
        ----------
        candidates : Candidates
        phi_max : float
            Largest allowed cost; used to scale the IM1 fallback.
        d_max : float
            Speed that maps to cost phi_max under IM1, pixels/frame (:meth:`SpeedLimits.scale`).
        """

    def gate_radius(self, speed: np.ndarray, has_history: np.ndarray, phi_max: float) -> np.ndarray:
        """Per-head speed beyond which no candidate can pass the phi_max test, pixels/frame.

        Parameters
        ----------
        speed : ndarray of float, shape (m,)
            Each head's previous speed, pixels/frame (ignored where ``has_history`` is False).
        has_history : ndarray of bool, shape (m,)
        phi_max : float

        Returns
        -------
        ndarray of float, shape (m,)
            ``inf`` where the model does not bound the speed.
        """
        return np.full(speed.shape, np.inf)


@dataclass(frozen=True)
class NearestNeighbour(IndividualModel, key="im1"):
    """IM1, nearest neighbour: the gap-normalised distance against the speed that costs phi_max.

    Attributes
    ----------
    power : {1, 2}
        Exponent of the distance: 1 as in the paper, 2 for random walks, whose Gaussian steps
        make the sum of squared distances the negative log-likelihood of an assignment; across
        a gap of g frames the squared distance is divided by g (the variance grows with g), not
        by g squared.
    """

    name: str = "im1"
    power: int = 1
    order: ClassVar[int] = 1

    def __post_init__(self) -> None:
        self._check_name()
        if self.power not in (1, 2):
            raise ValueError(f"IM1 power must be 1 or 2, got {self.power}")

    def cost(self, candidates: Candidates, phi_max: float, d_max: float) -> np.ndarray:
        if self.power == 1:
            return phi_max * nearest_neighbour_cost(candidates, d_max)
        return phi_max * nearest_neighbour_cost(candidates, d_max) ** 2 * candidates.gap


@dataclass(frozen=True)
class SmoothMotion(IndividualModel, key="im2"):
    """IM2, Sethi and Jain's smooth motion (:func:`smooth_motion_cost`).

    Attributes
    ----------
    w1, w2 : float
        Weights of direction and speed (the paper's rotating-dish values 0.1 and 0.9).
    """

    name: str = "im2"
    w1: float = 0.1
    w2: float = 0.9

    def __post_init__(self) -> None:
        self._check_name()
        if self.w1 < 0 or self.w2 < 0 or self.w1 + self.w2 == 0:
            raise ValueError("IM2 weights must be non-negative and not both zero")

    def cost(self, candidates: Candidates, phi_max: float, d_max: float) -> np.ndarray:
        cost = phi_max * nearest_neighbour_cost(candidates, d_max)
        history = candidates.has_history
        if history.any():
            cost[history] = smooth_motion_cost(candidates.previous_velocity[history], candidates.velocity[history], self.w1, self.w2)
        return cost

    def gate_radius(self, speed: np.ndarray, has_history: np.ndarray, phi_max: float) -> np.ndarray:
        radius = np.full(speed.shape, np.inf)
        ratio = smooth_motion_speed_ratio_limit(phi_max, self.w2)
        if math.isfinite(ratio):
            bounded = ratio * (speed + SPEED_EPSILON)
            radius[has_history] = bounded[has_history] * (1 + 1e-9) + 1e-9
        return radius


@dataclass(frozen=True)
class ProximalUniformity(IndividualModel, key="im3"):
    """IM3, Rangarajan and Shah's proximal uniformity (:func:`proximal_uniformity_cost`)."""

    name: str = "im3"

    def __post_init__(self) -> None:
        self._check_name()

    def cost(self, candidates: Candidates, phi_max: float, d_max: float) -> np.ndarray:
        return proximal_uniformity_cost(candidates)


class CombinedModel(_Registered):
    """A combined motion model: how one frame's individual costs become assignment weights.

    ``CombinedModel("cm2", w1=0.5, w2=0.5)`` builds the model registered as "cm2"
    (:data:`COMBINED_MODELS`); the default is "cm1".

    Examples
    --------
    >>> CombinedModel("cm1", z=2.0).weights(np.array([0.1, 0.2]), np.array([0, 1]), np.array([0, 1]), 0.3)
    array([0.01, 0.04])
    """

    _kind = "combined model"
    _default = "cm1"
    name: str

    def unmatched_weight(self, phi_max: float) -> float:
        """Weight of a slave (missed point) or a false track (spurious measurement)."""
        return phi_max

    @abc.abstractmethod
    def weights(self, cost: np.ndarray, head: np.ndarray, measurement: np.ndarray, phi_max: float) -> np.ndarray:
        """Assignment weight of each pair that survived pruning.

        Parameters
        ----------
        cost : ndarray of float, shape (P,)
            Individual costs, all within phi_max.
        head, measurement : ndarray of int, shape (P,)
            The pairs' head and measurement indices (CM2 averages over each one's other pairs).
        phi_max : float
            The individual cost of a slave and of a false track: every head's and every
            measurement's option besides its pairs.
        """


@dataclass(frozen=True)
class GeneralisedMean(CombinedModel, key="cm1"):
    """CM1, the generalised mean: weights ``c**z``; larger z penalises large deviations more."""

    name: str = "cm1"
    z: float = 1.0

    def __post_init__(self) -> None:
        self._check_name()
        if self.z <= 0:
            raise ValueError(f"CM1 exponent z must be positive, got {self.z}")

    def unmatched_weight(self, phi_max: float) -> float:
        return phi_max**self.z

    def weights(self, cost: np.ndarray, head: np.ndarray, measurement: np.ndarray, phi_max: float) -> np.ndarray:
        return cost**self.z


@dataclass(frozen=True)
class ConditionedDeviation(CombinedModel, key="cm2"):
    """CM2 as the paper writes it, deviation conditioned on alternatives and competition:
    ``c - w1 * mean alternatives - w2 * mean competitors``, over the gated pairs of the head and
    of the measurement. Linear in the costs, it leaves the optimum of an assignment that matches
    every head and measurement where CM1's is (see the README's derivation); "cm2-margin" can
    move it."""

    name: str = "cm2"
    w1: float = 0.0
    w2: float = 0.0

    def __post_init__(self) -> None:
        self._check_name()
        if self.w1 < 0 or self.w2 < 0:
            raise ValueError("CM2 weights must be non-negative")

    def weights(self, cost: np.ndarray, head: np.ndarray, measurement: np.ndarray, phi_max: float) -> np.ndarray:
        return cost - self.w1 * _mean_of_others(cost, head) - self.w2 * _mean_of_others(cost, measurement)


@dataclass(frozen=True)
class MarginDeviation(ConditionedDeviation, key="cm2-margin"):
    """CM2 against the best alternative and the best competitor: a pair is cheaper by how far it
    beats them, ``c - w1 * max(0, a - c) - w2 * max(0, b - c)``.

    ``a`` is the cheapest other option of the pair's head (its other gated measurements, or its
    slave at phi_max), ``b`` the cheapest other taker of the pair's measurement (its other gated
    heads, or a false track at phi_max). Only the head's (measurement's) favourite gains, by its
    margin, so an unambiguous link is preferred to an equally cheap contested one: the paper's
    intent for CM2 (own cost low, alternatives and competitors poor), but through a minimum, which
    is not linear in the costs and can change the optimum where the mean form cannot. With w1 = w2
    = 0 it is CM1 (z = 1).

    Examples
    --------
    Head 0 prefers measurement 0 by 0.03 over its other option, head 1 its only pair by 0.02
    over its slave; measurement 0 has no other taker (0.08 below a false track), measurement 1
    prefers head 0 by 0.03:

    >>> cost, head, measurement = np.array([0.02, 0.05, 0.08]), np.array([0, 0, 1]), np.array([0, 1, 1])
    >>> MarginDeviation(w1=0.5, w2=0.5).weights(cost, head, measurement, 0.1).round(3)
    array([-0.035,  0.035,  0.07 ])
    """

    name: str = "cm2-margin"

    def weights(self, cost: np.ndarray, head: np.ndarray, measurement: np.ndarray, phi_max: float) -> np.ndarray:
        head_margin = np.maximum(_best_other(cost, head, phi_max) - cost, 0.0)
        measurement_margin = np.maximum(_best_other(cost, measurement, phi_max) - cost, 0.0)
        return cost - self.w1 * head_margin - self.w2 * measurement_margin


# Every model by the name the options and configurations use.
INDIVIDUAL_MODELS: dict[str, type] = IndividualModel._registry
COMBINED_MODELS: dict[str, type] = CombinedModel._registry


def _mean_of_others(cost: np.ndarray, group: np.ndarray) -> np.ndarray:
    """For each pair, the mean cost of the other pairs in its group (0 when it is alone)."""
    if cost.size == 0:
        return cost
    _, inverse, counts = np.unique(group, return_inverse=True, return_counts=True)
    totals = np.bincount(inverse, weights=cost)
    others = counts[inverse] - 1
    return np.divide(totals[inverse] - cost, others, out=np.zeros_like(cost), where=others > 0)


def _best_other(cost: np.ndarray, group: np.ndarray, ceiling: float) -> np.ndarray:
    """For each pair, the cheapest other pair of its group, or ``ceiling`` when that is cheaper
    or there is none (of two equally cheap pairs each is the other's best)."""
    if cost.size == 0:
        return cost
    order = np.lexsort((cost, group))
    sorted_group = group[order]
    first = np.ones(order.size, bool)
    first[1:] = sorted_group[1:] != sorted_group[:-1]
    start = np.flatnonzero(first)
    size = np.diff(np.append(start, order.size))
    best = cost[order[start]]
    second = np.where(size > 1, cost[order[np.minimum(start + 1, order.size - 1)]], np.inf)
    group_of = np.repeat(np.arange(start.size), size)
    other = np.where(first, second[group_of], best[group_of])
    result = np.empty_like(cost)
    result[order] = np.minimum(other, ceiling)
    return result


def acceptable_links(
    model: IndividualModel, candidates: Candidates, phi_max: float, limits: SpeedLimits
) -> tuple[Candidates, np.ndarray]:
    """The candidate links that pass the speed gate and cost at most phi_max, with their cost.

    Parameters
    ----------
    model : IndividualModel
    candidates : Candidates
    phi_max : float
        Largest individual cost of a link.
    limits : SpeedLimits
        The speed gate, and the scale of the IM1 fallback (taken over the pairs it admits).

    Returns
    -------
    Candidates, ndarray of float (P',)
    """
    # One speed per pair for both the gate and the scale.
    speed = _speeds(candidates.velocity)
    admitted = limits._admits_speed(speed)
    if not admitted.all():
        candidates, speed = candidates.subset(admitted), speed[admitted]
    cost = model.cost(candidates, phi_max, limits._scale_of_speeds(speed))
    keep = cost <= phi_max
    return (candidates, cost) if keep.all() else (candidates.subset(keep), cost[keep])


# The default link cost, the model measured on a first pass, is registered with the others
# (persistence.py builds on this module, so it is imported last).
from . import persistence  # noqa: E402,F401
