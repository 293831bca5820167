"""A synthetic rotating-dish clip with ground truth, like the seed recordings of the paper.

Dark seeds lie on a light dish that turns about its centre at a near-constant angular speed,
filmed from above at 25 Hz: seeds near the centre move about a pixel per frame, seeds at the rim
tens of pixels. Positions are in pixels, x to the right and y down, with pixel centres at
integer coordinates (OpenCV convention); frame indices are 0-based. A positive angle turns the
dish clockwise on screen, because y points down.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

import cv2
import numpy as np

from seedtrack.tracking.tracks import NO_MEASUREMENT, Tracks

from .csvio import write_table
from .video import write_video

# Fractions of min(width, height) and of the dish radius, as in the paper's set-up: the dish
# fills most of the picture, and seeds keep clear of its rim.
_DISH_RADIUS_FRACTION = 0.46
_SEED_RADIUS_FRACTION = 0.95
# Seeds further apart than this many seed lengths never touch, even when turned end to end.
_SEPARATION_IN_LENGTHS = 2.5
# Grey levels of the scene before noise.
_BACKGROUND_GREY = 80.0
_DISH_GREY_BRIGHTEST = 235.0
_SEED_GREY_RANGE = (40.0, 60.0)
# Sub-samples per pixel along each axis when rendering seeds.
_SUPERSAMPLING = 4
# Candidate positions drawn per seed before placement gives up: dart throwing slows down
# sharply as the dish fills, so running out means the spec asks for too many seeds.
_CANDIDATES_PER_SEED = 200
# Distinct streams from one random_seed, so that adding a knob never changes the noise.
_NOISE_STREAM = 1
_CLUTTER_STREAM = 2
_COMINGS_AND_GOINGS_STREAM = 3
# Dish wall: a dark ring this many pixels wide just outside the dish, at this grey level, and
# the shadow it casts on the dish: this many grey levels deep at the wall on the lit side's
# opposite, fading inwards over this many pixels.
_RIM_WIDTH = 3.0
_RIM_GREY = 45.0
_SHADOW_DEPTH = 40.0
_SHADOW_FADE = 5.0
# Glare: Gaussian spots of reflected light, fixed in the picture (they come from the lamp).
_GLARE_SIGMA_RANGE = (2.0, 5.0)
_GLARE_GREY_RANGE = (30.0, 60.0)
# Dust: dark round specks lying on the dish, turning with it, this diameter in pixels.
_DUST_DIAMETER = 1.5
_DUST_GREY = 60.0
# Frames a seed that is hidden, added or removed stays in view at each end of a clip, at least:
# the fewest measured frames in a row from which a track can start.
_SHOWN_AT_ENDS = 3


@dataclass(frozen=True)
class DishSpec:
    """What to render.

    Attributes
    ----------
    seeds : int
        Number of seeds.
    frames : int
        Number of frames.
    width, height : int
        Frame size in pixels.
    rim_speed : float
        Speed of the dish rim in pixels per frame; the angular speed is rim_speed / radius
        radians per frame, so seeds (at most 0.95 radius out) move up to 0.95 * rim_speed.
    random_seed : int
        Seed of every random choice: same spec, same frames, byte for byte.
    hidden_probability : float
        Probability, independently per seed and frame (frame 0 included), that a seed is not
        drawn.
    hidden_seeds : int
        Seeds hidden once for ``hidden_frames`` frames in a row (as by a hand), each from a
        random frame that leaves at least 3 frames in view before and after.
    hidden_frames : int
        Length of each of those hidings, frames.
    added_seeds : int
        Seeds put on the dish mid-clip: absent (NaN in the truth) before a random frame in
        1..frames-3.
    removed_seeds : int
        Seeds taken off the dish mid-clip: absent after a random frame in 2..frames-2, so that
        each is seen in at least 3 frames. Hidden, added and removed seeds are distinct.
    fps : float
        Frames per second of the clip written by :func:`write_dish_clip`.
    seed_length, seed_width : float
        Full lengths of a seed's ellipse axes in pixels.
    blur_sigma : float
        Standard deviation of the optical Gaussian blur in pixels (0 for none).
    noise_sigma : float
        Standard deviation of the sensor noise in grey levels (0 for none).
    illumination : float
        How many grey levels darker the dish gets from its brightest to its dimmest part
        (vignette plus a linear gradient).
    speed_jitter : float
        Relative standard deviation of the angular speed from frame to frame.
    touching_pairs : int
        How many pairs of seeds lie in contact, touching at a random angle from a random side;
        they stay in contact as the dish turns.
    rim : bool
        Draw the dish wall as a dark ring just outside the dish, and its shadow on the dish.
    glare_spots : int
        Bright spots of reflected light, fixed in the picture while the dish turns beneath.
    dust_specks : int
        Dark specks 1.5 px across (a seed is 7 x 3.5) lying on the dish, turning with it, at
        least a seed length away from every seed; not in the truth.
    separation : float or None
        Least distance between seed centres, pixels; None for 2.5 seed lengths, so that seeds
        never touch unless in a touching pair. A seed length or less makes a dense dish on
        which many seeds touch.
    """

    seeds: int = 80
    frames: int = 10
    width: int = 640
    height: int = 480
    rim_speed: float = 42.0
    random_seed: int = 0
    hidden_probability: float = 0.0
    hidden_seeds: int = 0
    hidden_frames: int = 0
    added_seeds: int = 0
    removed_seeds: int = 0
    fps: float = 25.0
    seed_length: float = 7.0
    seed_width: float = 3.5
    blur_sigma: float = 0.7
    noise_sigma: float = 2.0
    illumination: float = 20.0
    speed_jitter: float = 0.005
    touching_pairs: int = 0
    rim: bool = False
    glare_spots: int = 0
    dust_specks: int = 0
    separation: float | None = None

    def __post_init__(self) -> None:
        checks = [
            (_is_int(self.seeds) and self.seeds >= 0, "seeds must be a whole number >= 0"),
            (_is_int(self.frames) and self.frames >= 1, "frames must be a whole number >= 1"),
            (_is_int(self.width) and self.width >= 16, "width must be a whole number >= 16"),
            (_is_int(self.height) and self.height >= 16, "height must be a whole number >= 16"),
            (_is_int(self.random_seed) and self.random_seed >= 0, "random_seed must be a whole number >= 0"),
            (0 <= self.rim_speed < math.inf, "rim_speed must be finite and >= 0"),
            (0 <= self.hidden_probability <= 1, "hidden_probability must be in [0, 1]"),
            (
                all(_is_int(n) and n >= 0 for n in (self.hidden_seeds, self.hidden_frames, self.added_seeds, self.removed_seeds)),
                "hidden_seeds, hidden_frames, added_seeds and removed_seeds must be whole numbers >= 0",
            ),
            (self.hidden_seeds + self.added_seeds + self.removed_seeds <= self.seeds, "more seeds hidden, added or removed than seeds"),
            (
                self.hidden_seeds == 0 or self.frames >= self.hidden_frames + 2 * _SHOWN_AT_ENDS,
                "frames must be at least hidden_frames + 6 to hide seeds",
            ),
            (self.added_seeds + self.removed_seeds == 0 or self.frames >= 2 * _SHOWN_AT_ENDS, "frames must be at least 6 to add or remove seeds"),
            (0 < self.fps < math.inf, "fps must be finite and > 0"),
            (0 < self.seed_width <= self.seed_length, "need 0 < seed_width <= seed_length"),
            (self.seed_length < _DISH_RADIUS_FRACTION * min(self.width, self.height), "seed_length must be smaller than the dish"),
            (0 <= self.blur_sigma <= 10, "blur_sigma must be in [0, 10]"),
            (0 <= self.noise_sigma <= 100, "noise_sigma must be in [0, 100]"),
            (0 <= self.illumination <= 100, "illumination must be in [0, 100]"),
            (0 <= self.speed_jitter < 1, "speed_jitter must be in [0, 1)"),
            (
                _is_int(self.touching_pairs) and 0 <= 2 * self.touching_pairs <= max(self.seeds, 0),
                "touching_pairs must be a whole number, at most half the seeds",
            ),
            (_is_int(self.glare_spots) and self.glare_spots >= 0, "glare_spots must be a whole number >= 0"),
            (_is_int(self.dust_specks) and self.dust_specks >= 0, "dust_specks must be a whole number >= 0"),
            (self.separation is None or 0 < self.separation < math.inf, "separation must be finite and > 0"),
        ]
        problems = [message for ok, message in checks if not ok]
        if problems:
            raise ValueError(f"bad DishSpec: {'; '.join(problems)}")


def _is_int(value) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, bool)


@dataclass(frozen=True, eq=False)
class DishScene:
    """A rendered dish: ground truth and a renderer for each frame.

    Attributes
    ----------
    spec : DishSpec
        What was asked for.
    truth : Tracks
        One track per seed; ``xy`` (seeds, frames, 2) in pixels is defined in every frame the
        seed is on the dish (NaN before an added seed arrives and after a removed one leaves),
        ``measurement`` is the seed index where the seed is drawn and -1 where it is hidden or
        absent, so hidden positions count as interpolated.
    visible : ndarray of bool, shape (seeds, frames)
        Whether each seed is drawn in each frame.
    centre : tuple of float
        Dish centre (x, y) in pixels.
    radius : float
        Dish radius in pixels.
    orientation : ndarray of float, shape (seeds, frames)
        Angle of each seed's long axis from the x axis, radians, clockwise on screen.
    seed_grey : ndarray of float, shape (seeds,)
        Grey level of each seed's body.
    background : ndarray of float32, shape (height, width)
        The empty dish before blur and noise (with its rim and shadow if asked for).
    glare : ndarray of float32, shape (height, width)
        Light added to every frame by the glare spots, grey levels.
    dust_xy : ndarray of float, shape (dust_specks, frames, 2)
        Centre of each dust speck in each frame, pixels.
    """

    spec: DishSpec
    truth: Tracks
    visible: np.ndarray
    centre: tuple[float, float]
    radius: float
    orientation: np.ndarray
    seed_grey: np.ndarray
    background: np.ndarray
    glare: np.ndarray
    dust_xy: np.ndarray

    def visible_points(self) -> list[np.ndarray]:
        """The positions (x, y), pixels, of the seeds drawn in each frame, in seed order: what
        a perfect detector would measure."""
        return [self.truth.xy[self.visible[:, k], k] for k in range(self.spec.frames)]

    def render(self, frame_index: int) -> np.ndarray:
        """Render one frame.

        Parameters
        ----------
        frame_index : int
            0-based frame index, < ``spec.frames``.

        Returns
        -------
        ndarray of uint8, shape (height, width, 3)
            BGR image (all channels equal).
        """
        if not _is_int(frame_index) or not 0 <= frame_index < self.spec.frames:
            raise IndexError(f"frame_index must be in 0..{self.spec.frames - 1}, got {frame_index!r}")
        shown = self.visible[:, frame_index]
        n_shown, n_dust = int(shown.sum()), len(self.dust_xy)
        spec = self.spec
        image = _draw_ellipses(
            self.background,
            np.concatenate([self.truth.xy[shown, frame_index], self.dust_xy[:, frame_index]]).reshape(-1, 2),
            np.concatenate([self.orientation[shown, frame_index], np.zeros(n_dust)]),
            np.concatenate([self.seed_grey[shown], np.full(n_dust, _DUST_GREY)]),
            np.r_[np.full(n_shown, spec.seed_length / 2), np.full(n_dust, _DUST_DIAMETER / 2)],
            np.r_[np.full(n_shown, spec.seed_width / 2), np.full(n_dust, _DUST_DIAMETER / 2)],
        )
        image += self.glare
        if self.spec.blur_sigma > 0:
            image = cv2.GaussianBlur(image, (0, 0), self.spec.blur_sigma, borderType=cv2.BORDER_REFLECT)
        if self.spec.noise_sigma > 0:
            rng = np.random.default_rng((self.spec.random_seed, _NOISE_STREAM, frame_index))
            image += np.float32(self.spec.noise_sigma) * rng.standard_normal(image.shape, dtype=np.float32)
        grey = np.clip(np.rint(image), 0, 255).astype(np.uint8)
        return cv2.cvtColor(grey, cv2.COLOR_GRAY2BGR)

    def frames(self) -> Iterator[np.ndarray]:
        """Yield every frame in order, rendered on demand."""
        for frame_index in range(self.spec.frames):
            yield self.render(frame_index)


def make_dish_scene(spec: DishSpec) -> DishScene:
    """Place the seeds, turn the dish and set up rendering; see :class:`DishScene`.

    Raises
    ------
    ValueError
        If the seeds do not fit on the dish at the minimum separation.
    """
    rng = np.random.default_rng(spec.random_seed)
    centre = np.array([(spec.width - 1) / 2, (spec.height - 1) / 2])
    radius = _DISH_RADIUS_FRACTION * min(spec.width, spec.height)
    pairs = spec.touching_pairs
    # A seed with a partner needs room for the partner, a seed length further out at most.
    room = spec.seed_length if pairs else 0.0
    separation = _SEPARATION_IN_LENGTHS * spec.seed_length if spec.separation is None else spec.separation
    start = _place_seeds(rng, spec.seeds - pairs, _SEED_RADIUS_FRACTION * radius - room, separation + room)
    angle = _dish_angles(rng, spec.frames, spec.rim_speed / radius, spec.speed_jitter)
    heading = rng.uniform(0, np.pi, spec.seeds)
    seed_grey = rng.uniform(*_SEED_GREY_RANGE, spec.seeds)
    visible = rng.random((spec.seeds, spec.frames)) >= spec.hidden_probability
    # Partners (the last seeds) touch the first seeds at a random angle from a random side.
    clutter = np.random.default_rng((spec.random_seed, _CLUTTER_STREAM))
    relative, side = clutter.uniform(0, np.pi, pairs), clutter.uniform(0, 2 * np.pi, pairs)
    heading[spec.seeds - pairs :] = heading[:pairs] + relative
    gap = _contact_distance(spec.seed_length / 2, spec.seed_width / 2, relative, side)
    turn = heading[:pairs] + side
    start = np.concatenate([start, start[:pairs] + gap[:, None] * np.column_stack([np.cos(turn), np.sin(turn)])])
    orientation = heading[:, None] + angle[None, :]
    xy = centre + _rotate(start, angle)
    on_dish, hand = _comings_and_goings(spec)
    visible &= on_dish & ~hand
    xy[~on_dish] = np.nan
    dust_start = _place_dust(clutter, spec.dust_specks, start, _SEED_RADIUS_FRACTION * radius, spec.seed_length)
    background = _empty_dish(spec.width, spec.height, centre, radius, spec.illumination)
    if spec.rim:
        background = _add_rim(background, centre, radius)
    measurement = np.where(visible, np.arange(spec.seeds)[:, None], NO_MEASUREMENT)
    return DishScene(
        spec=spec,
        truth=Tracks.from_dense(xy=xy, measurement=measurement),
        visible=visible,
        centre=(float(centre[0]), float(centre[1])),
        radius=float(radius),
        orientation=orientation,
        seed_grey=seed_grey,
        background=background,
        glare=_glare(clutter, spec.glare_spots, spec.width, spec.height, centre, radius),
        dust_xy=centre + _rotate(dust_start, angle),
    )


def write_dish_clip(spec: DishSpec, out_dir: str | os.PathLike, *, progress=None, crf: int = 14) -> DishScene:
    """Render a scene to ``out_dir/clip.mp4`` and its truth to ``out_dir/truth.csv``.

    Parameters
    ----------
    spec : DishSpec
        What to render; the clip's frame rate is ``spec.fps``.
    out_dir : path-like
        Folder, created if missing.
    progress : tqdm-like or callable, optional
        Passed to :func:`seedtrack.data.video.write_video`; ticked once per frame.
    crf : int
        x264 quality; the default keeps compression from moving seed centroids by more than a
        few hundredths of a pixel.

    Returns
    -------
    DishScene
        The scene that was written.
    """
    scene = make_dish_scene(spec)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    write_video(out / "clip.mp4", scene.frames(), spec.fps, crf=crf, progress=progress)
    write_table(out / "truth.csv", scene.truth.to_rows())
    return scene


def _comings_and_goings(spec: DishSpec) -> tuple[np.ndarray, np.ndarray]:
    """(seeds, frames) bool arrays: whether each seed is on the dish, and whether a hand hides it.

    Drawn from their own random stream, so a spec without hidden, added or removed seeds
    renders exactly as before these knobs existed.
    """
    rng = np.random.default_rng((spec.random_seed, _COMINGS_AND_GOINGS_STREAM))
    who = rng.permutation(spec.seeds)
    end = np.cumsum([spec.hidden_seeds, spec.added_seeds, spec.removed_seeds])
    hidden, added, removed = who[: end[0]], who[end[0] : end[1]], who[end[1] : end[2]]
    frame = np.arange(spec.frames)
    on_dish = np.ones((spec.seeds, spec.frames), bool)
    arrival = rng.integers(1, spec.frames - _SHOWN_AT_ENDS + 1, size=added.size)
    on_dish[added] = frame >= arrival[:, None]
    departure = rng.integers(_SHOWN_AT_ENDS - 1, spec.frames - 1, size=removed.size)  # last frame on the dish
    on_dish[removed] = frame <= departure[:, None]
    hand = np.zeros_like(on_dish)
    if hidden.size:
        begin = rng.integers(_SHOWN_AT_ENDS, spec.frames - _SHOWN_AT_ENDS - spec.hidden_frames + 1, size=hidden.size)
        hand[hidden] = (frame >= begin[:, None]) & (frame < begin[:, None] + spec.hidden_frames)
    return on_dish, hand


def _place_seeds(rng: np.random.Generator, count: int, max_radius: float, separation: float) -> np.ndarray:
    """Dart throwing: uniform positions (relative to the centre) no closer than ``separation``.

    Returns
    -------
    ndarray of float, shape (count, 2)
    """
    # Discs of diameter `separation` centred within max_radius cover no more than their areas
    # allow: ten million seeds are refused at once rather than after as many darts.
    most = int(((max_radius + separation / 2) / (separation / 2)) ** 2)
    if count > most:
        raise ValueError(f"at most {most} seeds fit on the dish {separation:.1f} px apart, not {count}; use fewer seeds, shorter seeds or a larger frame")
    candidates = _uniform_in_disc(rng, count * _CANDIDATES_PER_SEED, max_radius)
    placed = np.empty((count, 2))
    n_placed = 0
    for candidate in candidates:
        if n_placed == count:
            break
        if np.all(np.sum((placed[:n_placed] - candidate) ** 2, axis=1) >= separation**2):
            placed[n_placed] = candidate
            n_placed += 1
    if n_placed < count:
        raise ValueError(
            f"only {n_placed} of {count} seeds fit on the dish {separation:.1f} px apart; "
            "use fewer seeds, shorter seeds or a larger frame"
        )
    return placed


def _uniform_in_disc(rng: np.random.Generator, count: int, radius: float) -> np.ndarray:
    # sqrt makes the density uniform over the area rather than over the radius.
    r = radius * np.sqrt(rng.random(count))
    theta = rng.uniform(0, 2 * np.pi, count)
    return np.column_stack([r * np.cos(theta), r * np.sin(theta)])


def _dish_angles(rng: np.random.Generator, frames: int, omega: float, jitter: float) -> np.ndarray:
    """Cumulative dish angle (radians) at each frame, starting at 0."""
    steps = omega * (1 + jitter * rng.standard_normal(frames - 1))
    return np.concatenate([[0.0], np.cumsum(steps)])


def _rotate(points: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rotate (n, 2) points by each of (f,) angles about the origin; returns (n, f, 2)."""
    cos, sin = np.cos(angle)[None, :], np.sin(angle)[None, :]
    x, y = points[:, 0:1], points[:, 1:2]
    return np.stack([x * cos - y * sin, x * sin + y * cos], axis=-1)


def _empty_dish(width: int, height: int, centre: np.ndarray, radius: float, illumination: float) -> np.ndarray:
    """The light dish on a dark background, dimmer towards its rim and to one side."""
    y, x = np.mgrid[0:height, 0:width].astype(np.float32)
    dx, dy = (x - np.float32(centre[0])) / radius, (y - np.float32(centre[1])) / radius
    rho2 = dx * dx + dy * dy
    # Half vignette, half a gradient towards the bottom right: both between 0 and 1 on the dish.
    dimming = 0.5 * rho2 + 0.25 * (1 + (dx + dy) / np.float32(math.sqrt(2)))
    dish = _DISH_GREY_BRIGHTEST - illumination * dimming
    # Anti-aliased rim: the fraction of each pixel inside the dish, to first order.
    inside = np.clip(radius - np.sqrt(rho2) * radius + 0.5, 0, 1)
    return (_BACKGROUND_GREY + inside * (dish - _BACKGROUND_GREY)).astype(np.float32)


def _contact_distance(a: float, b: float, relative: np.ndarray, side: np.ndarray) -> np.ndarray:
    """Distance between the centres of two equal ellipses that touch.

    Parameters
    ----------
    a, b : float
        Semi-axes, pixels.
    relative : ndarray, shape (n,)
        Heading of the second ellipse relative to the first, radians.
    side : ndarray, shape (n,)
        Direction from the first centre to the second, relative to the first's heading.

    Returns
    -------
    ndarray, shape (n,)
        Pixels; found by bisection to well below a thousandth of a pixel.
    """
    t = np.linspace(0, 2 * np.pi, 1440, endpoint=False)
    rim_x, rim_y = a * np.cos(t), b * np.sin(t)
    cos, sin = np.cos(relative)[:, None], np.sin(relative)[:, None]
    direction_x, direction_y = np.cos(side)[:, None], np.sin(side)[:, None]

    def overlap(distance: np.ndarray) -> np.ndarray:
        d = distance[:, None]
        # The second's rim in the first's frame, and the first's rim in the second's frame.
        x2, y2 = d * direction_x + rim_x * cos - rim_y * sin, d * direction_y + rim_x * sin + rim_y * cos
        x1, y1 = rim_x - d * direction_x, rim_y - d * direction_y
        u, v = x1 * cos + y1 * sin, -x1 * sin + y1 * cos
        inside_first = ((x2 / a) ** 2 + (y2 / b) ** 2).min(axis=1) < 1
        inside_second = ((u / a) ** 2 + (v / b) ** 2).min(axis=1) < 1
        return inside_first | inside_second

    low, high = np.zeros(relative.size), np.full(relative.size, 2 * a + 1e-6)
    for _ in range(40):
        middle = (low + high) / 2
        apart = ~overlap(middle)
        high = np.where(apart, middle, high)
        low = np.where(apart, low, middle)
    return high


def _place_dust(rng: np.random.Generator, count: int, seeds: np.ndarray, max_radius: float, clearance: float) -> np.ndarray:
    """Dust positions (relative to the centre) at least ``clearance`` from every seed and speck.

    Returns
    -------
    ndarray of float, shape (count, 2)
    """
    placed = np.empty((count, 2))
    n_placed = 0
    for candidate in _uniform_in_disc(rng, count * _CANDIDATES_PER_SEED, max_radius):
        if n_placed == count:
            break
        others = np.concatenate([seeds, placed[:n_placed]])
        if np.all(np.sum((others - candidate) ** 2, axis=1) >= clearance**2):
            placed[n_placed] = candidate
            n_placed += 1
    if n_placed < count:
        raise ValueError(f"only {n_placed} of {count} dust specks fit between the seeds; use fewer")
    return placed


def _add_rim(background: np.ndarray, centre: np.ndarray, radius: float) -> np.ndarray:
    """The dish wall as a dark ring outside the dish, and its shadow falling on the dish from
    the upper left."""
    height, width = background.shape
    y, x = np.mgrid[0:height, 0:width].astype(np.float32)
    dx, dy = x - np.float32(centre[0]), y - np.float32(centre[1])
    rho = np.sqrt(dx * dx + dy * dy)
    # Anti-aliased: the fraction of each pixel inside the ring, to first order.
    ring = np.clip(np.minimum(rho - radius, radius + _RIM_WIDTH - rho) + 0.5, 0, 1)
    toward_light = np.clip(-(dx + dy) / np.maximum(rho, 1) / np.float32(math.sqrt(2)), 0, 1)
    shadow = _SHADOW_DEPTH * toward_light * np.exp(-np.clip(radius - rho, 0, None) / _SHADOW_FADE) * (rho < radius)
    dish = background - shadow
    return (dish + ring * (_RIM_GREY - dish)).astype(np.float32)


def _glare(
    rng: np.random.Generator, count: int, width: int, height: int, centre: np.ndarray, radius: float
) -> np.ndarray:
    """Light of ``count`` Gaussian glare spots on the dish, grey levels, shape (height, width)."""
    spots = centre + _uniform_in_disc(rng, count, 0.9 * radius)
    sigma = rng.uniform(*_GLARE_SIGMA_RANGE, count)
    grey = rng.uniform(*_GLARE_GREY_RANGE, count)
    y, x = np.mgrid[0:height, 0:width].astype(np.float32)
    light = np.zeros((height, width), np.float32)
    for (cx, cy), s, g in zip(spots, sigma, grey):
        light += np.float32(g) * np.exp(-((x - np.float32(cx)) ** 2 + (y - np.float32(cy)) ** 2) / np.float32(2 * s * s))
    return light


def _draw_ellipses(
    background: np.ndarray, xy: np.ndarray, orientation: np.ndarray, grey: np.ndarray, a: np.ndarray, b: np.ndarray
) -> np.ndarray:
    """Blend ellipses (seeds, dust) into a copy of ``background`` by their exact pixel coverage.

    Parameters
    ----------
    xy : ndarray, shape (n, 2)
        Centres, pixels.
    orientation : ndarray, shape (n,)
        Long-axis angles, radians.
    grey : ndarray, shape (n,)
        Grey level of each body.
    a, b : ndarray, shape (n,)
        Semi-axes, pixels.

    Returns
    -------
    ndarray of float32, shape (height, width)
    """
    height, width = background.shape
    half = int(math.ceil(a.max(initial=0.0))) + 2
    offsets = np.arange(-half, half + 1)
    # Each ellipse gets a square patch of pixels around the pixel nearest its centre.
    columns = np.rint(xy[:, 0])[:, None].astype(int) + offsets
    rows = np.rint(xy[:, 1])[:, None].astype(int) + offsets
    coverage = _ellipse_coverage(columns, rows, xy, orientation, a, b)
    inside = ((columns >= 0) & (columns < width))[:, None, :] & ((rows >= 0) & (rows < height))[:, :, None]
    flat = (np.clip(rows, 0, height - 1)[:, :, None] * width + np.clip(columns, 0, width - 1)[:, None, :])[inside]
    covered = np.bincount(flat, weights=coverage[inside], minlength=height * width)
    ink = np.bincount(flat, weights=(coverage * grey[:, None, None])[inside], minlength=height * width)
    # Ellipses never overlap (placement keeps them apart or exactly touching), so coverage
    # sums to at most 1 but for rounding where two touch.
    image = background.ravel() * np.clip(1 - covered, 0, 1) + ink
    return image.reshape(height, width).astype(np.float32)


def _ellipse_coverage(
    columns: np.ndarray, rows: np.ndarray, xy: np.ndarray, orientation: np.ndarray, a: np.ndarray, b: np.ndarray
) -> np.ndarray:
    """Fraction of each patch pixel covered by each seed's ellipse.

    Parameters
    ----------
    columns, rows : ndarray of int, shape (n, p)
        Pixel columns and rows of each seed's patch.
    xy : ndarray, shape (n, 2)
        Ellipse centres in pixels.
    orientation : ndarray, shape (n,)
        Long-axis angles in radians.
    a, b : ndarray, shape (n,)
        Semi-axes in pixels.

    Returns
    -------
    ndarray, shape (n, p, p)
        Coverage in [0, 1], indexed [seed, row, column].
    """
    s = _SUPERSAMPLING
    n, p = columns.shape
    # Sub-sample k of pixel c sits at c + (k + 0.5) / s - 0.5, so that the samples of a pixel
    # are centred on the pixel centre (integer coordinate).
    sub = (np.arange(s) + 0.5) / s - 0.5
    sx = (columns[:, :, None] + sub).reshape(n, 1, p * s) - xy[:, 0, None, None]
    sy = (rows[:, :, None] + sub).reshape(n, p * s, 1) - xy[:, 1, None, None]
    cos, sin = np.cos(orientation)[:, None, None], np.sin(orientation)[:, None, None]
    a, b = a[:, None, None], b[:, None, None]
    u = (sx * cos + sy * sin) / a
    v = (-sx * sin + sy * cos) / b
    q = np.sqrt(u * u + v * v)
    # Signed distance to the rim to first order, (q - 1) / |grad q|, in pixels; a linear ramp
    # one sub-sample wide anti-aliases each sub-sample so that coverage moves smoothly with
    # sub-pixel shifts instead of in steps.
    gradient = np.sqrt((u / a) ** 2 + (v / b) ** 2) / np.maximum(q, 1e-9)
    distance = (q - 1) / np.maximum(gradient, 1e-9)
    sample_coverage = np.clip(0.5 - distance * s, 0, 1)
    return sample_coverage.reshape(n, p, s, p, s).mean(axis=(2, 4))
