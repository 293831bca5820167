"""Point sets the tracker was not tuned on: noisy smooth motion, insect-like walks and flows.

These generators exist to check accuracy claims on motion that none of the defaults was
chosen against (the issue-15 discipline): a PSMG-like generator written apart from
:mod:`seedtrack.data.psmg` whose speed and direction steps are given relative to the speed,
persistent random walks in an arena (insects: a heading that wanders, a speed that varies,
walls that turn them back), particles in a vortex and in a shear flow with diffusion. Every
generator returns what :func:`seedtrack.data.psmg.generate_psmg` returns: measured positions
per frame in random order and the truth as :class:`~seedtrack.tracking.tracks.Tracks`
(pixels, x right, y down, 0-based frames).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from seedtrack.tracking.tracks import NO_MEASUREMENT, Tracks

# Trajectories drawn per wanted one when only those that stay in view are kept.
_OVERDRAW = 6
_ATTEMPTS = 100
# A trajectory that enters or leaves is kept when it is in view in this many frames.
_MIN_IN_VIEW = 3


@dataclass(frozen=True)
class HeldOutSpec:
    """One held-out scene.

    Attributes
    ----------
    kind : {"smooth", "insect", "vortex", "shear"}
        "smooth": each point keeps a speed and heading that take Gaussian steps of
        ``speed_step`` times the mean speed and ``turn_step`` degrees a frame, speed within
        [0, 2 speed], trajectories that stay in the view. "insect": headings wander by
        ``turn_step`` degrees a frame (von Mises), each step's speed is the walker's own mean
        times a gamma factor of relative spread ``speed_step``, walls reflect. "vortex": a
        Lamb-Oseen vortex about the centre whose fastest ring moves at ``speed``, plus
        diffusion. "shear": x-velocity growing linearly from 0 at the top to ``speed`` at the
        bottom, plus diffusion; points enter and leave.
    points : int
        Points in the view (about, for "shear").
    speed : float
        Mean speed ("smooth", "insect") or the fastest flow speed ("vortex", "shear"), pixels/frame.
    speed_step : float
        Relative speed noise per frame (see ``kind``).
    turn_step : float
        Direction noise per frame, degrees.
    diffusion : float
        Standard deviation of a Brownian step per axis, pixels/frame ("vortex", "shear").
    missed : float
        Probability that a point in view is not measured in a frame.
    frames : int
    size : float
        Side of the square view, pixels.
    random_seed : int
    """

    kind: str = "smooth"
    points: int = 50
    speed: float = 6.0
    speed_step: float = 0.1
    turn_step: float = 10.0
    diffusion: float = 0.3
    missed: float = 0.0
    frames: int = 20
    size: float = 200.0
    random_seed: int = 0

    def __post_init__(self) -> None:
        if self.kind not in _KINDS:
            raise ValueError(f"kind must be one of {', '.join(_KINDS)}, got {self.kind!r}")
        if self.points < 0 or self.frames < 2 or not self.size > 0 or self.speed < 0:
            raise ValueError("need points >= 0, frames >= 2, size > 0 and speed >= 0")
        if min(self.speed_step, self.turn_step, self.diffusion) < 0 or not 0 <= self.missed < 1:
            raise ValueError("noise levels must be non-negative and missed in [0, 1)")

    @property
    def max_speed(self) -> float:
        """A speed no point exceeds in a typical frame, pixels/frame (the peers' search range
        is twice the mean speed, as for PSMG)."""
        return 2.0 * self.speed


def generate_held_out(spec: HeldOutSpec) -> tuple[list[np.ndarray], Tracks]:
    """Draw one scene.

    Returns
    -------
    frames : list of ndarray, each (M_k, 2)
        Measured positions per frame, pixels, in random order.
    truth : Tracks
        One track per point with its position in every frame it is in view (NaN outside),
        measurement -1 where it was in view but missed.

    Example
    -------
    >>> frames, truth = generate_held_out(HeldOutSpec(kind="insect", points=10, random_seed=1))
    >>> len(frames), truth.n_tracks
    (20, 10)
    """
    rng = np.random.default_rng(spec.random_seed)
    paths = _KINDS[spec.kind](rng, spec)
    inside = ((paths >= 0) & (paths <= spec.size)).all(axis=2)
    seen = inside & (rng.random(inside.shape) >= spec.missed)
    measurement = np.full(inside.shape, NO_MEASUREMENT, dtype=np.int64)
    frames = []
    for k in range(spec.frames):
        who = rng.permutation(np.flatnonzero(seen[:, k]))
        measurement[who, k] = np.arange(who.size)
        frames.append(paths[who, k])
    return frames, Tracks.from_dense(np.where(inside[..., None], paths, np.nan), measurement)


def _kept_in_view(rng: np.random.Generator, spec: HeldOutSpec, draw) -> np.ndarray:
    """``spec.points`` trajectories from ``draw(rng, count)`` that stay in the view throughout."""
    kept, wanted = [], spec.points
    for _ in range(_ATTEMPTS):
        if wanted <= 0:
            break
        batch = draw(rng, _OVERDRAW * wanted + 8)
        ok = ((batch >= 0) & (batch <= spec.size)).all(axis=(1, 2))
        kept.append(batch[ok][:wanted])
        wanted -= kept[-1].shape[0]
    if wanted > 0:
        raise ValueError(f"could not draw {spec.points} trajectories that stay in view at speed {spec.speed:g}")
    return np.concatenate(kept) if kept else np.empty((0, spec.frames, 2))


def _smooth(rng: np.random.Generator, spec: HeldOutSpec) -> np.ndarray:
    def draw(rng: np.random.Generator, count: int) -> np.ndarray:
        steps = spec.frames - 1
        speed = np.empty((count, steps))
        speed[:, 0] = spec.speed
        noise = rng.normal(0.0, spec.speed_step * spec.speed, (count, steps))
        for k in range(1, steps):
            speed[:, k] = np.clip(speed[:, k - 1] + noise[:, k], 0.0, 2.0 * spec.speed)
        heading = rng.uniform(0, 2 * math.pi, (count, 1)) + np.cumsum(
            np.concatenate((np.zeros((count, 1)), rng.normal(0.0, math.radians(spec.turn_step), (count, steps - 1))), axis=1), axis=1
        )
        step = np.stack((speed * np.cos(heading), speed * np.sin(heading)), axis=-1)
        start = rng.uniform(0, spec.size, (count, 1, 2))
        return np.concatenate((start, start + np.cumsum(step, axis=1)), axis=1)

    return _kept_in_view(rng, spec, draw)


def _insect(rng: np.random.Generator, spec: HeldOutSpec) -> np.ndarray:
    n, steps = spec.points, spec.frames - 1
    # Von Mises concentration whose turning angles have about turn_step degrees of spread.
    spread = math.radians(max(spec.turn_step, 1e-3))
    kappa = 1.0 / (spread * spread)
    mean_speed = spec.speed * rng.uniform(0.5, 1.5, n)
    shape = 1.0 / max(spec.speed_step, 1e-3) ** 2
    heading = rng.uniform(0, 2 * math.pi, n)
    xy = np.empty((n, spec.frames, 2))
    xy[:, 0] = rng.uniform(0, spec.size, (n, 2))
    for k in range(steps):
        heading = heading + rng.vonmises(0.0, kappa, n)
        speed = mean_speed * rng.gamma(shape, 1.0 / shape, n)
        nxt = xy[:, k] + speed[:, None] * np.column_stack((np.cos(heading), np.sin(heading)))
        # A wall turns the insect back: reflect the position and the heading component.
        low, high = nxt < 0, nxt > spec.size
        nxt = np.where(low, -nxt, np.where(high, 2 * spec.size - nxt, nxt))
        flip = low | high
        heading = np.where(flip[:, 0], math.pi - heading, heading)
        heading = np.where(flip[:, 1], -heading, heading)
        xy[:, k + 1] = nxt
    return xy


def _vortex(rng: np.random.Generator, spec: HeldOutSpec) -> np.ndarray:
    centre = spec.size / 2.0
    core = spec.size / 6.0
    # Lamb-Oseen: v(r) = c (1 - exp(-r^2/core^2)) / r peaks at r = 1.121 core with 0.638 c / core.
    circulation = spec.speed * core / 0.638

    def draw(rng: np.random.Generator, count: int) -> np.ndarray:
        radius = spec.size / 2.0 * np.sqrt(rng.uniform(0.0, 1.0, count))
        angle = rng.uniform(0, 2 * math.pi, count)
        xy = np.empty((count, spec.frames, 2))
        xy[:, 0] = centre + np.column_stack((radius * np.cos(angle), radius * np.sin(angle)))
        for k in range(spec.frames - 1):
            rel = xy[:, k] - centre
            r = np.maximum(np.hypot(*rel.T), 1e-6)
            speed = circulation * -np.expm1(-(r / core) ** 2) / r
            # Exact rotation by the ring's angle this frame, so that the flow keeps its radius.
            turn = speed / r
            c, s = np.cos(turn), np.sin(turn)
            rotated = np.column_stack((c * rel[:, 0] - s * rel[:, 1], s * rel[:, 0] + c * rel[:, 1]))
            xy[:, k + 1] = centre + rotated + rng.normal(0.0, spec.diffusion, (count, 2))
        return xy

    return _kept_in_view(rng, spec, draw)


def _shear(rng: np.random.Generator, spec: HeldOutSpec) -> np.ndarray:
    # Upstream band from which points can flow in during the clip, at the fastest speed.
    reach = spec.speed * (spec.frames - 1)
    count = int(round(spec.points * (spec.size + reach) / spec.size))
    xy = np.empty((count, spec.frames, 2))
    xy[:, 0, 0] = rng.uniform(-reach, spec.size, count)
    xy[:, 0, 1] = rng.uniform(0, spec.size, count)
    for k in range(spec.frames - 1):
        flow = spec.speed * np.clip(xy[:, k, 1] / spec.size, 0.0, 1.0)
        xy[:, k + 1] = xy[:, k] + np.column_stack((flow, np.zeros(count))) + rng.normal(0.0, spec.diffusion, (count, 2))
    inside = ((xy >= 0) & (xy <= spec.size)).all(axis=2)
    return xy[inside.sum(axis=1) >= _MIN_IN_VIEW]


_KINDS = {"smooth": _smooth, "insect": _insect, "vortex": _vortex, "shear": _shear}
