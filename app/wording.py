"""What the messages people read say: counts, input kinds, how the points move."""

from __future__ import annotations

import math
import re


def counted(count: int, noun: str, plural: str | None = None) -> str:
    """``"1 frame"``, ``"3 frames"``: the count and the noun, plural (``noun + "s"`` unless
    given) when the count is not one."""
    return f"{count} {noun}" if count == 1 else f"{count} {plural or noun + 's'}"


# What every command's INPUT may be: open_frames (data/frames.py) reads all of them.
CLIP_INPUT_HELP = "video file, TIFF stack (multi-page .tif), image folder or glob pattern such as 'frames/*.png'"


def motion_lines(fit, verbose: bool = False) -> list[str]:
    """What ``track``, ``run`` and ``demo`` say of how the points move: one short ``motion:``
    line on what the tracker uses (a :class:`seedtrack.tracking.regime.MotionFit`); with
    ``verbose`` also the first look at the motion and the whole measurement, each on a line.

    Example
    -------
    >>> from seedtrack.data.walkers import WalkerSpec, generate_walkers
    >>> from seedtrack.tracking.linking import link_goa
    >>> _, fit = link_goa(generate_walkers(WalkerSpec(walkers=100, frames=8, drift=(1.0, 0.0), random_seed=1))[0])
    >>> motion_lines(fit)  # doctest: +ELLIPSIS
    ['motion: random motion (persistence ..., noise ... px/frame, drift (...) px/frame), speed limit ... px/frame']
    """
    config = fit.config
    limit = "no speed limit" if config.d_max is None else f"speed limit {config.d_max:.1f} px/frame"
    drift = f"drift ({fit.drift[0]:.2f}, {fit.drift[1]:.2f}) px/frame" if any(fit.drift) else ""
    if fit.measured is not None:
        # What the final pass tracks with, named from the measured persistence, not from the
        # first look (which may have seen the same points otherwise).
        statistics = config.individual.statistics
        persistence = statistics.persistence
        kind = "smooth" if persistence >= _SMOOTH else "reversing" if persistence <= -_RANDOM else "random" if persistence <= _RANDOM else "partly smooth"
        measured = ", ".join(filter(None, (f"persistence {persistence:.2f}", f"noise {statistics.noise:.2f} px/frame", drift)))
        line = f"motion: {kind} motion ({measured}), {limit}"
        details = [f"  first look, on unambiguous 3-frame chains: {fit.choice.reason}", f"  measured on a first pass, then tracked with: {fit.measured}"]
    else:
        # The first look is what the tracker uses: its verdict, the model and the limit.
        verdict = re.split(r"[:;,]", fit.choice.reason, maxsplit=1)[0]
        line = f"motion: {verdict}, tracked with {config.individual.name.upper()}, {limit}" + (f" about the {drift}" if drift else "")
        details = [f"  {fit.choice.reason}"]
    if fit.measured is not None and config.localisation_error > 0:
        # A given (or measured by the detector) localisation error floors the noise: said, so
        # that a noise printed at the floor is not read as the motion's.
        details.append(f"  localisation error of the points {config.localisation_error:.3f} px per axis: the noise is never fitted below sqrt(6) x that, {math.sqrt(6.0) * config.localisation_error:.2f} px/frame")
    return [line, *details] if verbose else [line]


# Measured velocity persistence at or above which motion is called smooth, at or below which
# random; at or below minus the random bound, steps turn back: reversing.
_SMOOTH = 0.7
_RANDOM = 0.3
