"""Motion kinds that no default of seedtrack was tuned on (issue 29): points oscillating about
fixed sites, run-and-tumble walkers, people walking side by side seen every second frame, a
crowded swarm whose nearest neighbour lies within a step, slow walkers on whole pixels, and
objects that leave while others enter later far away.

Every generator returns what :func:`seedtrack.data.psmg.generate_psmg` returns: measured
positions per frame in random order and the truth as :class:`~seedtrack.tracking.tracks.Tracks`
(pixels, x right, y down, 0-based frames; NaN where an object is out of view or absent).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from seedtrack.tracking.tracks import NO_MEASUREMENT, Tracks


@dataclass(frozen=True)
class UnseenSpec:
    """One scene.

    Attributes
    ----------
    kind : {"oscillate", "tumble", "side_by_side", "swarm", "whole_pixel", "relay"}
        "oscillate": each point swings along a line through its own fixed site, amplitude up to
        ``speed`` times its period over 2 pi (fastest speed about ``speed``), periods of 4 to 10
        frames, so the velocity reverses every 2 to 5 frames. "tumble": straight runs at
        ``speed``, each frame a tumble with chance 0.1 to a heading turned 30 to 180 degrees;
        walls reflect. "side_by_side": pairs walking abreast ``spacing`` pixels apart at
        ``speed`` with slow turns, every second frame dropped (so ``speed`` is per kept frame).
        "swarm": smooth motion at ``speed`` among so many points that the nearest neighbour is
        nearer than a step; walls reflect. "whole_pixel": smooth slow walkers whose positions are
        rounded to whole pixels. "relay": objects on smooth paths that each stay for part of the
        clip, so that tracks end and others start later elsewhere.
    points : int
        Objects in the scene (in view at a time, about, for "relay").
    speed : float
        Typical speed, pixels/frame (per kept frame for "side_by_side").
    frames : int
        Frames returned.
    size : float
        Side of the square view, pixels.
    spacing : float
        Distance between walkers abreast, pixels ("side_by_side").
    noise : float
        Standard deviation of the position error per axis, pixels.
    random_seed : int
    """

    kind: str = "oscillate"
    points: int = 100
    speed: float = 4.0
    frames: int = 30
    size: float = 200.0
    spacing: float = 6.0
    noise: float = 0.2
    random_seed: int = 0

    def __post_init__(self) -> None:
        if self.kind not in _KINDS:
            raise ValueError(f"kind must be one of {', '.join(_KINDS)}, got {self.kind!r}")
        if self.points < 1 or self.frames < 3 or not self.size > 0 or not self.speed > 0 or self.noise < 0:
            raise ValueError("need points >= 1, frames >= 3, size > 0, speed > 0 and noise >= 0")


def generate_unseen(spec: UnseenSpec) -> tuple[list[np.ndarray], Tracks]:
    """Draw one scene.

    Returns
    -------
    frames : list of ndarray, each (M_k, 2)
        Measured positions per frame, pixels, in random order.
    truth : Tracks
        One track per object with its position in every frame it is in view.

    Example
    -------
    >>> frames, truth = generate_unseen(UnseenSpec(kind="tumble", points=10, random_seed=1))
    >>> len(frames), truth.n_tracks
    (30, 10)
    """
    rng = np.random.default_rng(spec.random_seed)
    paths = _KINDS[spec.kind](rng, spec)
    paths = paths + rng.normal(0.0, spec.noise, paths.shape)
    if spec.kind == "whole_pixel":
        paths = np.round(paths)
    return observed(rng, paths, spec.size)


def observed(rng: np.random.Generator, paths: np.ndarray, size: float) -> tuple[list[np.ndarray], Tracks]:
    """The frames and truth of objects on ``paths`` (objects x frames x 2, pixels) seen in a
    square view of side ``size``: each frame's points in random order, NaN where out of view."""
    inside = ((paths >= 0) & (paths <= size)).all(axis=2)
    paths = paths[inside.any(axis=1)]
    inside = inside[inside.any(axis=1)]
    measurement = np.full(inside.shape, NO_MEASUREMENT, dtype=np.int64)
    frames = []
    for k in range(paths.shape[1]):
        who = rng.permutation(np.flatnonzero(inside[:, k]))
        measurement[who, k] = np.arange(who.size)
        frames.append(paths[who, k])
    return frames, Tracks.from_dense(np.where(inside[..., None], paths, np.nan), measurement)


def _reflected(xy: np.ndarray, heading: np.ndarray, size: float) -> tuple[np.ndarray, np.ndarray]:
    """Positions folded back into [0, size] and headings turned as off a wall."""
    low, high = xy < 0, xy > size
    xy = np.where(low, -xy, np.where(high, 2 * size - xy, xy))
    heading = np.where(low[:, 0] | high[:, 0], math.pi - heading, heading)
    heading = np.where(low[:, 1] | high[:, 1], -heading, heading)
    return xy, heading


def _walk(rng: np.random.Generator, spec: UnseenSpec, n: int, frames: int, speed: np.ndarray, turn: float, tumble: float) -> np.ndarray:
    """Walkers in the view with walls, heading wandering ``turn`` radians a frame and, with chance
    ``tumble`` a frame, turned 30 to 180 degrees either way."""
    xy = np.empty((n, frames, 2))
    xy[:, 0] = rng.uniform(0, spec.size, (n, 2))
    heading = rng.uniform(0, 2 * math.pi, n)
    for k in range(frames - 1):
        heading = heading + rng.normal(0.0, turn, n)
        turned = rng.random(n) < tumble
        heading = np.where(turned, heading + rng.choice((-1.0, 1.0), n) * rng.uniform(math.pi / 6, math.pi, n), heading)
        step = speed[:, None] * np.column_stack((np.cos(heading), np.sin(heading)))
        xy[:, k + 1], heading = _reflected(xy[:, k] + step, heading, spec.size)
    return xy


def _oscillate(rng: np.random.Generator, spec: UnseenSpec) -> np.ndarray:
    n = spec.points
    site = rng.uniform(0, spec.size, (n, 2))
    period = rng.uniform(4.0, 10.0, n)
    # Fastest speed amplitude * 2 pi / period, between half and all of spec.speed.
    amplitude = spec.speed * rng.uniform(0.5, 1.0, n) * period / (2 * math.pi)
    angle = rng.uniform(0, math.pi, n)
    phase = rng.uniform(0, 2 * math.pi, n)
    swing = amplitude[:, None] * np.sin(2 * math.pi * np.arange(spec.frames)[None, :] / period[:, None] + phase[:, None])
    return site[:, None, :] + swing[..., None] * np.column_stack((np.cos(angle), np.sin(angle)))[:, None, :]


def _tumble(rng: np.random.Generator, spec: UnseenSpec) -> np.ndarray:
    speed = spec.speed * rng.uniform(0.7, 1.3, spec.points)
    return _walk(rng, spec, spec.points, spec.frames, speed, math.radians(2.0), 0.1)


def _side_by_side(rng: np.random.Generator, spec: UnseenSpec) -> np.ndarray:
    pairs = (spec.points + 1) // 2
    walked = 2 * spec.frames - 1
    speed = spec.speed / 2 * rng.uniform(0.8, 1.2, pairs)
    centre = _walk(rng, spec, pairs, walked, speed, math.radians(4.0), 0.0)
    step = np.diff(centre, axis=1)
    step = np.concatenate((step[:, :1], step), axis=1)
    across = np.stack((-step[..., 1], step[..., 0]), axis=-1) / np.maximum(np.hypot(*np.moveaxis(step, -1, 0)), 1e-9)[..., None]
    # Abreast, with a little sway of each walker about its place.
    sway = rng.normal(0.0, 0.1 * spec.spacing, (2, pairs, walked, 1))
    left = centre + across * (spec.spacing / 2 + sway[0])
    right = centre - across * (spec.spacing / 2 + sway[1])
    return np.concatenate((left, right))[: spec.points, ::2]


def _swarm(rng: np.random.Generator, spec: UnseenSpec) -> np.ndarray:
    speed = spec.speed * rng.uniform(0.8, 1.2, spec.points)
    return _walk(rng, spec, spec.points, spec.frames, speed, math.radians(10.0), 0.0)


def _whole_pixel(rng: np.random.Generator, spec: UnseenSpec) -> np.ndarray:
    speed = spec.speed * rng.uniform(0.5, 1.5, spec.points)
    return _walk(rng, spec, spec.points, spec.frames, speed, math.radians(15.0), 0.0)


def _relay(rng: np.random.Generator, spec: UnseenSpec) -> np.ndarray:
    # Each object stays a third of the clip on average: three times as many as are in view.
    n = 3 * spec.points
    speed = spec.speed * rng.uniform(0.7, 1.3, n)
    xy = _walk(rng, spec, n, spec.frames, speed, math.radians(10.0), 0.0)
    stay = rng.integers(5, max(6, 2 * spec.frames // 3), n)
    start = rng.integers(-stay + 3, spec.frames - 3)
    frame = np.arange(spec.frames)
    absent = (frame[None, :] < start[:, None]) | (frame[None, :] >= (start + stay)[:, None])
    return np.where(absent[..., None], -1.0, xy)


_KINDS = {"oscillate": _oscillate, "tumble": _tumble, "side_by_side": _side_by_side, "swarm": _swarm, "whole_pixel": _whole_pixel, "relay": _relay}

__all__ = ["UnseenSpec", "generate_unseen", "observed"]
