"""Generated frames of Gaussian spots of known position, as in the ISBI particle tracking challenge.

Spots are Gaussian (point spread function of standard deviation ``sigma``) on a flat background,
imaged with Poisson (shot) noise and Gaussian read noise. The signal-to-noise ratio is, as in the
challenge (Chenouard et al., Nature Methods 11, 281, 2014), the spot's peak above the background
over the noise's standard deviation at the peak: SNR = A / sqrt(background + A + read_noise^2). Some spots
lie in touching pairs (centres ``touching_distance`` sigmas apart), and some are out of focus: a
bright core inside a dark ring, as a defocused bead shows under bright-field light. Positions
are in pixels, x to the right and y down, pixel centres at integer coordinates.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class SpotFieldSpec:
    """What to generate.

    Attributes
    ----------
    width, height : int
        Frame size, pixels.
    spots : int
        Spots per frame, touching and out-of-focus ones included.
    touching_pairs : int
        Pairs of spots whose centres lie ``touching_distance`` sigmas apart.
    rings : int
        Out-of-focus spots: a core of ``sigma`` inside a dark ring of radius 3 sigma.
    sigma : float
        Standard deviation of a spot, pixels.
    snr : float
        Peak above the background over the noise's standard deviation at the peak.
    background : float
        Background level, photons per pixel.
    read_noise : float
        Standard deviation of the read noise, photons.
    touching_distance : float
        Distance between the centres of a touching pair, sigmas.
    random_seed : int
    """

    width: int = 512
    height: int = 512
    spots: int = 200
    touching_pairs: int = 10
    rings: int = 10
    sigma: float = 1.5
    snr: float = 4.0
    background: float = 10.0
    read_noise: float = 1.0
    touching_distance: float = 4.0
    random_seed: int = 0

    def __post_init__(self) -> None:
        if 2 * self.touching_pairs + self.rings > self.spots:
            raise ValueError("touching pairs and rings are more than the spots")
        if not (self.sigma > 0 and self.snr > 0 and self.background >= 0 and self.read_noise >= 0):
            raise ValueError("sigma and snr must be > 0, background and read_noise >= 0")


@dataclass(frozen=True, eq=False)
class SpotField:
    """A generated frame and its truth.

    Attributes
    ----------
    image : ndarray of float32, shape (height, width)
        Photons counted per pixel.
    xy : ndarray of float, shape (spots, 2)
        True centres, pixels.
    kind : ndarray of str, shape (spots,)
        "single", "touching" or "ring".
    """

    image: np.ndarray
    xy: np.ndarray
    kind: np.ndarray


def make_spot_field(spec: SpotFieldSpec) -> SpotField:
    """Generate one frame of spots (same spec, same frame).

    Example
    -------
    >>> field = make_spot_field(SpotFieldSpec(width=64, height=64, spots=4, touching_pairs=1, rings=1))
    >>> field.image.shape, field.xy.shape, sorted(set(field.kind.tolist()))
    ((64, 64), (4, 2), ['ring', 'single', 'touching'])
    """
    rng = np.random.default_rng(spec.random_seed)
    margin = 6 * spec.sigma
    apart = 8 * spec.sigma
    # Spots placed apart: first the anchors of the touching pairs, last the rings.
    placed = spec.spots - spec.touching_pairs
    centres = _dart_throw(rng, placed, spec.width, spec.height, margin, apart)
    kind = np.array(["single"] * placed, dtype=object)
    kind[placed - spec.rings :] = "ring"
    # Partners of the first spots, touching them in a random direction.
    angle = rng.uniform(0, 2 * np.pi, spec.touching_pairs)
    partners = centres[: spec.touching_pairs] + spec.touching_distance * spec.sigma * np.column_stack((np.cos(angle), np.sin(angle)))
    kind[: spec.touching_pairs] = "touching"
    xy = np.concatenate([centres, partners])
    kind = np.concatenate([kind, np.array(["touching"] * spec.touching_pairs, dtype=object)])
    # A = snr * sqrt(background + A + read^2), solved for A.
    floor = spec.background + spec.read_noise**2
    amplitude = (spec.snr**2 + np.sqrt(spec.snr**4 + 4 * spec.snr**2 * floor)) / 2
    rows, columns = np.mgrid[0 : spec.height, 0 : spec.width].astype(np.float32)
    photons = np.full((spec.height, spec.width), spec.background, np.float32)
    reach = int(np.ceil(5 * spec.sigma))
    for (x, y), what in zip(xy, kind):
        r0, c0 = int(round(y)), int(round(x))
        box = (slice(max(r0 - 2 * reach, 0), r0 + 2 * reach + 1), slice(max(c0 - 2 * reach, 0), c0 + 2 * reach + 1))
        squared = (columns[box] - x) ** 2 + (rows[box] - y) ** 2
        photons[box] += amplitude * np.exp(-squared / (2 * spec.sigma**2))
        if what == "ring":
            # The dark ring takes off about as much light as the core brings.
            ring = np.exp(-((np.sqrt(squared) - 3 * spec.sigma) ** 2) / (2 * (0.8 * spec.sigma) ** 2))
            photons[box] -= 0.5 * amplitude * ring
    image = rng.poisson(np.maximum(photons, 0)).astype(np.float32) + rng.normal(0, spec.read_noise, photons.shape).astype(np.float32)
    return SpotField(image=image, xy=xy, kind=kind.astype(str))


def _dart_throw(rng: np.random.Generator, count: int, width: int, height: int, margin: float, apart: float) -> np.ndarray:
    placed: list[np.ndarray] = []
    for candidate in np.column_stack((rng.uniform(margin, width - 1 - margin, 200 * count), rng.uniform(margin, height - 1 - margin, 200 * count))):
        if len(placed) == count:
            break
        if not placed or np.min(np.sum((np.array(placed) - candidate) ** 2, axis=1)) >= apart**2:
            placed.append(candidate)
    if len(placed) < count:
        raise ValueError(f"only {len(placed)} of {count} spots fit {apart:.1f} px apart")
    return np.array(placed)
