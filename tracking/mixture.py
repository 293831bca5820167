"""Motion states per track: a mixture of persistences and noises fitted to a scene, and each
track's own state judged from its own history.

One scene can hold objects that move differently: some smooth, some walking at random, some
swinging back and forth. A single :class:`~seedtrack.tracking.persistence.MotionStatistics`
fitted to all of them is a compromise that fits none (or fits the commonest and calls the
others' changes sudden). Here a pass's three-frame chains are fitted by expectation
maximisation to a mixture of two or three motion states, each a persistence (-1 reversing to 1
smooth) with its own noise, plus a broad component that takes the pass's wrong links; the
number of states is the one the Bayesian information criterion prefers. The states are kept
only where the data show them to be properties of tracks: a track's chain one, two and three
links on is in the same state more often than chance (``STICKY``), no state is as wide as a
good part of the spacing (``WIDEST``), and some two keep velocity differently (``DISTINCT``).
Otherwise, as when the scene is of one kind, there is one state and the model is the scene-wide
one exactly.

Each track head keeps the moments of its own velocity changes (:func:`add_chain_moments`, older
ones fading by ``MEMORY`` a link), and its chance of being in each state follows from them by
Bayes' rule, starting from the scene's share of that state: a track with no history is
predicted by the scene's mixture, and one frame of evidence moves it only as far as that frame's
likelihoods do. A link's cost is the negative log of the mixture of the states' predictions
weighted so, in the same units as :class:`~seedtrack.tracking.persistence.PersistentModel`'s.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.special import logsumexp

from .motion import Candidates
from .persistence import _MIN_NOISE, Chains, MotionStatistics, PersistentModel, _turned

# Share of a head's older velocity changes kept each time it adds one: its state is judged on
# about the last 1 / (1 - MEMORY) links, so an object that changes how it moves (or a wrong
# link in its history) is not held to its old state for good.
MEMORY = 0.9
# At most this many states; each is a persistence, a noise and its growth with the speed.
MOST_STATES = 3
# States holding less than this share of the chains are not kept (a few chains fit anything).
LEAST_SHARE = 0.05
# States are kept only where tracks keep them: a track's chain a few links on is in the state of
# this one at least this much more often than chance would have it (Cohen's kappa, the least over
# 1 to ``LAGS`` links on; 0 for states that come and go along a track, 1 for each track in a state
# of its own). One link on is not enough: where a pass links wrongly in a crowd, its wrong links
# come in runs of two or three and look like a state a link on, not three on. Chosen on tuning
# seeds (bench_mixed.py's mixed scenes 0-4, the swarm and the dish 80 30% missed 0-9, the other
# unseen and held-out scenes 0-4), BIC's choice of states: mixed scenes 0.26 to 0.64, every
# other 0.15 at most (swarm 0.11, run-and-tumble 0.03, dishes 0.15) but one dish 30% missed at
# 0.38 whose wide state the spacing test below removes (and two more of seeds 10-49: DISTINCT).
STICKY = 0.2
LAGS = 3
# States are kept only where some two keep velocity differently: their persistences at least
# this far apart. States of one persistence and different noise are what wrong links that chain
# make of one kind of motion (dishes 30% missed, tuning seeds 0-49: a state of persistence 0.72
# to 0.78 and 9 to 18 px of noise beside the true one at 0.99 and under 1 px, kappa 0.24 and
# 0.28, in 2 clips, which lost strict merit 0.36 -> 0.01 and 0.44 -> 0.03). Chosen on those
# tuning seeds with bench_mixed.py's mixed scenes 0-4: mixed 0.68 to 0.99 apart but one clip at
# 0.19 (states 1.00 and 0.81; it is left scene-wide), the dishes 0.22 and 0.27.
DISTINCT = 0.5
# Largest noise of a state, per axis, in units of the mean spacing of the points (one over the
# square root of their density); chosen on tuning seeds 0-1 (see fit_states).
WIDEST = 0.35
# Chains the fit uses at most, in runs of LAGS + 1 evenly spaced over all of them: EM's cost grows
# with the chains (100,000 chains of two states: 1.8 s of CPU on all of them, 0.26 s on 10,000),
# and a few thousand pin three states' persistence and noise to a few hundredths.
MOST_CHAINS = 10_000
_ITERATIONS = 60
# The broad component of wrong links: a velocity drawn from this many times the spread of all
# velocities (per axis), whatever the velocity before it.
_WRONG_SPREAD = 2.0


def add_chain_moments(moments: np.ndarray, rows: np.ndarray, before: np.ndarray, after: np.ndarray, consecutive: np.ndarray) -> None:
    """Add one velocity change per head to its moments, in place: ``moments[rows]`` (H, 5) hold
    the count of changes and the sums of |b|^2, b.a, b x a and |a|^2 over the head's pairs of
    consecutive velocities (b before a, pixels/frame), each older pair weighed ``MEMORY`` times
    less per pair added since. Heads whose ``before`` is NaN or whose pair is not
    ``consecutive`` (spans of one frame each) are left as they are.

    Example
    -------
    >>> m = np.zeros((1, 5))
    >>> add_chain_moments(m, np.array([0]), np.array([[1.0, 0.0]]), np.array([[1.0, 1.0]]), np.array([True]))
    >>> m.tolist()
    [[1.0, 1.0, 1.0, 1.0, 2.0]]
    """
    use = consecutive & ~np.isnan(before[:, 0])
    if not use.any():
        return
    b, a, rows = before[use], after[use], rows[use]
    moments[rows] *= MEMORY
    moments[rows, 0] += 1.0
    moments[rows, 1] += np.einsum("ij,ij->i", b, b)
    moments[rows, 2] += np.einsum("ij,ij->i", b, a)
    moments[rows, 3] += b[:, 0] * a[:, 1] - b[:, 1] * a[:, 0]
    moments[rows, 4] += np.einsum("ij,ij->i", a, a)


def fit_states(chains: Chains, scene: MotionStatistics) -> tuple[tuple[MotionStatistics, ...], tuple[float, ...]]:
    """Motion states of a scene and the share of chains in each, fitted to ``chains`` by EM.

    Each state is ``scene`` with its own persistence, turn, noise and relative noise; the number
    of states (1 to ``MOST_STATES``) is the one of least BIC, kept only where tracks keep their
    states (``STICKY`` over 1 to ``LAGS`` links on), no state is wider than ``WIDEST`` of the
    spacing and some two persistences are ``DISTINCT`` apart. One state is ``scene`` itself.

    Parameters
    ----------
    chains : Chains
        Three-frame chains of a first pass (:func:`~seedtrack.tracking.persistence.measured_chains`).
    scene : MotionStatistics
        The scene-wide fit to the same chains (:func:`~seedtrack.tracking.persistence.fit_chains`).

    Example
    -------
    >>> rng = np.random.default_rng(0)
    >>> smooth = rng.normal(0, 3, (200, 1, 2)) + rng.normal(0, 0.1, (200, 8, 2))
    >>> paths = np.concatenate((smooth, rng.normal(0, 2, (200, 8, 2))))  # tracks x frames x velocity
    >>> from seedtrack.tracking.persistence import fit_chains
    >>> chains = Chains(paths[:, :-1].reshape(-1, 2), paths[:, 1:].reshape(-1, 2), np.zeros(2), 2.5)
    >>> states, shares = fit_states(chains, fit_chains(chains))
    >>> sorted(round(s.persistence, 1) for s in states), [round(w, 1) for w in shares]
    ([0.0, 1.0], [0.5, 0.5])
    """
    # Evenly spaced runs of LAGS + 1 chains: a chain continues the one before it on the same track
    # where its first velocity is that one's second (the same two points, the same bits).
    total = chains.before.shape[0]
    starts = np.arange(0, total, max((LAGS + 1) * total // MOST_CHAINS, 1))
    index = np.unique(np.minimum(starts[:, None] + np.arange(LAGS + 1), total - 1))
    before, after = chains.before[index], chains.after[index]
    follows = np.zeros(index.size, bool)
    follows[1:] = (index[1:] == index[:-1] + 1) & (after[:-1] == before[1:]).all(axis=1)
    floor = max(_MIN_NOISE, chains.resolution / np.sqrt(2.0), np.sqrt(6.0) * chains.localisation)
    speed2 = np.einsum("ij,ij->i", before, before)
    wrong = _WRONG_SPREAD**2 * max(chains.spread, floor) ** 2
    wrong_log = -np.einsum("ij,ij->i", after, after) / (2.0 * wrong) - np.log(2.0 * np.pi * wrong)
    # First guesses of who is in which state: chains ranked by how well the scene's fit explains
    # them (states of one persistence and different noise), and by how much of its velocity
    # each keeps (states of different persistence: one guess alone ended between them, fitting
    # smooth, random and reversing chains with persistence 0.7, -0.1 and -0.7).
    change = after - scene.persistence * _turned(before, scene.turn)
    ranks = [_rank(np.einsum("ij,ij->i", change, change) / (scene.noise**2 + scene.relative**2 * speed2))]
    ranks.append(_rank(np.einsum("ij,ij->i", before, after) / np.maximum(speed2, 1e-12)))

    def sticky(resp: np.ndarray) -> bool:
        return min(_stickiness(resp, follows, lag) for lag in range(1, LAGS + 1)) >= STICKY

    best, best_bic = None, np.inf
    for count in range(1, MOST_STATES + 1):
        for rank in ranks[: 1 if count == 1 else None]:
            fitted = _em(before, after, speed2, wrong_log, np.minimum((rank * count).astype(int), count - 1), count, floor)
            if fitted is None:
                continue
            params, shares, loglik, resp = fitted
            bic = -2.0 * loglik + (4 * count) * np.log(after.shape[0])
            if bic < best_bic:
                best, best_bic = (params, shares, resp), bic
        # Where two states are no better than one, or tracks do not keep them, three are not
        # tried: most scenes are of one kind, and the three-state fits were most of the cost
        # of deciding so (oscillators, 2,700 chains: 0.08 s of CPU a clip, 0.03 s without).
        if count == 2 and (best is None or len(best[0]) < 2 or not sticky(best[2])):
            return (scene,), (1.0,)
    params, shares, resp = best
    if not sticky(resp):
        return (scene,), (1.0,)
    if chains.density:
        # A state whose noise is a good part of the spacing between points is no motion a
        # tracker could follow: its chains are wrong links that chain (a first pass's on a dish
        # 15% missed: 0.48 of the spacing; walkers of the mixed scenes 0.13 to 0.22).
        kept = [k for k, p in enumerate(params) if p[2] * np.sqrt(chains.density) <= WIDEST]
        if len(kept) < 2:
            return (scene,), (1.0,)
        params, shares = [params[k] for k in kept], shares[kept]
    persistences = [p[0] for p in params]
    if max(persistences) - min(persistences) < DISTINCT:
        return (scene,), (1.0,)
    states = tuple(replace(scene, persistence=p, turn=t, noise=max(n, floor), relative=r, along=None, across=None) for p, t, n, r in params)
    total = float(np.sum(shares))
    return states, tuple(float(w) / total for w in shares)


def _rank(values: np.ndarray) -> np.ndarray:
    """Each value's rank among them, as a share in [0, 1)."""
    return np.argsort(np.argsort(values, kind="stable"), kind="stable") / max(values.size, 1)


def _em(before: np.ndarray, after: np.ndarray, speed2: np.ndarray, wrong_log: np.ndarray, group: np.ndarray, count: int, floor: float):
    """EM for ``count`` states from a first split ``group`` of the chains; (persistence, turn,
    noise, relative) per state, their shares and the log-likelihood, or None when a state falls
    below ``LEAST_SHARE``."""
    # A state's squared change |a - p R(turn) b|^2 from these, without turning every chain.
    dot = np.einsum("ij,ij->i", before, after)
    cross = before[:, 0] * after[:, 1] - before[:, 1] * after[:, 0]
    after2 = np.einsum("ij,ij->i", after, after)
    resp = np.zeros((after.shape[0], count + 1))
    resp[np.arange(after.shape[0]), group] = 1.0
    previous = -np.inf
    for _ in range(_ITERATIONS):
        params, logs = [], []
        for k in range(count):
            w = resp[:, k]
            total = w.sum()
            if total <= 0:
                return None
            # Each state's own turn, as the scene's is fitted (fit_chains): a random walk's
            # turn is noise, and the scene's, measured mostly on walkers, turned smooth movers.
            norm = max(float(np.einsum("i,i->", w, speed2)), 1e-12)
            along, across = float(np.einsum("i,i->", w, dot)) / norm, float(np.einsum("i,i->", w, cross)) / norm
            persistence, turn = min(float(np.hypot(along, across)), 1.0), float(np.arctan2(across, along))
            if along <= 0:
                persistence, turn = max(along, -1.0), 0.0
            along_turned = np.cos(turn) * dot + np.sin(turn) * cross
            squared = np.maximum(after2 - 2.0 * persistence * along_turned + persistence**2 * speed2, 0.0) / 2.0
            noise2, relative2 = _weighted_fit(speed2, squared, w)
            variance = np.maximum(noise2 + relative2 * speed2, floor**2)
            params.append((persistence, turn, float(np.sqrt(max(noise2, floor**2))), float(np.sqrt(relative2))))
            logs.append(np.log(total / w.size + 1e-300) - squared / variance - np.log(2.0 * np.pi * variance))
        wrong_share = max(resp[:, count].mean(), 1e-6)
        logs.append(np.log(wrong_share) + wrong_log)
        logs = np.column_stack(logs)
        top = logs.max(axis=1)
        norm = top + np.log(np.exp(logs - top[:, None]).sum(axis=1))
        resp = np.exp(logs - norm[:, None])
        loglik = float(norm.sum())
        if loglik - previous < 1e-6 * after.shape[0]:
            break
        previous = loglik
    shares = resp[:, :count].mean(axis=0)
    if shares.min() < LEAST_SHARE:
        return None
    return params, shares, loglik, resp[:, :count]


def _stickiness(resp: np.ndarray, follows: np.ndarray, lag: int) -> float:
    """How much more often a track's chain ``lag`` links on is in the same state than chance
    would put it there: 0 when states come and go along a track, 1 when each track keeps its own."""
    state = np.eye(resp.shape[1])[resp.argmax(axis=1)]
    # Chain i and chain i + lag are on one track where every chain between continues the last.
    run = np.convolve(follows[1:].astype(int), np.ones(lag, int), mode="valid") == lag
    now, then = state[lag:][run], state[:-lag][run]
    if not now.shape[0]:
        return 0.0
    agree = float(np.mean(np.einsum("ij,ij->i", now, then)))
    chance = float(np.dot(now.mean(axis=0), then.mean(axis=0)))
    return (agree - chance) / max(1.0 - chance, 1e-12)


def _weighted_fit(x: np.ndarray, y: np.ndarray, w: np.ndarray) -> tuple[float, float]:
    """Weighted least-squares c0, c1 >= 0 of y = c0 + c1 x (the normal equations: two unknowns)."""
    sw, swx, swy = w.sum(), np.einsum("i,i->", w, x), np.einsum("i,i->", w, y)
    swxx, swxy = np.einsum("i,i,i->", w, x, x), np.einsum("i,i,i->", w, x, y)
    det = sw * swxx - swx * swx
    c0, c1 = ((swxx * swy - swx * swxy) / det, (sw * swxy - swx * swy) / det) if det > 1e-12 * max(sw * swxx, 1e-300) else (-1.0, -1.0)
    if c1 < 0:
        return float(max(swy / max(sw, 1e-12), 0.0)), 0.0
    if c0 < 0:
        return 0.0, float(max(swxy / max(swxx, 1e-12), 0.0))
    return float(c0), float(c1)


def state_chances(history: np.ndarray, states: tuple[MotionStatistics, ...], shares: tuple[float, ...]) -> np.ndarray:
    """Chance (P, K) that each head is in each state, from its moments ``history`` (P, 5) (see
    :func:`add_chain_moments`) and the scene's ``shares``, by Bayes' rule.

    The variance that grows with the speed is taken at the head's mean squared speed.

    Example
    -------
    >>> smooth = MotionStatistics(1.0, 0.2, 0.0, (0.0, 0.0), 3.0, 100)
    >>> walk = MotionStatistics(0.0, 2.0, 0.0, (0.0, 0.0), 3.0, 100)
    >>> keeps = np.array([[3.0, 27.0, 27.0, 0.0, 27.0]])  # 3 changes of (3, 0) to (3, 0)
    >>> state_chances(keeps, (smooth, walk), (0.5, 0.5)).round(3).tolist()
    [[1.0, 0.0]]
    >>> state_chances(np.zeros((1, 5)), (smooth, walk), (0.3, 0.7)).round(3).tolist()
    [[0.3, 0.7]]
    """
    n, sbb, sba, sbxa, saa = history.T
    logs = []
    for state, share in zip(states, shares):
        along = state.persistence * (np.cos(state.turn) * sba + np.sin(state.turn) * sbxa)
        residual = np.maximum(saa - 2.0 * along + state.persistence**2 * sbb, 0.0)
        variance = state.noise**2 + state.relative**2 * sbb / np.maximum(n, 1e-12)
        logs.append(np.log(share) - residual / (2.0 * variance) - n * np.log(2.0 * np.pi * variance))
    logs = np.column_stack(logs)
    return np.exp(logs - logsumexp(logs, axis=1, keepdims=True))


@dataclass(frozen=True)
class MixtureModel(PersistentModel, key="mixture"):
    """The individual model of motion states per track: each head's link costs the negative log
    of the states' predictions (:class:`PersistentModel` each) mixed by its chance of being in
    each (:func:`state_chances`).

    ``statistics`` is the scene-wide fit: it decides what the scene-wide model decides beside
    the link cost (joins across gaps, whether a head is still there, the gate of first links),
    and scores heads without a velocity or with no history (gap closing's candidates).
    Built by name, as the measured model is: ``IndividualModel(name="mixture", statistics=...,
    states=..., shares=...)``; it runs in a frame moving with the drift (drift 0).

    Attributes
    ----------
    states : tuple of MotionStatistics
        The scene's motion states (:func:`fit_states`); none: the scene-wide model.
    shares : tuple of float
        Share of the chains in each state, summing to 1.
    """

    name: str = "mixture"
    states: tuple[MotionStatistics, ...] = ()
    shares: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        self._check_name()
        if len(self.states) != len(self.shares):
            raise ValueError(f"need one share per motion state, got {len(self.states)} states and {len(self.shares)} shares")
        if any(s.drift != (0.0, 0.0) for s in (self.statistics, *self.states)):
            raise ValueError("the mixture model runs in the frame moving with the drift: its drift must be (0, 0)")

    def cost(self, candidates: Candidates, phi_max: float, d_max: float) -> np.ndarray:
        """As :meth:`PersistentModel.cost`, each head's states mixed by its chances.

        Example
        -------
        A head whose history is smooth pays for a 1 px turn what the smooth state charges:

        >>> smooth = MotionStatistics(1.0, 0.2, 0.0, (0.0, 0.0), 3.0, 100)
        >>> walk = MotionStatistics(0.0, 2.0, 0.0, (0.0, 0.0), 3.0, 100)
        >>> model = MixtureModel(walk, gate=3.0, states=(smooth, walk), shares=(0.5, 0.5))
        >>> pairs = Candidates(np.array([0]), np.array([0]), np.array([[3.0, 1.0]]), np.array([1]), np.array([[3.0, 0.0]]),
        ...                    history=np.array([[3.0, 27.0, 27.0, 0.0, 27.0]]))
        >>> float(model.cost(pairs, 0.1, 10.0)[0]) > 0.1
        True
        """
        scene = super().cost(candidates, phi_max, d_max)
        use = candidates.has_history & np.isfinite(scene)
        if len(self.states) < 2 or candidates.history is None or not use.any():
            return scene
        pairs = candidates.subset(use)
        chances = state_chances(pairs.history, self.states, self.shares)
        terms, weights = [], []
        for k, state in enumerate(self.states):
            squared, spread, one_frame, _ = PersistentModel(state, self.gate, self.w1, self.w2, self.speed_scale)._parts(pairs)
            terms.append(squared + spread)
            weights.append(chances[:, k] / one_frame)
        terms, weights = np.column_stack(terms), np.column_stack(weights)
        weights /= weights.sum(axis=1, keepdims=True)
        with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
            mixed = -2.0 * logsumexp(-0.5 * terms, b=weights, axis=1)
        mixed = np.where(np.isnan(mixed), np.inf, mixed)
        cost = scene.copy()
        cost[use] = phi_max * mixed / self.gate**2
        return cost

    def gate_radius(self, speed: np.ndarray, has_history: np.ndarray, phi_max: float) -> np.ndarray:
        """The widest of the states' gates and the scene's (a mixture costs at least its
        cheapest state's cost)."""
        radius = super().gate_radius(speed, has_history, phi_max)
        for state in self.states:
            radius = np.maximum(radius, PersistentModel(state, self.gate, self.w1, self.w2, self.speed_scale).gate_radius(speed, has_history, phi_max))
        return radius

    def describe(self) -> str:
        """One line for the user: the states and their shares."""
        return ", ".join(f"{share:.0%} persistence {s.persistence:.2f} noise {s.noise:.2f} px/frame + {s.relative:.2f} x speed" for s, share in zip(self.states, self.shares))


__all__ = ["MEMORY", "MixtureModel", "add_chain_moments", "fit_states", "state_chances"]
