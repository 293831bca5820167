"""Tracks drawn over video frames: the overlay of clips, single pictures, summaries and comparisons.

A frame is drawn in three passes: the fading trails of every track (drawn into a colour layer and
an alpha layer, then blended once where the alpha is not zero, which keeps the per-frame cost
proportional to what is drawn rather than to the frame size), then the heads, start and end marks
and ids, then the legend and frame counter. Sizes follow the output frame, so that the same
picture reads at 640x480 and at 4K.
"""

from __future__ import annotations

import functools
import math
import threading
from dataclasses import dataclass
from typing import Iterable, Iterator, Sequence

import cv2
import numpy as np
from PIL import Image, ImageDraw, ImageFont
from scipy.spatial import cKDTree

from seedtrack.tracking.tracks import Tracks

from .errors import UsageError

# Okabe-Ito: distinguishable with the common colour-vision deficiencies (BGR order).
PALETTE_BGR = np.array(
    [
        (0, 159, 230),  # orange
        (233, 180, 86),  # sky blue
        (115, 158, 0),  # bluish green
        (66, 228, 240),  # yellow
        (178, 114, 0),  # blue
        (0, 94, 213),  # vermillion
        (167, 121, 204),  # reddish purple
    ],
    dtype=np.uint8,
)
# Comparison colours: the two track sets in blue and vermillion, their disagreements in yellow,
# the one pair of this palette that no common colour-vision deficiency confuses with the others.
COMPARE_A_BGR = (178, 114, 0)
COMPARE_B_BGR = (0, 94, 213)
WARNING_BGR = (66, 228, 240)
_HALO = (0, 0, 0)
_NEUTRAL = (235, 235, 235)

# Sub-pixel drawing: OpenCV takes integer coordinates scaled by 2**SHIFT.
SHIFT = 4
# Text sizes are given as OpenCV font scales (as cv2.putText takes them); a scale of 1 is a
# TrueType font of this many pixels, about the height OpenCV's Hershey font has at scale 1.
_PIXELS_PER_FONT_SCALE = 30
# Heads are rings this many times the style's radius: the object inside stays visible.
_RING = 1.6
# Start and end marks, in the style's marker sizes.
_MARK_SIZE = 1.6
# A detection this close to a measured track point (pixels) is that point.
FALSE_DETECTION_TOLERANCE = 0.5

# Drawn frames smaller than this show nothing; larger than this exceed what H.264 encoders take
# (level 6.2: 8192 x 4320) and what memory holds per frame.
_SMALLEST_SIDE = 16
_LARGEST_SIDE = 8192


def track_colour(track_id: int) -> tuple[int, int, int]:
    """The BGR colour of a track id; the same id gets the same colour on every run."""
    return tuple(int(c) for c in PALETTE_BGR[int(track_id) % len(PALETTE_BGR)])


def to_fixed(points: np.ndarray) -> np.ndarray:
    """Pixel positions as the int32 fixed-point coordinates OpenCV draws with ``shift=SHIFT``."""
    return np.round(np.asarray(points) * (1 << SHIFT)).astype(np.int32)


def track_links(present: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every link of a track set: each position joined to the same track's previous position.

    A track with frames missing (a file written every few frames, or a tool that bridges gaps)
    is linked across the gap rather than broken.

    Parameters
    ----------
    present : ndarray of bool, shape (n_tracks, n_frames)

    Returns
    -------
    rows, starts, ends : ndarray of int, shape (K,)
        Track row, and the columns where each link starts and ends.
    """
    rows, columns = np.nonzero(present)
    same = rows[1:] == rows[:-1]
    return rows[1:][same], columns[:-1][same], columns[1:][same]


@dataclass(frozen=True)
class View:
    """The part of the input frame shown and its enlargement.

    Attributes
    ----------
    box : tuple of int
        (x0, y0, x1, y1): crop of the input frame in pixels, x1 and y1 exclusive.
    size : tuple of int
        (width, height) of the drawn frame in pixels.
    """

    box: tuple[int, int, int, int]
    size: tuple[int, int]

    @classmethod
    def of(cls, frame_size: tuple[int, int], crop: str | None = None, scale: float = 1.0) -> "View":
        """The view asked for by ``--crop x0,y0,x1,y1`` and ``--scale S`` on frames of ``frame_size``.

        Raises
        ------
        UsageError
            If the crop is malformed or outside the frame, or the scale is not positive.
        """
        width, height = frame_size
        box = (0, 0, width, height) if crop is None else _parse_crop(crop, frame_size)
        if not (scale > 0 and math.isfinite(scale)):
            raise UsageError(f"--scale must be a finite number > 0, got {scale:g}")
        exact = ((box[2] - box[0]) * scale, (box[3] - box[1]) * scale)
        if min(exact) < _SMALLEST_SIDE or max(exact) > _LARGEST_SIDE:
            raise UsageError(
                f"--scale {scale:g} draws {exact[0]:.0f}x{exact[1]:.0f} frames; each side must be {_SMALLEST_SIDE} to "
                f"{_LARGEST_SIDE} pixels (the view is {box[2] - box[0]}x{box[3] - box[1]})"
            )
        return cls(box, (round(exact[0]), round(exact[1])))

    @property
    def _factors(self) -> np.ndarray:
        x0, y0, x1, y1 = self.box
        return np.array([self.size[0] / (x1 - x0), self.size[1] / (y1 - y0)])

    def image(self, frame: np.ndarray) -> np.ndarray:
        """The frame cropped and resized to :attr:`size` (always a new array)."""
        x0, y0, x1, y1 = self.box
        crop = frame[y0:y1, x0:x1]
        if (crop.shape[1], crop.shape[0]) == self.size:
            return crop.copy()
        shrink = self.size[0] < crop.shape[1]
        return cv2.resize(crop, self.size, interpolation=cv2.INTER_AREA if shrink else cv2.INTER_LINEAR)

    def points(self, xy: np.ndarray) -> np.ndarray:
        """Input pixel positions (..., 2) in drawn-frame pixels; pixel centres map to pixel centres."""
        return (np.asarray(xy, float) - np.array(self.box[:2]) + 0.5) * self._factors - 0.5


def _parse_crop(text: str, frame_size: tuple[int, int]) -> tuple[int, int, int, int]:
    try:
        box = tuple(int(part) for part in text.split(","))
    except ValueError:
        box = ()
    width, height = frame_size
    if len(box) != 4:
        raise UsageError(f"--crop must be x0,y0,x1,y1 in whole pixels, got {text!r}")
    x0, y0, x1, y1 = box
    if not (0 <= x0 < x1 <= width and 0 <= y0 < y1 <= height):
        raise UsageError(f"--crop {text} is not a box inside the {width}x{height} frame (x0 < x1 <= {width}, y0 < y1 <= {height})")
    return box


@dataclass(frozen=True)
class Style:
    """Line widths and sizes in drawn-frame pixels, from the frame size (640x480 is the unit)."""

    line: int
    radius: float
    font: float
    text: int
    marker: int

    @classmethod
    def for_size(cls, size: tuple[int, int]) -> "Style":
        unit = min(size) / 480.0
        return cls(
            line=max(1, round(1.5 * unit)),
            radius=max(2.5, 3.5 * unit),
            font=max(0.3, 0.42 * unit),
            text=max(1, round(unit)),
            marker=max(7, round(9 * unit)),
        )


class TrackLayer:
    """One track set prepared for drawing in one view.

    Parameters
    ----------
    tracks : Tracks
    view : View
    trail : int
        Past positions per fading trail (0: heads only).
    labels : bool
        Write each track's id beside its head.
    colour : tuple of int, optional
        One BGR colour for every track (comparisons); by default each track's :func:`track_colour`.
    warnings : ndarray of bool, shape (n_tracks, n_frames), optional
        Links drawn in the warning colour: ``warnings[t, c]`` marks the link ending at column c.
    frame_indices : ndarray of int, optional
        0-based clip frame index of each column; by default column c is ``tracks.first_frame + c``.
    """

    def __init__(
        self,
        tracks: Tracks,
        view: View,
        *,
        trail: int = 10,
        labels: bool = True,
        colour: tuple[int, int, int] | None = None,
        warnings: np.ndarray | None = None,
        frame_indices: np.ndarray | None = None,
    ) -> None:
        # The tracks' points as they are held (sorted by track, then column), never a dense
        # (track, frame) array: on a long clip with many short tracks that would be most of
        # memory. Each frame draws the points of its trail's columns.
        self.xy = view.points(tracks.point_xy)
        self.track = tracks.point_track
        self.point_column = tracks.point_column
        self.hollow = tracks.point_interpolated
        self.by_column = np.argsort(tracks.point_column, kind="stable")
        self.column_starts = np.searchsorted(tracks.point_column[self.by_column], np.arange(tracks.n_frames + 1))
        self.ids = tracks.track_ids
        self.trail = int(trail)
        self.labels = labels
        self.warnings = warnings
        if colour is None:
            self.palette = PALETTE_BGR.astype(int)
            self.colour_index = self.ids % len(PALETTE_BGR)
        else:
            self.palette = np.array([colour])
            self.colour_index = np.zeros(tracks.n_tracks, int)
        self._colours = [tuple(int(c) for c in colour) for colour in self.palette]
        self._link_palette = np.vstack([self.palette, WARNING_BGR])
        self._texts = [str(track_id) for track_id in self.ids]
        n_frames = tracks.n_frames
        self.frame_indices = tracks.first_frame + np.arange(n_frames) if frame_indices is None else np.asarray(frame_indices)
        first, last = tracks.spans()
        self.offsets = tracks.offsets
        # A track cut by the first or last frame of the set has not really started or ended there.
        self.starts = np.flatnonzero(first > 0)
        self.start_column = first[self.starts]
        self.start_xy = self.xy[self.offsets[self.starts]]
        self.ends = np.flatnonzero((last >= 0) & (last < n_frames - 1))
        self.end_column = last[self.ends]
        self.end_xy = self.xy[self.offsets[self.ends + 1] - 1]

    def column(self, frame_index: int) -> int | None:
        """Column holding 0-based clip frame ``frame_index``, or None."""
        column = int(np.searchsorted(self.frame_indices, frame_index))
        return column if column < len(self.frame_indices) and self.frame_indices[column] == frame_index else None

    def segments(self, low: int, high: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Links between present positions from column ``low`` to column ``high`` (see :func:`track_links`).

        Returns
        -------
        rows : ndarray of int, shape (K,)
            Track row of each link.
        ends : ndarray of int, shape (K,)
            Column where each link ends.
        points : ndarray of int32, shape (K, 2, 2)
            Fixed-point start and end of each link.
        """
        # Point order is track then column, as track_links reads a dense window.
        held = np.sort(self.by_column[self.column_starts[low] : self.column_starts[high + 1]])
        track = self.track[held]
        same = track[1:] == track[:-1]
        points = np.stack([self.xy[held[:-1][same]], self.xy[held[1:][same]]], axis=1)
        return track[1:][same], self.point_column[held[1:][same]], to_fixed(points)

    def _at(self, column: int) -> np.ndarray:
        """The points of ``column``, by track."""
        return self.by_column[self.column_starts[column] : self.column_starts[column + 1]]

    def draw(self, canvas: np.ndarray, frame_index: int, style: Style) -> None:
        """Draw trails, heads, marks and ids of frame ``frame_index`` onto ``canvas`` in place."""
        column = self.column(frame_index)
        if column is None:
            return
        low = max(0, column - self.trail)
        if column > low:
            rows, ends, points = self.segments(low, column)
            age = column - ends
            alpha = np.round(255 * (self.trail - age) / self.trail).astype(int)
            warned, group = self._link_colours(rows, ends)
            _draw_faded(canvas, points, group, self._link_palette, alpha, warned, style.line)
        taken = Occupancy(canvas.shape[:2])
        # Starts and ends stay marked for one trail length, so that they are seen for more than a frame.
        self._draw_marks(canvas, column - self.trail, column, style, taken)
        held = self._at(column)
        present = self.track[held]
        heads = self.xy[held]
        draw_heads(canvas, heads, self.colour_index[present], self._colours, self.hollow[held], style)
        if self.labels:
            taken.add_points(heads, ring_radius(style))
            colours = [self._colours[index] for index in self.colour_index[present]]
            _draw_labels(canvas, [self._texts[row] for row in present], heads, colours, style, taken)

    def _draw_marks(self, canvas: np.ndarray, low: int, high: int, style: Style, taken: Occupancy, size: float = _MARK_SIZE, spacing: float = 1.0) -> None:
        """Mark the starts and ends that fall in columns ``low`` to ``high``, each only where no
        mark drawn before it lies within ``spacing`` mark widths: on dense footage they would
        hide the picture, and a sample of them says as much about where tracks begin and end.
        ``size`` is in the style's marker sizes."""
        width = style.marker * size
        half = width * (0.5 + spacing)
        spaced = Occupancy(canvas.shape[:2])
        for rows, columns, places, kind in (
            (self.starts, self.start_column, self.start_xy, cv2.MARKER_TRIANGLE_UP),
            (self.ends, self.end_column, self.end_xy, cv2.MARKER_SQUARE),
        ):
            shown = (columns >= low) & (columns <= high)
            for row, xy in zip(rows[shown], places[shown]):
                x, y = xy
                if spaced.free(x - half, y - half, x + half, y + half, inside=False):
                    spaced.take(x - width / 2, y - width / 2, x + width / 2, y + width / 2)
                    taken.take(x - width / 2, y - width / 2, x + width / 2, y + width / 2)
                    _draw_marker(canvas, xy, self._colour(row), kind, style, size)

    def _link_colours(self, rows: np.ndarray, ends: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Whether each link is a warning, and its index into ``_link_palette`` (warnings last)."""
        warned = self.warnings[rows, ends] if self.warnings is not None else np.zeros(rows.size, bool)
        return warned, np.where(warned, len(self.palette), self.colour_index[rows])

    def _colour(self, row: int) -> tuple[int, int, int]:
        return self._colours[self.colour_index[row]]

    def draw_summary(self, canvas: np.ndarray, style: Style) -> None:
        """Draw every whole trajectory with its start and end marks onto ``canvas`` in place."""
        last = len(self.column_starts) - 2
        rows, ends, points = self.segments(0, last)
        _, group = self._link_colours(rows, ends)
        for index in np.unique(group):
            chosen = group == index
            cv2.polylines(canvas, points[chosen], False, tuple(int(c) for c in self._link_palette[index]), style.line, cv2.LINE_AA, SHIFT)
        taken = Occupancy(canvas.shape[:2])
        # Every start and end of a long clip at once: smaller marks, further apart than in a frame.
        self._draw_marks(canvas, 0, last, style, taken, size=1.0, spacing=2.0)
        if self.labels:
            counts = np.diff(self.offsets)
            # The longest tracks are labelled first: where labels must be left out, the short ones go.
            rows = np.flatnonzero(counts)
            rows = rows[np.argsort(-counts[rows], kind="stable")]
            starts = self.xy[self.offsets[rows]]
            # Ids of whole trajectories crowd more than a frame's: each keeps a label's height clear.
            margin = text_size("0", style.font, style.text)[1]
            _draw_labels(canvas, [self._texts[row] for row in rows], starts, [self._colour(row) for row in rows], style, taken, margin)


def _draw_faded(canvas, points, group, palette, alpha, thick, line) -> None:
    """Draw links whose opacity is ``alpha`` (0-255), blending only the pixels they touch.

    ``points`` are the (K, 2, 2) fixed-point link ends, ``group`` each link's row in ``palette``
    (BGR, at most 255 rows), ``thick`` the links drawn twice as wide (warnings), ``line`` the
    width in pixels. Links are drawn twice into single-channel layers: which palette colour (drawn
    wider, without anti-aliasing, so that it covers every pixel the other reaches) and how opaque
    (anti-aliased, so it alone carries the smooth edges).
    """
    if not len(points):
        return
    inks, opacity = _scratch(canvas.shape[:2])
    try:
        _blend_links(canvas, inks, opacity, points, group, palette, alpha, thick, line)
    finally:
        inks.fill(0)
        opacity.fill(0)


def _blend_links(canvas, inks, opacity, points, group, palette, alpha, thick, line) -> None:
    widths = np.where(thick, 2 * line + 1, line)
    # One call per colour and width, warnings (thick) last so that they lie on top. The kinds are
    # sorted as one number each (both fit in a byte): a set of a Python tuple per link took
    # 0.14 ms of a 7 ms frame (80 trails of 10 links, 640x512), this 0.02 ms.
    kinds, kind = np.unique(((widths > line).astype(np.int64) << 16) | (group.astype(np.int64) << 8) | widths, return_inverse=True)
    for number, code in enumerate(kinds.tolist()):
        cv2.polylines(inks, points[kind.reshape(-1) == number], False, ((code >> 8) & 0xFF) + 1, (code & 0xFF) + 4, cv2.LINE_8, SHIFT)
    # Oldest first, warnings last, so that newer links and warnings lie on top.
    order = np.lexsort((alpha, thick))
    keys = np.stack([thick[order], alpha[order], widths[order]], axis=1)
    boundaries = np.flatnonzero(np.any(np.diff(keys, axis=0) != 0, axis=1)) + 1
    for run in np.split(order, boundaries):
        cv2.polylines(opacity, points[run], False, int(alpha[run[0]]), int(widths[run[0]]), cv2.LINE_AA, SHIFT)
    found = cv2.findNonZero(opacity)
    if found is None:
        return
    xs, ys = found.reshape(-1, 2).T
    flat = ys.astype(np.intp) * canvas.shape[1] + xs
    weight = opacity.reshape(-1).take(flat).astype(np.uint16)[:, None]
    # Index 0 (no ink) takes black, as a pixel outside the colour layer would.
    over = np.vstack([[0, 0, 0], palette]).astype(np.uint16).take(inks.reshape(-1).take(flat), axis=0)
    # Pixels viewed as 3-byte items: gathering and scattering whole pixels is several times
    # faster than indexing rows of a (pixels, 3) array.
    pixels = canvas.reshape(-1, 3).view("V3").reshape(-1)
    under = pixels.take(flat).view(np.uint8).reshape(-1, 3)
    # Integer blending, rounded, so the same on every machine; (v + 1 + (v >> 8)) >> 8 is v // 255
    # for every v below 65536, without a division.
    mixed = under * (255 - weight) + over * weight + 127
    blended = ((mixed + 1 + (mixed >> 8)) >> 8).astype(np.uint8)
    pixels.put(flat, blended.view("V3").reshape(-1))


# Each thread's own layers: frames may be drawn in several threads at once.
_SCRATCH = threading.local()


def _scratch(shape: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
    """Two zeroed uint8 layers of a frame's (height, width), reused from frame to frame by this
    thread (and left zeroed)."""
    layers = getattr(_SCRATCH, "layers", None)
    if layers is None or layers[0].shape != shape:
        _SCRATCH.layers = layers = (np.zeros(shape, np.uint8), np.zeros(shape, np.uint8))
    return layers


def draw_heads(canvas, xy: np.ndarray, groups: np.ndarray, colours: list, hollow: np.ndarray, style: Style) -> None:
    """A ring around each measured position and a dashed ring around each interpolated one, on a
    black halo, so that the object itself stays in sight.

    ``groups`` holds each head's index into ``colours``. Rings are polygons drawn in one call per
    colour, which is much faster than a circle per head.

    Example
    -------
    >>> canvas = np.zeros((40, 40, 3), np.uint8)
    >>> draw_heads(canvas, np.array([[20.0, 20.0]]), np.array([0]), [(0, 255, 0)], np.array([False]), Style.for_size((640, 480)))
    >>> int(canvas[20, 20, 1]), int(canvas[20, 26, 1]) > 100  # the centre left alone, the ring green
    (0, True)
    """
    if not len(xy):
        return
    radius = style.radius * _RING
    # As few vertices as keep the polygon within 0.3 pixels of the circle (an edge of length L
    # bulges L**2 / 8r from it), a multiple of 4 to make whole dashes.
    vertices = 4 * int(np.clip(np.ceil(2 * np.pi * np.sqrt(radius / 2.4) / 4), 3, 16))
    angle = np.linspace(0, 2 * np.pi, vertices, endpoint=False)
    unit = np.column_stack([np.cos(angle), np.sin(angle)]) * radius
    rings = to_fixed(xy[:, None, :] + unit[None])
    # A dashed ring: two edges drawn, two left out, all the way round.
    dash_starts = np.arange(0, vertices, 4)
    dash = (dash_starts[:, None] + np.arange(3)[None]) % vertices
    for chosen, closed in ((~hollow, True), (hollow, False)):
        if not chosen.any():
            continue
        shapes = rings[chosen] if closed else rings[chosen][:, dash].reshape(-1, 3, 2)
        shape_groups = groups[chosen] if closed else np.repeat(groups[chosen], len(dash_starts))
        # The dark halo needs no smooth edge (the coloured ring covers its middle), and drawing it
        # without anti-aliasing halves the cost of the heads.
        cv2.polylines(canvas, shapes, closed, _HALO, style.line + 2, cv2.LINE_8, SHIFT)
        for group in np.unique(shape_groups):
            cv2.polylines(canvas, shapes[shape_groups == group], closed, colours[group], style.line, cv2.LINE_AA, SHIFT)


def ring_radius(style: Style) -> float:
    """Radius of the ring drawn around a head, pixels of the drawn frame.

    Example
    -------
    >>> round(ring_radius(Style.for_size((640, 480))), 1)
    5.6
    """
    return style.radius * _RING


def _draw_marker(canvas, xy, colour, kind: int, style: Style, size: float = 1.6) -> None:
    """A marker ``size`` times the style's marker size, on a black halo."""
    if np.isnan(xy[0]):
        return
    at = (int(round(xy[0])), int(round(xy[1])))
    pixels = int(round(style.marker * size))
    cv2.drawMarker(canvas, at, _HALO, kind, pixels, style.line + 2, cv2.LINE_AA)
    cv2.drawMarker(canvas, at, colour, kind, pixels, style.line, cv2.LINE_AA)


def _draw_labels(canvas, texts: list[str], xy: np.ndarray, colours: list, style: Style, taken: "Occupancy", margin: float = 0.0) -> None:
    """Each text beside its position where it overlaps nothing taken; see :func:`place_labels`."""
    chosen, origins = place_labels(taken, texts, xy, ring_radius(style) + 1, style.font, style.text, margin)
    draw_texts(canvas, [texts[i] for i in chosen], origins, [colours[i] for i in chosen], style.font, style.text)


class Occupancy:
    """Which parts of a picture are taken by marks and labels, on a grid of 2-pixel cells.

    Parameters
    ----------
    shape : tuple of int
        (height, width) of the picture, pixels.

    Example
    -------
    >>> taken = Occupancy((100, 200))
    >>> taken.take(10, 10, 20, 20)
    >>> taken.free(15, 15, 30, 30), taken.free(40, 40, 50, 50)
    (False, True)
    """

    CELL = 2

    def __init__(self, shape: tuple[int, int]) -> None:
        self.shape = shape
        self.grid = np.zeros((shape[0] // self.CELL + 2, shape[1] // self.CELL + 2), bool)

    def _cells(self, x0: float, y0: float, x1: float, y1: float) -> tuple[slice, slice]:
        c = self.CELL
        return slice(max(0, int(y0 // c)), max(0, int(y1 // c) + 1)), slice(max(0, int(x0 // c)), max(0, int(x1 // c) + 1))

    def free(self, x0: float, y0: float, x1: float, y1: float, inside: bool = True) -> bool:
        """Whether the box (pixels, inclusive) overlaps nothing taken (and, if ``inside``, lies
        wholly inside the picture)."""
        if inside and (x0 < 0 or y0 < 0 or x1 >= self.shape[1] or y1 >= self.shape[0]):
            return False
        return not self.grid[self._cells(x0, y0, x1, y1)].any()

    def take(self, x0: float, y0: float, x1: float, y1: float) -> None:
        """Mark the box (pixels, inclusive) as taken."""
        self.grid[self._cells(x0, y0, x1, y1)] = True

    def add_points(self, xy: np.ndarray, radius: float) -> None:
        """Mark a square of half-side ``radius`` around each position as taken."""
        xy = np.asarray(xy, float).reshape(-1, 2)
        xy = xy[np.isfinite(xy).all(axis=1)]
        low = np.maximum(np.floor((xy - radius) / self.CELL).astype(int), 0).tolist()
        # Cut at 0 too: a negative end would count from the far side (a head left of or above
        # a cropped view marked whole rows or columns as taken).
        high = np.maximum(np.floor((xy + radius) / self.CELL).astype(int) + 1, 0).tolist()
        for (x0, y0), (x1, y1) in zip(low, high):
            self.grid[y0:y1, x0:x1] = True


def place_labels(taken: Occupancy, texts: list[str], xy: np.ndarray, gap: float, font: float, thickness: int, margin: float = 0.0) -> tuple[list[int], list[tuple[int, int]]]:
    """Where each label goes: the first free place of four around its position, or nowhere.

    On dense footage labels would cover each other and the objects; a label that finds no free
    place (above right, below right, above left, below left of its position) is left out, so
    that the ones drawn can be read. Labels earlier in ``texts`` are placed first.

    Parameters
    ----------
    taken : Occupancy
        What the labels must not cover; the placed labels are added to it.
    texts : list of str
    xy : ndarray, shape (N, 2)
        Position each label belongs to, pixels.
    gap : float
        Distance kept from the position, pixels.
    font, thickness
        As for :func:`draw_texts`.
    margin : float
        Room kept free around each placed label, pixels: more thins the labels further.

    Returns
    -------
    chosen : list of int
        Index of each placed label.
    origins : list of tuple of int
        Its text origin (left end of the baseline), pixels.

    Example
    -------
    >>> taken = Occupancy((100, 200))
    >>> place_labels(taken, ["7", "7"], np.array([[50.0, 50.0], [50.0, 50.0]]), 4, 0.5, 1)[0]
    [0, 1]
    """
    xy = np.asarray(xy, float).reshape(-1, 2)
    if not len(texts):
        return [], []
    pictures = {text: _halo(text, font, thickness) for text in set(texts)}
    width = np.array([pictures[text][0].shape[1] for text in texts], float)[:, None]
    height = np.array([pictures[text][0].shape[0] for text in texts], float)[:, None]
    x, y = xy[:, :1], xy[:, 1:]
    # The four candidate boxes of every label at once (top-left corners), then one loop that
    # only checks and marks the grid: labels are placed in turn, each after those before it.
    box_x = np.round(np.hstack([x + gap, x + gap, x - gap - width, x - gap - width]))
    box_y = np.round(np.hstack([y - gap - height, y + gap, y - gap - height, y + gap]))
    last_x, last_y = box_x + width - 1, box_y + height - 1
    rows, columns = taken.shape
    fits = np.isfinite(x) & (box_x >= 0) & (box_y >= 0) & (last_x < columns) & (last_y < rows)
    cell = taken.CELL
    spans = [np.floor(values / cell).astype(int) for values in (box_y, last_y, box_x, last_x)]
    wide = [np.floor(values / cell).astype(int) for values in (box_y - margin, last_y + margin, box_x - margin, last_x + margin)]
    spans, wide = [a.tolist() for a in spans], [np.maximum(a, 0).tolist() for a in wide]
    fits, box_x, box_y = fits.tolist(), box_x.tolist(), box_y.tolist()
    grid = taken.grid
    chosen, origins = [], []
    for index, text in enumerate(texts):
        for k in range(4):
            if fits[index][k] and not grid[spans[0][index][k] : spans[1][index][k] + 1, spans[2][index][k] : spans[3][index][k] + 1].any():
                grid[wide[0][index][k] : wide[1][index][k] + 1, wide[2][index][k] : wide[3][index][k] + 1] = True
                _, left, top = pictures[text]
                chosen.append(index)
                origins.append((int(box_x[index][k]) + left, int(box_y[index][k]) + top))
                break
    return chosen, origins


def draw_text(canvas: np.ndarray, text: str, origin: tuple[int, int], colour, font: float, thickness: int, once: bool = False) -> None:
    """Write ``text`` with its baseline starting at ``origin`` (pixels), on a black halo
    (``once``: as :func:`draw_texts`)."""
    draw_texts(canvas, [text], [origin], [colour], font, thickness, once)


def text_size(text: str, font: float, thickness: int = 1) -> tuple[int, int]:
    """(width, height) in pixels of ``text`` as :func:`draw_texts` writes it, halo included.

    Example
    -------
    >>> width, height = text_size("1524", 0.5)
    >>> width > height > 10
    True
    """
    picture, _, _ = _halo(text, font, thickness)
    return picture.shape[1], picture.shape[0]


def draw_texts(canvas: np.ndarray, texts: list[str], origins: list[tuple[int, int]], colours: list, font: float, thickness: int, once: bool = False) -> None:
    """Write each text on ``canvas`` (BGR uint8) with its baseline starting at its origin (pixels),
    on a black halo.

    The glyphs are a TrueType sans-serif (Pillow's own font), whose digits cannot be taken for
    one another or for strokes: OpenCV's Hershey 7 reads as a slash.

    Parameters
    ----------
    font : float
        Size as an OpenCV font scale: 1 is a 30-pixel font.
    thickness : int
        The dark halo around the glyphs is at least ``thickness // 2 + 1`` pixels wide (and a
        tenth of the font size).
    once : bool
        The texts will not be written again (a frame counter): their pictures are not kept for
        the next call, as recurring texts' are (on a long clip, thousands of cached counters
        were most of the memory drawing took).
    """
    height, width = canvas.shape[:2]
    placed = []
    for text, (x, y), colour in zip(texts, origins, colours):
        picture, left, top = _draw_halo(text, font, thickness) if once else _halo(text, font, thickness)
        x0, y0 = x - left, y - top
        x1, y1 = x0 + picture.shape[1], y0 + picture.shape[0]
        cx0, cy0, cx1, cy1 = max(x0, 0), max(y0, 0), min(x1, width), min(y1, height)
        if cx0 < cx1 and cy0 < cy1:
            placed.append((text, picture, (slice(cy0, cy1), slice(cx0, cx1)), (slice(cy0 - y0, cy1 - y0), slice(cx0 - x0, cx1 - x0)), colour))
    # Halos first, the darker of two where they overlap, so that no halo covers another label's glyphs.
    for _, picture, box, clip, _ in placed:
        cv2.min(canvas[box], picture[clip][..., :3], dst=canvas[box])
    for text, picture, box, clip, colour in placed:
        colour = tuple(int(c) for c in colour)
        keep, ink = _glyph_layers(picture, colour) if once else _glyphs(text, font, thickness, colour)
        target = canvas[box]
        cv2.multiply(target, keep[clip], dst=target, scale=1 / 255)
        cv2.add(target, ink[clip], dst=target)


@functools.lru_cache(maxsize=4096)
def _glyphs(text: str, font: float, thickness: int, colour: tuple[int, int, int]) -> tuple[np.ndarray, np.ndarray]:
    """What a pixel under the glyphs keeps of itself (0-255, three channels) and the colour the
    glyphs add (premultiplied by their coverage): writing is then one multiply and one add."""
    return _glyph_layers(_halo(text, font, thickness)[0], colour)


def _glyph_layers(picture: np.ndarray, colour: tuple[int, int, int]) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_glyphs` of a text's :func:`_halo` picture."""
    coverage = picture[..., 3:4].astype(np.uint16)
    keep = np.repeat((255 - coverage).astype(np.uint8), 3, axis=2)
    ink = ((coverage * np.array(colour, np.uint16) + 127) // 255).astype(np.uint8)
    return keep, ink


# A FreeType face is not to be used by two threads at once.
_FONT_LOCK = threading.Lock()


@functools.lru_cache(maxsize=16)
def _truetype(pixels: int) -> ImageFont.FreeTypeFont:
    return ImageFont.load_default(size=pixels)


def _draw_halo(text: str, font: float, thickness: int) -> tuple[np.ndarray, int, int]:
    """``text`` drawn once: channels 0-2 the most each pixel may keep of its brightness (255 - the
    halo), channel 3 the glyphs' coverage (0-255); and the text origin's position in that picture
    (left, top)."""
    pixels = max(6, round(_PIXELS_PER_FONT_SCALE * font))
    # The halo grows with the font, so that large text stands out as well as small.
    reach = max(thickness // 2 + 1, round(pixels / 10))
    pad = reach + 1
    with _FONT_LOCK:
        face = _truetype(pixels)
        left, top, right, bottom = face.getbbox(text, anchor="ls")
        size = (right - left + 2 * pad, bottom - top + 2 * pad)
        written = Image.new("L", size, 0)
        ImageDraw.Draw(written).text((pad - left, pad - top), text, fill=255, font=face, anchor="ls")
    glyphs = np.asarray(written)
    grow = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * reach + 1, 2 * reach + 1))
    keep = 255 - cv2.dilate(glyphs, grow)
    picture = np.dstack([keep, keep, keep, glyphs])
    picture.flags.writeable = False
    return picture, pad - left, pad - top


# Ids recur every frame, hence the cache.
_halo = functools.lru_cache(maxsize=4096)(_draw_halo)


class FalseDetections:
    """Detections that no track holds (false detections), grouped by frame, in drawn-frame pixels.

    Parameters
    ----------
    frame, x, y : ndarray, shape (M,)
        0-based frame index and position (pixels) of every detection.
    tracks : Tracks
    view : View
    frame_indices : ndarray of int, optional
        Clip frame index of each track column; by default ``tracks.first_frame + column``.
    tolerance : float
        A detection within this distance (pixels) of a measured track point in its frame is held.
    """

    def __init__(self, frame, x, y, tracks: Tracks, view: View, frame_indices=None, tolerance: float = FALSE_DETECTION_TOLERANCE) -> None:
        frame = np.asarray(frame, np.int64)
        columns = tracks.first_frame + np.arange(tracks.n_frames) if frame_indices is None else np.asarray(frame_indices)
        measured = ~tracks.point_interpolated
        # Frames become a third coordinate spaced wider than the tolerance, so one tree query
        # matches within frames only.
        spacing = 4.0 * tolerance + 1.0
        held_points = np.column_stack([tracks.point_xy[measured], columns[tracks.point_column[measured]] * spacing])
        queries = np.column_stack([x, y, frame * spacing])
        if len(held_points) and len(queries):
            distance, _ = cKDTree(held_points).query(queries, distance_upper_bound=tolerance)
            free = ~np.isfinite(distance)
        else:
            free = np.ones(len(queries), bool)
        order = np.argsort(frame[free], kind="stable")
        self.frames = frame[free][order]
        self.xy = view.points(np.column_stack([x, y])[free][order])

    def __len__(self) -> int:
        return len(self.frames)

    def draw(self, canvas: np.ndarray, frame_index: int, style: Style) -> None:
        """Mark the false detections of frame ``frame_index`` with a cross, in place."""
        low, high = np.searchsorted(self.frames, [frame_index, frame_index + 1])
        for xy in self.xy[low:high]:
            # Smaller than the track marks: false detections may be many.
            _draw_marker(canvas, xy, _NEUTRAL, cv2.MARKER_TILTED_CROSS, style, size=0.8)


# A legend entry: symbol ("ring", "dashed", "start", "end", "cross" or "line"), BGR colour, text.
LegendEntry = tuple[str, tuple[int, int, int], str]


def track_legend(false_detections: bool) -> list[LegendEntry]:
    """Legend of :meth:`TrackLayer.draw`: what each mark means."""
    entries = [
        ("ring", _NEUTRAL, "measured"),
        ("dashed", _NEUTRAL, "interpolated"),
        ("start", _NEUTRAL, "track start"),
        ("end", _NEUTRAL, "track end"),
    ]
    return entries + [("cross", _NEUTRAL, "false detection")] if false_detections else entries


def draw_legend(canvas: np.ndarray, entries: Sequence[LegendEntry], style: Style) -> None:
    """A small key in the top-right corner on a darkened box, in place."""
    if not entries:
        return
    font = style.font * 0.9
    text_height = text_size("Ag", font, style.text)[1]
    row = int(text_height * 1.4)
    pad = row // 2
    symbol = row
    text_width = max(text_size(text, font, style.text)[0] for _, _, text in entries)
    width = pad * 3 + symbol + text_width
    height = pad * 2 + row * len(entries)
    x0 = max(0, canvas.shape[1] - width - pad)
    box = canvas[pad : pad + height, x0 : x0 + width]
    box[...] = (box.astype(np.uint16) * 2 // 5).astype(np.uint8)
    for index, (kind, colour, text) in enumerate(entries):
        y = pad + pad + row * index + row // 2
        x = x0 + pad + symbol // 2
        if kind == "line":
            cv2.line(canvas, (x - symbol // 2, y), (x + symbol // 2, y), colour, max(2, style.line), cv2.LINE_AA)
        elif kind in ("ring", "dashed"):
            symbol_style = Style(style.line, min(style.radius, symbol / 3 / _RING), style.font, style.text, style.marker)
            draw_heads(canvas, np.array([[x, y]], float), np.zeros(1, int), [colour], np.array([kind == "dashed"]), symbol_style)
        else:
            kinds = {"start": cv2.MARKER_TRIANGLE_UP, "end": cv2.MARKER_SQUARE, "cross": cv2.MARKER_TILTED_CROSS}
            cv2.drawMarker(canvas, (x, y), colour, kinds[kind], int(symbol * 0.6), style.line, cv2.LINE_AA)
        draw_text(canvas, text, (x0 + pad * 2 + symbol, y + text_height // 3), _NEUTRAL, font, style.text)


def annotate(
    image: np.ndarray,
    frame_index: int,
    view: View,
    layers: Sequence[TrackLayer],
    *,
    false_detections: FalseDetections | None = None,
    legend: Sequence[LegendEntry] = (),
    title: str = "",
) -> np.ndarray:
    """One annotated frame: the view of ``image`` with every layer, false detections, legend and counter.

    Parameters
    ----------
    image : ndarray of uint8, shape (H, W, 3) BGR
        The input frame (not modified).
    frame_index : int
        Its 0-based index in the clip, printed in the top-left corner after ``title``.

    Returns
    -------
    ndarray of uint8, shape (view height, view width, 3)
    """
    canvas = np.ascontiguousarray(view.image(image))
    style = Style.for_size(view.size)
    for layer in layers:
        layer.draw(canvas, frame_index, style)
    if false_detections is not None:
        false_detections.draw(canvas, frame_index, style)
    draw_legend(canvas, legend, style)
    _draw_title(canvas, f"{title}frame {frame_index}", style)
    return canvas


def _draw_title(canvas: np.ndarray, text: str, style: Style) -> None:
    text_height = text_size("0", style.font, style.text)[1]
    draw_text(canvas, text, (text_height // 2, text_height), _NEUTRAL, style.font, style.text, once=True)


def annotate_frames(frames: Iterable[tuple[int, np.ndarray]], view: View, layers: Sequence[TrackLayer], **options) -> Iterator[tuple[int, np.ndarray]]:
    """:func:`annotate` every ``(frame_index, image)`` a frame source yields; yields ``(frame_index, annotated)``."""
    for index, image in frames:
        yield index, annotate(image, index, view, layers, **options)


def summary_picture(image: np.ndarray, view: View, layers: Sequence[TrackLayer], title: str = "") -> np.ndarray:
    """Every trajectory of every layer over one frame (the paper's rotating-dish figure).

    Returns
    -------
    ndarray of uint8, shape (view height, view width, 3)
    """
    canvas = view.image(image)
    style = Style.for_size(view.size)
    for layer in layers:
        layer.draw_summary(canvas, style)
    draw_legend(canvas, [("start", _NEUTRAL, "track start"), ("end", _NEUTRAL, "track end")], style)
    if title:
        _draw_title(canvas, title, style)
    return canvas
