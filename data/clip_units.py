"""The physical units a clip carries: a TIFF's resolution tags, a video's frame rate.

TIFF: ImageJ (and Fiji, and tifffile with ``imagej=True``) writes the pixel size as
``XResolution``/``YResolution`` (pixels per unit) with the unit and the frame interval in the
``ImageDescription`` (``unit=micron``, ``finterval=0.5``, ``tunit=sec``). Without an ImageJ unit,
a resolution in pixels per centimetre is read as a calibration; one per inch is not, since
that is the print size every image editor writes (72 or 300 dpi), not a microscope's
calibration. Video: the frame interval is 1 / frame rate, in seconds, but only when asked for
(videos always carry a rate, often a nominal one), so pixels and frames stay the default.
"""

from __future__ import annotations

import os
from pathlib import Path

from .calibration import Calibration
from .frames import IMAGE_SUFFIXES, TIFF_SUFFIXES

_X_RESOLUTION, _Y_RESOLUTION, _RESOLUTION_UNIT, _DESCRIPTION = 282, 283, 296, 270
_CENTIMETRE = 3


def tiff_calibration(path: str | os.PathLike) -> Calibration:
    """The calibration of a TIFF's first page; pixels and frames when it gives none (or the
    file is not a TIFF).

    Example
    -------
    >>> tiff_calibration("clip.mp4")
    Calibration(pixel_size=1.0, space_unit='pixel', frame_interval=1.0, time_unit='frame')
    """
    path = Path(path)
    if path.suffix.lower() not in TIFF_SUFFIXES or not path.is_file():
        return Calibration()
    from PIL import Image

    try:
        with Image.open(path) as image:
            tags = dict(image.tag_v2)
    except (OSError, ValueError):
        return Calibration()
    try:
        return _calibration(tags)
    except ValueError:  # a size or interval no clip has (1e-20 um a pixel): no calibration
        return Calibration()


def _calibration(tags: dict) -> Calibration:
    description = _imagej_fields(str(tags.get(_DESCRIPTION, "")))
    units = Calibration()
    resolution = float(tags.get(_X_RESOLUTION, 0) or 0)
    # ImageJ writes micrometres as the escape \u00B5m.
    unit = description["unit"].replace("\\u00B5", "µ") if "unit" in description else None
    if resolution > 0:
        if unit and unit.lower() not in ("pixel", "pixels"):
            units = units.overridden(pixel_size=1.0 / resolution, space_unit=unit)
        elif unit is None and tags.get(_RESOLUTION_UNIT) == _CENTIMETRE:
            units = units.overridden(pixel_size=1e4 / resolution, space_unit="um")
    interval = _number(description.get("finterval"))
    if interval is not None and interval > 0:
        units = units.overridden(frame_interval=interval, time_unit=description.get("tunit", "s") or "s")
    return units


def clip_calibration(path: str | os.PathLike) -> Calibration:
    """The units a clip gives, asked for explicitly (``analyze --clip``): a TIFF's calibration,
    or a video's frame interval (1 / its frame rate, seconds); pixels and frames for images.

    Raises
    ------
    DataError
        If a video cannot be opened.
    """
    path = Path(path)
    if path.suffix.lower() in IMAGE_SUFFIXES or not path.is_file():  # images, folders, patterns
        return tiff_calibration(path)
    from .video import probe_video

    return video_calibration(probe_video(path).fps)


def video_calibration(fps: float) -> Calibration:
    """Frames ``1 / fps`` seconds apart; pixels stay pixels.

    Example
    -------
    >>> video_calibration(25.0).frame_interval
    0.04
    """
    return Calibration().overridden(frame_interval=1.0 / fps, time_unit="s")


def _imagej_fields(description: str) -> dict[str, str]:
    if not description.startswith("ImageJ="):
        return {}
    return dict(line.split("=", 1) for line in description.splitlines() if "=" in line)


def _number(text: str | None) -> float | None:
    try:
        return float(text) if text is not None else None
    except ValueError:
        return None
