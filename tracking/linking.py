"""GOA tracking fitted to the motion of the points: the one path that the command, the Python
API, :func:`seedtrack.tracking.trackers.run_tracker` and the experiments all take.

The decision is made from the measurements alone (:func:`seedtrack.tracking.regime.choose_motion`):
smooth motion keeps the smooth-motion model IM2 with no speed limit; random motion is tracked by
nearest neighbour within a speed limit about the common drift, in a frame moving with that drift.
GOA given the same points with and without this step can differ completely: on random walkers
IM2 follows chance alignments from one neighbour to the next.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Sequence

import numpy as np

from .gap_closing import split_through_held
from .goa import GOAConfig, Progress, goa, goa_updown, initial_links
from .goa import pass_steps as _updown_steps
from .lifecycle import LifecycleConfig, goa_updown_open
from .adaptive import REFITS, head_slaves, sample_frames, track_measured_motion
from .regime import MotionFit, choose_motion, fit_motion, track_without_drift
from .tracks import Tracks, point_frames

GOA_FAMILY = ("goa", "goa-updown", "goa-updown-fixed")


def fit_to_motion(frames: Sequence[np.ndarray], config: GOAConfig = GOAConfig(), motion: str = "auto", keep_model: bool = False) -> MotionFit:
    """Measure how the points move and fit ``config`` to it.

    Parameters
    ----------
    frames : sequence of ndarray, each (M_k, 2)
        Positions (x, y) per frame, pixels, consecutive frames.
    config : GOAConfig
        What the user set; a speed limit given bounds the steps about the drift.
    motion : {"auto", "smooth", "random"}
        "auto" measures; the others say what the motion is.
    keep_model : bool
        Keep ``config``'s individual model (the user chose it) whatever the motion.

    Examples
    --------
    >>> from seedtrack.data.walkers import WalkerSpec, generate_walkers
    >>> frames, _ = generate_walkers(WalkerSpec(walkers=200, frames=10, random_seed=1))
    >>> fit_to_motion(frames).config.individual.name
    'im1'
    """
    choice = choose_motion(frames, motion)
    fitted, drift = fit_motion(config, choice, keep_model)
    return MotionFit(choice, fitted, drift)


def link_goa(
    frames: Sequence[np.ndarray],
    algorithm: str = "goa-updown",
    config: GOAConfig = GOAConfig(),
    lifecycle: LifecycleConfig | None = LifecycleConfig(),
    motion: str = "auto",
    keep_model: bool = False,
    first_frame: int = 0,
    progress: Progress | None = None,
    first_links: np.ndarray | None = None,
) -> tuple[Tracks, MotionFit]:
    """Track points with a GOA tracker fitted to their motion.

    Parameters
    ----------
    frames : sequence of ndarray, each (M_k, 2)
        Positions (x, y) per frame, pixels, consecutive frames.
    algorithm : {"goa-updown", "goa-updown-fixed", "goa"}
        GOA-updown whose tracks open and end anywhere (``lifecycle`` None: the paper's fixed
        count of tracks), GOA-updown as published, or GOA's single forward pass from the first
        links ``config`` chooses.
    config : GOAConfig
        Before fitting to the motion (:func:`fit_to_motion`).
    lifecycle : LifecycleConfig or None
        When tracks open and end, for "goa-updown" only.
    motion : {"auto", "smooth", "random"}
    keep_model : bool
        Keep ``config``'s individual model whatever the motion.
    first_frame : int
        0-based frame index of ``frames[0]``.
    progress : callable, optional
        Called with 1 after each step; :func:`pass_steps` calls in all.
    first_links : ndarray of int, shape (n, 2), optional
        For "goa": the first two frames' correspondences (indices into ``frames[0]`` and
        ``frames[1]``, -1 for none), as the paper's protocol gives them, instead of choosing them.

    Returns
    -------
    tracks : Tracks
        In the image frame (the drift put back); column k holds ``frames[k]``.
    fit : MotionFit

    Examples
    --------
    Two points moving right by 2 pixels a frame:

    >>> import numpy as np
    >>> frames = [np.array([[10.0 + 2 * k, 10.0], [10.0 + 2 * k, 40.0]]) for k in range(5)]
    >>> tracks, fit = link_goa(frames)
    >>> tracks.n_tracks
    2
    """
    if algorithm not in GOA_FAMILY:
        raise ValueError(f"algorithm must be one of {', '.join(GOA_FAMILY)}, got {algorithm!r}")
    frames = point_frames(frames)

    def track(moved: list[np.ndarray], fitted: GOAConfig, given: np.ndarray | None = first_links) -> Tracks:
        if algorithm == "goa":
            initial = given if given is not None else initial_links(moved, fitted)
            return goa(moved, initial, fitted, first_frame, progress=progress)
        if algorithm == "goa-updown-fixed" or lifecycle is None:
            return goa_updown(moved, fitted, first_frame, progress=progress)
        kept = lifecycle
        if lifecycle.max_slaves is None:
            kept = replace(lifecycle, max_slaves=head_slaves(fitted, lifecycle.max_gap))
        return goa_updown_open(moved, fitted, kept, first_frame, progress=progress)

    if motion == "auto" and not keep_model:
        # The first links given are the whole clip's first frames', not a sample's.
        tracks, fit = track_measured_motion(frames, config, track, lambda moved, fitted: track(moved, fitted, None))
    else:
        fit = fit_to_motion(frames, config, motion, keep_model)
        tracks = track_without_drift(frames, fit.drift, lambda moved: track(moved, fit.config))
    tracks = _measured_exactly(tracks, frames) if any(fit.drift) else tracks
    # Last, on the positions as reported: a filled-in point never lies on another track's point.
    # Tracks that open and end anywhere only; the paper's forms keep their count of tracks.
    return (split_through_held(tracks) if algorithm == "goa-updown" and lifecycle is not None else tracks), fit


def _measured_exactly(tracks: Tracks, frames: list[np.ndarray]) -> Tracks:
    """``tracks`` with each measured position the measurement itself: moving into the drift's
    frame and back changes the last bits, and a measured point must keep its position.

    The positions are set in place (the tracks are the pass's own), frame by frame: on a million
    points a copy of them and of the frames joined were 31 MB of the peak of seedtrack track.
    """
    held = np.flatnonzero(tracks.point_measurement >= 0)
    held = held[np.argsort(tracks.point_column[held], kind="stable")]
    bounds = np.searchsorted(tracks.point_column[held], np.arange(len(frames) + 1))
    for k, points in enumerate(frames):
        rows = held[bounds[k] : bounds[k + 1]]
        tracks.point_xy[rows] = points[tracks.point_measurement[rows]]
    return tracks


def pass_steps(algorithm: str, counts: Sequence[int], motion: str = "auto", keep_model: bool = False) -> int:
    """Number of progress calls :func:`link_goa` makes for frames of ``counts`` points each: a
    pass's over all of them, and when the motion is measured, 1 + REFITS passes' over the frames
    of the sample (:func:`seedtrack.tracking.adaptive.sample_frames`).

    Example
    -------
    >>> pass_steps("goa-updown", [10] * 30), pass_steps("goa-updown", [10] * 30, motion="random")
    (174, 58)
    """

    def steps(n_frames: int) -> int:
        return max(n_frames - 1, 0) if algorithm == "goa" else _updown_steps(n_frames)

    if motion != "auto" or keep_model:
        return steps(len(counts))
    return (1 + REFITS) * steps(len(sample_frames(counts))) + steps(len(counts))


__all__ = ["GOA_FAMILY", "MotionFit", "fit_to_motion", "link_goa", "pass_steps"]
