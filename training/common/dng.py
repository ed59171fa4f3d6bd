"""Writing a camera RAW (DNG) of a known linear scene: what the tests, the captures study and the README's example
give ``panolight estimate`` to read back through rawpy (LibRaw). tifffile writes it (a development dependency)."""
from __future__ import annotations

from fractions import Fraction

import numpy as np

XYZ_TO_SRGB = np.array([[3.2404542, -1.5371385, -0.4985314], [-0.9692660, 1.8760108, 0.0415560],
                        [0.0556434, -0.2040259, 1.0572252]])  # the ColorMatrix1 of a sensor that sees linear sRGB


def _rational(v) -> list[int]:
    f = Fraction(float(v)).limit_denominator(1 << 20)
    return [f.numerator, f.denominator]


def mosaic(scene: np.ndarray, scale: float = 1.0, neutral=(0.5, 1.0, 0.8), black: int = 512,
           white: int = 15000) -> np.ndarray:
    """(H, W) uint16 RGGB Bayer counts of the linear sRGB ``scene`` (H, W, 3): each channel's signal scene x scale
    x the as-shot ``neutral`` of the sensor's range (white - black), over ``black``, clipped at ``white``."""
    signal = black + np.asarray(scene, np.float64) * scale * np.asarray(neutral, np.float64) * (white - black)
    signal = np.clip(signal, 0, white)
    cfa = np.empty(signal.shape[:2])
    cfa[0::2, 0::2] = signal[0::2, 0::2, 0]
    cfa[0::2, 1::2] = signal[0::2, 1::2, 1]
    cfa[1::2, 0::2] = signal[1::2, 0::2, 1]
    cfa[1::2, 1::2] = signal[1::2, 1::2, 2]
    return np.round(cfa).astype(np.uint16)


def write_dng(path, scene, *, scale: float = 1.0, neutral=(0.5, 1.0, 0.8), black: int = 512, white: int = 15000,
              time_s: float | None = None, f_number: float | None = None, orientation: int = 1) -> str:
    """Write a DNG of the linear sRGB ``scene`` (H, W, 3; H and W even) as an RGGB sensor records it (``mosaic``).
    LibRaw, white-balancing by ``neutral``, gives back scene x scale, clipped at 1 (the sensor's white) where the
    least-amplified channel clips. ``time_s`` / ``f_number``: the exposure the file records. ``orientation``:
    TIFF's (6: the stored mosaic is shown turned 90 degrees clockwise). Returns the path as a string."""
    import tifffile

    tags = [(271, "s", 0, "PanoLight", True), (272, "s", 0, "Test sensor", True),
            (274, "H", 1, (orientation,), True),
            (33421, "H", 2, (2, 2), True), (33422, "B", 4, (0, 1, 1, 2), True),  # a 2 x 2 RGGB pattern
            (50706, "B", 4, (1, 4, 0, 0), True), (50707, "B", 4, (1, 1, 0, 0), True),  # DNG 1.4, readable as 1.1
            (50708, "s", 0, "PanoLight test sensor", True), (50714, "H", 1, (black,), True),
            (50717, "I", 1, (white,), True),
            (50721, "2i", 9, sum((_rational(v) for v in XYZ_TO_SRGB.ravel()), []), True),
            (50778, "H", 1, (21,), True),  # calibrated under D65
            (50728, "2I", 3, sum((_rational(v) for v in neutral), []), True)]  # AsShotNeutral
    if time_s is not None:
        tags.append((33434, "2I", 1, _rational(time_s), True))
    if f_number is not None:
        tags.append((33437, "2I", 1, _rational(f_number), True))
    tifffile.imwrite(path, mosaic(scene, scale, neutral, black, white), photometric=32803, extratags=tags,
                     subfiletype=0)
    return str(path)
