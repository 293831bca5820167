"""Physical units of a clip or a track file: how long a pixel is and how long a frame lasts.

Positions and frames stay pixels and 0-based frame indices everywhere inside seedtrack; a
:class:`Calibration` travels beside them and converts at the edges (analysis tables, TrackMate
files, the overlay's scale bar). It is given by ``--pixel-size``/``--frame-interval`` or read
from the input: a TrackMate file's model units and image settings, a TIFF's resolution tags, a
video's frame rate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

PIXEL, FRAME = "pixel", "frame"
SMALLEST, LARGEST = 1e-12, 1e12


@dataclass(frozen=True)
class Calibration:
    """Length of a pixel and duration of a frame, each with its unit.

    Attributes
    ----------
    pixel_size : float
        Length of one pixel in ``space_unit`` (1.0 with ``"pixel"``: uncalibrated).
    space_unit : str
        ``"pixel"``, or a length unit such as ``"micron"``, ``"um"``, ``"mm"``.
    frame_interval : float
        Time between frames in ``time_unit`` (1.0 with ``"frame"``: uncalibrated).
    time_unit : str
        ``"frame"``, or a time unit such as ``"s"``, ``"sec"``, ``"min"``.

    Example
    -------
    >>> Calibration(0.5, "um", 2.0, "s").length(4.0), Calibration().calibrated
    (2.0, False)
    """

    pixel_size: float = 1.0
    space_unit: str = PIXEL
    frame_interval: float = 1.0
    time_unit: str = FRAME

    def __post_init__(self) -> None:
        for name in ("pixel_size", "frame_interval"):
            value = getattr(self, name)
            # Beyond these, squared lengths (an MSD) of pixel coordinates leave the floats.
            if not (math.isfinite(value) and SMALLEST <= value <= LARGEST):
                raise ValueError(f"{name} must be a positive number from {SMALLEST:g} to {LARGEST:g}, got {value!r}")

    @property
    def calibrated(self) -> bool:
        """Either unit is other than pixels or frames."""
        return self.space_unit != PIXEL or self.time_unit != FRAME

    def length(self, pixels: float):
        """``pixels`` in the space unit."""
        return pixels * self.pixel_size

    def duration(self, frames: float):
        """``frames`` in the time unit."""
        return frames * self.frame_interval

    def overridden(self, pixel_size: float | None = None, space_unit: str | None = None, frame_interval: float | None = None, time_unit: str | None = None) -> "Calibration":
        """This calibration with the values given (by options) in place of those read.

        A pixel size given without a unit makes the unit ``"um"`` if it was pixels; likewise a
        frame interval makes ``"s"``.

        Example
        -------
        >>> Calibration().overridden(pixel_size=0.2)
        Calibration(pixel_size=0.2, space_unit='um', frame_interval=1.0, time_unit='frame')
        """
        changes = {}
        if pixel_size is not None:
            changes["pixel_size"] = pixel_size
            changes["space_unit"] = space_unit or (self.space_unit if self.space_unit != PIXEL else "um")
        elif space_unit is not None:
            changes["space_unit"] = space_unit
        if frame_interval is not None:
            changes["frame_interval"] = frame_interval
            changes["time_unit"] = time_unit or (self.time_unit if self.time_unit != FRAME else "s")
        elif time_unit is not None:
            changes["time_unit"] = time_unit
        return replace(self, **changes)
