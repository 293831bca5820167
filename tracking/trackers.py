"""Every tracker by name, behind one call: frames and a speed limit in, tracks out.

``seedtrack track --algorithm NAME`` and the experiments pick trackers from here, so each one
is given the same measurements and the same speed limit (d_max, v_max) in the same units. The GOA
family is fitted to the motion of the points first (:func:`seedtrack.tracking.linking.link_goa`),
as the command does, so that a tracker called here gives the command's answer.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from .goa import GOAConfig, goa_updown
from .ipan import IPANConfig, ipan
from .linking import link_goa
from .nn import nearest_neighbour
from .rs import rangarajan_shah
from .ss import sethi_jain
from .tracks import Tracks, link_speed_limit


@dataclass(frozen=True)
class Tracker:
    """A tracker behind the common interface.

    Attributes
    ----------
    name : str
    summary : str
        One line for ``--help``.
    run : callable
        ``run(frames, max_speed, first_frame) -> Tracks``; frames are (M_k, 2) arrays in
        pixels, max_speed is pixels/frame or None when the user gave none.
    """

    name: str
    summary: str
    run: Callable[[Sequence[np.ndarray], float | None, int], Tracks]


def estimate_speed_limit(frames: Sequence[np.ndarray]) -> float:
    """A speed limit for trackers that need one, from the links GOA-updown makes without one.

    GOA-updown hardly depends on d_max, so its links show the speeds in the data; the limit is
    1.5 times their 99th percentile.

    Returns
    -------
    float
        Pixels/frame; 1.0 when there are no links to measure.
    """
    return link_speed_limit(goa_updown(frames))


def _ipan(frames, max_speed, first_frame):
    limit = max_speed if max_speed is not None else estimate_speed_limit(frames)
    return ipan(frames, IPANConfig(v_max=limit), first_frame)


TRACKERS: dict[str, Tracker] = {
    t.name: t
    for t in (
        Tracker(
            "goa-updown",
            "GOA-updown with track initiation and termination: tracks open from leftover points measured in three "
            "frames in a row, end after 10 missed frames, and are joined across gaps of up to 10 frames; the motion "
            "model fitted to the points (smooth: IM2; random: IM1 about the drift)",
            lambda frames, max_speed, first: link_goa(frames, "goa-updown", GOAConfig(d_max=max_speed), first_frame=first)[0],
        ),
        Tracker(
            "goa-updown-fixed",
            "GOA-updown as published (Veenman et al. 2001): one track per point of the first frame, slaves; "
            "the motion model fitted to the points",
            lambda frames, max_speed, first: link_goa(frames, "goa-updown-fixed", GOAConfig(d_max=max_speed), first_frame=first)[0],
        ),
        Tracker(
            "nn",
            "optimal nearest neighbour between consecutive frames; no motion model, no gap closing",
            lambda frames, max_speed, first: nearest_neighbour(frames, max_speed, first),
        ),
        Tracker(
            "ss",
            "Sethi-Jain greedy exchange with Salari-Sethi phantom points (IM2, phi_max 0.1)",
            lambda frames, max_speed, first: sethi_jain(frames, d_max=max_speed, first_frame=first),
        ),
        Tracker(
            "rs",
            "Rangarajan-Shah greedy proximal uniformity (IM3 + CM2), extrapolates occlusions; "
            "with a speed limit it is the paper's RS'",
            lambda frames, max_speed, first: rangarajan_shah(frames, max_speed, first_frame=first),
        ),
        Tracker(
            "ipan",
            "IPAN (Chetverikov-Verestoy): triplet hypotheses, N_ver 2, delta_max 0.6, gaps up to 2 frames; "
            "without a speed limit, one is estimated",
            _ipan,
        ),
    )
}


def run_tracker(name: str, frames: Sequence[np.ndarray], max_speed: float | None = None, first_frame: int = 0) -> Tracks:
    """Run the tracker called ``name``.

    Parameters
    ----------
    name : str
        A key of :data:`TRACKERS`.
    frames : sequence of ndarray, each (M_k, 2)
        Measurement positions per frame (x, y), pixels.
    max_speed : float or None
        Largest speed, pixels/frame (for the GOA family about the drift of random motion);
        None lets each tracker use its default.
    first_frame : int
        0-based frame index of ``frames[0]``.

    Raises
    ------
    KeyError
        If no tracker has that name.
    """
    return TRACKERS[name].run(frames, max_speed, first_frame)


__all__ = ["TRACKERS", "Tracker", "run_tracker", "estimate_speed_limit"]
