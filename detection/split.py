"""Split blobs of touching objects so that each object gives its own measurement.

A blob is a candidate when its area is well above the frame's typical blob area. Within it the
landscape is the contrast smoothed a little times the distance to the blob's edge: two objects
in contact show two summits, end to end through the narrow neck (distance) and side by side
through the lighter seam between them (contrast). A watershed from summits that stand out
divides the blob.
"""

from __future__ import annotations

import cv2
import numpy as np

# A blob this many times the typical area may hold several objects.
_CANDIDATE_AREA_RATIO = 1.3
# Blobs above this many typical areas are clutter (a rim, a smear), not worth splitting.
_LARGEST_RATIO = 12.0
# Blobs needed in a frame before their median area is trusted as the typical object.
_FEW_BLOBS = 5
# Summits are where the landscape exceeds this fraction of the blob's highest point.
_SUMMIT_LEVEL = 0.3
# Single objects are of one size when the quartiles of blob area differ by less than this ratio.
_UNIFORM_SPREAD = 1.5
# Most objects a blob is divided among by area.
_MOST_IN_CONTACT = 4
# Steps of hard EM when dividing a blob among elliptical objects.
_EM_STEPS = 20
# Blank pixels around each blob in the mosaic of candidates, so that no blob sees another.
_GAP = 6
# Width of a shelf of the mosaic, pixels.
_SHELF = 256
# Every piece must hold at least this fraction of the typical area, or the split is refused.
_SMALLEST_PIECE = 0.4


def split_touching(
    label: np.ndarray,
    count: int,
    inside: np.ndarray,
    shape: tuple[int, int],
    weight: np.ndarray,
    limits: tuple[float, float],
) -> tuple[np.ndarray, int]:
    """Relabel the object pixels so that touching objects get labels of their own.

    Parameters
    ----------
    label : ndarray of int, shape (n,)
        Blob label (1..count-1) of each object pixel.
    count : int
        One more than the largest label.
    inside : ndarray of int, shape (n,)
        Flat index of each object pixel in the frame.
    shape : tuple of int
        (height, width) of the frame.
    weight : ndarray of float, shape (n,)
        Contrast above the threshold of each object pixel.
    limits : tuple of float
        Smallest and largest area of an object, pixels.

    Returns
    -------
    label : ndarray of int, shape (n,)
        New labels; pieces of split blobs get labels from ``count`` on.
    count : int
        One more than the largest new label.
    """
    area = np.bincount(label, minlength=count)
    area[0] = 0
    plausible = area[(area >= max(limits[0], 1)) & (area <= limits[1])]
    if plausible.size < _FEW_BLOBS:
        return label, count
    typical = float(np.median(plausible))
    is_candidate = (area >= _CANDIDATE_AREA_RATIO * typical) & (area <= _LARGEST_RATIO * typical)
    chosen = np.flatnonzero(is_candidate[label])
    if chosen.size == 0:
        return label, count
    # Candidates are cut out and laid side by side in one small mosaic, so that every image
    # operation runs once per frame rather than once per blob.
    blob = label[chosen]
    order = np.argsort(blob, kind="stable")
    chosen, blob = chosen[order], blob[order]
    starts = np.flatnonzero(np.r_[True, blob[1:] != blob[:-1]])
    rows, columns = np.divmod(inside[chosen], shape[1])
    top = np.minimum.reduceat(rows, starts)
    left = np.minimum.reduceat(columns, starts)
    spans = np.maximum.reduceat(columns, starts) - left + 1
    heights = np.maximum.reduceat(rows, starts) - top + 1
    member = np.repeat(np.arange(starts.size), np.diff(np.r_[starts, blob.size]))
    # Shelf packing: cells left to right, a new shelf every _SHELF pixels.
    cell_x = np.r_[0, np.cumsum(spans + _GAP)[:-1]]
    shelf = cell_x // _SHELF
    cell_x = cell_x - shelf * _SHELF + _GAP
    shelf_height = np.zeros(shelf[-1] + 1, np.int64)
    np.maximum.at(shelf_height, shelf, heights)
    shelf_y = np.r_[0, np.cumsum(shelf_height + _GAP)[:-1]] + _GAP
    my = rows - top[member] + shelf_y[shelf][member]
    mx = columns - left[member] + cell_x[member]
    mosaic_shape = (int(shelf_y[-1] + shelf_height[-1] + _GAP), int((cell_x + spans).max() + _GAP))
    inked = np.zeros(mosaic_shape, np.uint8)
    inked[my, mx] = 1
    contrast = np.zeros(mosaic_shape, np.float32)
    contrast[my, mx] = weight[chosen]
    contrast = cv2.GaussianBlur(contrast, (0, 0), 1.0)
    distance = cv2.distanceTransform(inked, cv2.DIST_L2, cv2.DIST_MASK_5)
    landscape = contrast[my, mx] * distance[my, mx]
    # Summits: where the landscape exceeds a fraction of its blob's top; one object gives one
    # connected summit, objects in contact one each, cut apart by the neck or seam between.
    top_of_blob = np.maximum.reduceat(landscape, starts)
    summit = landscape > _SUMMIT_LEVEL * top_of_blob[member]
    summits = np.ones(mosaic_shape, np.uint8)
    summits[my[summit], mx[summit]] = 0
    # Every pixel joins the summit nearest to it (a watershed on the distance to the summits).
    _, nearest = cv2.distanceTransformWithLabels(summits, cv2.DIST_L2, 5, labelType=cv2.DIST_LABEL_CCOMP)
    piece = nearest[my, mx]
    # A pixel far from its own summits may lie nearer another blob's: it joins its blob's
    # first summit instead.
    owner = np.full(int(piece.max()) + 1, -1)
    owner[piece[summit]] = member[summit]
    first_summit = np.full(starts.size, -1)
    first_summit[member[summit][::-1]] = piece[summit][::-1]
    piece = np.where(owner[piece] == member, piece, first_summit[member])
    # Objects in contact at an angle or side by side may leave one summit. When single objects
    # all have about the same area, the area tells how many a blob holds, and the blob is
    # divided among that many elliptical objects.
    low, high = np.percentile(plausible, [25, 75])
    if high <= _UNIFORM_SPREAD * low:
        several = np.flatnonzero(np.rint(area[blob[starts]] / typical) >= 2)
        ends = np.r_[starts[1:], blob.size]
        next_piece = int(piece.max()) + 1
        for b in several:
            span = slice(starts[b], ends[b])
            if np.unique(piece[span]).size > 1:
                continue
            objects = min(int(np.rint(area[blob[starts[b]]] / typical)), _MOST_IN_CONTACT)
            xy = np.column_stack((columns[span], rows[span])).astype(float)
            piece[span] = next_piece + _ellipse_clusters(xy, weight[chosen[span]], objects)
            next_piece += objects
    # (blob, piece) pairs in order; a blob splits if it has several pieces, none too small.
    key = member.astype(np.int64) * (piece.max() + 1) + piece
    pairs, first, size = np.unique(key, return_index=True, return_counts=True)
    pair_blob = member[first]
    pieces_of_blob = np.bincount(pair_blob, minlength=starts.size)
    smallest = np.full(starts.size, np.inf)
    np.minimum.at(smallest, pair_blob, size)
    splits = (pieces_of_blob >= 2) & (smallest >= _SMALLEST_PIECE * typical)
    if not splits.any():
        return label, count
    # The first piece of a split blob keeps its label; the others get new ones.
    is_new = splits[pair_blob] & np.r_[False, pair_blob[1:] == pair_blob[:-1]]
    new_label = np.where(is_new, count + np.cumsum(is_new) - 1, blob[first])
    label = label.copy()
    label[chosen] = new_label[np.searchsorted(pairs, key)]
    return label, count + int(is_new.sum())



def _ellipse_clusters(xy: np.ndarray, weight: np.ndarray, objects: int) -> np.ndarray:
    """Divide one blob's pixels among ``objects`` elliptical objects (hard EM of a Gaussian
    mixture with a covariance of its own per object, started from slices across the blob's
    long axis).

    Returns
    -------
    ndarray of int, shape (n,)
        Object 0..objects-1 of each pixel.
    """
    x, y = xy[:, 0], xy[:, 1]
    centred = xy - np.average(xy, axis=0, weights=weight)
    _, vectors = np.linalg.eigh(np.cov(centred.T, aweights=weight))
    along = centred @ vectors[:, -1]
    ranks = np.argsort(np.argsort(along, kind="stable"), kind="stable")
    group = ranks * objects // len(along)
    for _ in range(_EM_STEPS):
        mass = np.bincount(group, weight, objects)
        if (mass <= 0).any():
            break
        mx, my = np.bincount(group, weight * x, objects) / mass, np.bincount(group, weight * y, objects) / mass
        own_x, own_y = x - mx[group], y - my[group]
        # A pixel is a unit square: its own spread (1/12) keeps each covariance proper.
        sxx = np.bincount(group, weight * own_x * own_x, objects) / mass + 1 / 12
        syy = np.bincount(group, weight * own_y * own_y, objects) / mass + 1 / 12
        sxy = np.bincount(group, weight * own_x * own_y, objects) / mass
        det = sxx * syy - sxy * sxy
        dx, dy = x[:, None] - mx, y[:, None] - my
        cost = (syy * dx * dx - 2 * sxy * dx * dy + sxx * dy * dy) / det + np.log(det)
        new = np.argmin(cost, axis=1)
        if np.array_equal(new, group):
            break
        group = new
    return group
