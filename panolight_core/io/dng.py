"""Writing a camera RAW (DNG) of a known linear panorama: an RGGB mosaic with its black and white levels, as-shot
white balance, colour matrix and, if asked, a sensor's noise; what the tests, the captures study and the README's
example give ``panolight estimate`` to read back through rawpy (LibRaw). tifffile writes it (installed with the
development extra; an ImportError names it otherwise)."""
from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

import numpy as np

XYZ_TO_SRGB = np.array([[3.2404542, -1.5371385, -0.4985314], [-0.9692660, 1.8760108, 0.0415560],
                        [0.0556434, -0.2040259, 1.0572252]])  # the ColorMatrix1 of a sensor that sees linear sRGB


def _rational(v) -> list[int]:
    f = Fraction(float(v)).limit_denominator(1 << 20)
    return [f.numerator, f.denominator]


FULL_WELL = 30000.0  # electrons at the sensor's white: a current full-frame sensor at base ISO ...
READ_NOISE = 3.0  # ... and its read noise, in electrons


@dataclass(frozen=True)
class Sensor:
    """A sensor's counts: its as-shot neutral (the raw RGB of a white; LibRaw's white balance divides by it), black
    and white levels (14-bit-like by default), and whether the file records that neutral."""

    neutral: tuple = (0.5, 1.0, 0.8)
    black: int = 512
    white: int = 15000
    as_shot: bool = True  # the file records the neutral (AsShotNeutral); False: it records no white balance


def mosaic(scene: np.ndarray, scale: float = 1.0, sensor: Sensor = Sensor(),
           rng: np.random.Generator | None = None) -> np.ndarray:
    """(H, W) uint16 RGGB Bayer counts of the linear sRGB ``scene`` (H, W, 3): each channel's signal scene x scale
    x the ``sensor``'s neutral of its range (white - black), over black, clipped at white. With ``rng``, a sensor's
    noise: photon (Poisson) noise of FULL_WELL electrons at white, and READ_NOISE."""
    black, white = sensor.black, sensor.white
    fraction = np.asarray(scene, np.float64) * scale * np.asarray(sensor.neutral, np.float64)
    cfa = np.empty(fraction.shape[:2])
    cfa[0::2, 0::2] = fraction[0::2, 0::2, 0]
    cfa[0::2, 1::2] = fraction[0::2, 1::2, 1]
    cfa[1::2, 0::2] = fraction[1::2, 0::2, 1]
    cfa[1::2, 1::2] = fraction[1::2, 1::2, 2]
    if rng is not None:  # photons beyond the well are clipped anyway: draw at most twice the well
        electrons = rng.poisson(np.minimum(cfa, 2.0) * FULL_WELL) + rng.normal(0.0, READ_NOISE, cfa.shape)
        cfa = electrons / FULL_WELL
    return np.round(np.clip(black + cfa * (white - black), 0, white)).astype(np.uint16)


def write_dng(path, scene, *, scale: float = 1.0, sensor: Sensor = Sensor(), time_s: float | None = None,
              f_number: float | None = None, orientation: int = 1, rng: np.random.Generator | None = None) -> str:
    """Write a DNG of the linear sRGB ``scene`` (H, W, 3; H and W even) as an RGGB ``sensor`` records it
    (``mosaic``, with its noise where ``rng`` is given). LibRaw, white-balancing by the sensor's neutral, gives back
    scene x scale, clipped at 1 (the sensor's white) where the least-amplified channel clips. ``time_s`` /
    ``f_number``: the exposure the file records. ``orientation``: TIFF's (6: the stored mosaic is shown turned 90
    degrees clockwise). Returns the path as a string."""
    neutral, black, white = sensor.neutral, sensor.black, sensor.white
    try:
        import tifffile
    except ImportError:
        raise ImportError("writing a DNG needs tifffile: pip install tifffile (or the 'dev' extra)") from None

    tags = [(271, "s", 0, "PanoLight", True), (272, "s", 0, "Test sensor", True),
            (274, "H", 1, (orientation,), True),
            (33421, "H", 2, (2, 2), True), (33422, "B", 4, (0, 1, 1, 2), True),  # a 2 x 2 RGGB pattern
            (50706, "B", 4, (1, 4, 0, 0), True), (50707, "B", 4, (1, 1, 0, 0), True),  # DNG 1.4, readable as 1.1
            (50708, "s", 0, "PanoLight test sensor", True), (50714, "H", 1, (black,), True),
            (50717, "I", 1, (white,), True),
            (50721, "2i", 9, sum((_rational(v) for v in XYZ_TO_SRGB.ravel()), []), True),
            (50778, "H", 1, (21,), True)]  # calibrated under D65
    if sensor.as_shot:
        tags.append((50728, "2I", 3, sum((_rational(v) for v in neutral), []), True))  # AsShotNeutral
    if time_s is not None:
        tags.append((33434, "2I", 1, _rational(time_s), True))
    if f_number is not None:
        tags.append((33437, "2I", 1, _rational(f_number), True))
    tifffile.imwrite(path, mosaic(scene, scale, sensor, rng), photometric=32803, extratags=tags,
                     subfiletype=0)
    return str(path)
