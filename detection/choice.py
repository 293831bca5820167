"""Which detector suits the footage, decided once per clip from its first frame.

Seeds on a dish are dark, elongated and often touch: the blob detector (threshold and connected
pixels, split where touching) measures them. Beads and fluorescent particles are small, round
and faint, and out-of-focus ones are a bright core in a dark ring: the spot detector
(Crocker and Grier) finds them. The choice looks at the strongest spots of the first frame: if
they are round and small, spots; if they are elongated or large, blobs. It is said in one line,
as the motion decision is.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from .spots import SpotSettings, fit_spot_settings, spot_shape

DETECTOR_NAMES = ("auto", "blob", "spot")
# Objects are elongated when the strongest spots curve this many times more sharply across than
# along, at their own scale (a seed 7 x 3.5 px gives about 1.6, a round bead about 1.2).
_ELONGATED = 1.4
# Spots wider than this are not small: the blob detector measures large objects whole.
_LARGEST_SPOT_PX = 15


@dataclass(frozen=True)
class DetectorChoice:
    """The detector for a clip and why.

    Attributes
    ----------
    name : {"blob", "spot"}
    reason : str
        What was measured, for the first line of output.
    spots : SpotSettings or None
        The spot detector's settings (diameter, least mass), when it is the one chosen.
    """

    name: str
    reason: str
    spots: SpotSettings | None = None


def choose_detector(
    gray: np.ndarray,
    polarity: str,
    *,
    detector: str = "auto",
    diameter: int | None = None,
    roi: np.ndarray | None = None,
    min_mass: float | None = None,
    snr: float | None = None,
    progress: Callable[[str], None] | None = None,
) -> DetectorChoice:
    """The detector for a clip, from its first frame.

    Parameters
    ----------
    gray : ndarray, shape (H, W)
        The first frame, grey, any depth.
    polarity : {"dark", "light"}
        The objects' polarity, already decided.
    detector : {"auto", "blob", "spot"}
        "auto" decides; "blob" or "spot" is taken as given (and said so).
    diameter : int, optional
        The spot diameter, pixels, odd; estimated from the frame when not given.
    roi : ndarray of uint8, shape (H, W), optional
        Nonzero where to look.
    min_mass : float, optional
        The spot detector's least mass (integrated brightness: the band-passed frame summed over
        a spot's disc, data units times pixels, as :func:`describe` prints it), taken instead of
        the one set from the measured noise.
    snr : float, optional
        The spot detector's signal-to-background ratio: the least mass is this many times the
        typical mass of the background's own maxima (see
        :func:`seedtrack.detection.spots.fit_spot_settings`); ``min_mass`` wins when both are given.
    progress : callable, optional
        Called with a few words as each measurement begins (the spots' size and shape, then the
        noise and least mass): each takes seconds on a frame of millions of pixels.

    Returns
    -------
    DetectorChoice

    Example
    -------
    >>> rows, columns = np.mgrid[0:64, 0:64]
    >>> frame = 10 + sum(60 * np.exp(-((columns - x) ** 2 + (rows - y) ** 2) / 4.0) for x, y in ((15, 15), (45, 40)))
    >>> choose_detector(frame.astype(np.float32), "light").name
    'spot'
    """
    if detector not in DETECTOR_NAMES:
        raise ValueError(f"detector must be one of {', '.join(DETECTOR_NAMES)}, got {detector!r}")
    if detector == "blob":
        return DetectorChoice("blob", "blob detector, as asked")
    step = progress or (lambda _: None)
    step("measuring the spots' size")
    shape = spot_shape(gray, polarity, roi)

    def spot_settings() -> SpotSettings:
        # Fitted only for the spot detector: measuring the noise costs a fifth of a second on a
        # 640x512 frame, as long as decoding 60 frames.
        step("measuring the noise and the least mass")
        settings = fit_spot_settings(gray, polarity, diameter=diameter or shape.diameter, roi=roi, snr=snr)
        return settings if min_mass is None else replace(settings, min_mass=float(min_mass))

    if detector == "spot":
        settings = spot_settings()
        return DetectorChoice("spot", f"spot detector, as asked; {describe(settings)}", settings)
    if shape.diameter > _LARGEST_SPOT_PX:
        # Said as the scale-space sigma, not as the spot diameter (6 sigma wide), which is no
        # object's size: a disc of radius r peaks at sigma r / sqrt(2).
        return DetectorChoice("blob", f"objects of scale sigma {shape.sigma:.1f} px (spot diameter {shape.diameter} px, above {_LARGEST_SPOT_PX}), larger than spots: blob detector")
    if shape.elongation > _ELONGATED:
        return DetectorChoice("blob", f"elongated objects ({shape.elongation:.2f} times as sharp across as along): blob detector")
    settings = spot_settings()
    return DetectorChoice("spot", f"small round spots ({shape.elongation:.2f} times as sharp across as along): spot detector, {describe(settings)}", settings)


def describe(settings: SpotSettings) -> str:
    """The spot settings in words: diameter, least mass and, where the background's maxima were
    measured, the signal-to-background ratio it stands for.

    Example
    -------
    >>> describe(SpotSettings(diameter=9, min_mass=40.0, floor=1.5))
    'diameter 9 px, least mass 40 (noise floor 1.5)'
    >>> describe(SpotSettings(diameter=11, min_mass=72.0, floor=0.09, background_mass=25.0))
    'diameter 11 px, least mass 72 = snr 2.88 x background maxima 25 (noise floor 0.09)'
    """
    ratio = f" = snr {settings.min_mass / settings.background_mass:.3g} x background maxima {settings.background_mass:.3g}" if settings.background_mass > 0 else ""
    return f"diameter {settings.diameter} px, least mass {settings.min_mass:.3g}{ratio} (noise floor {settings.floor:.3g})"
