"""How much a bracket frame's 8-bit code counts in the merge (``camera.brackets``): the hat, the noise a camera's
curve reads into a code, and which codes the ghost test trusts. Tables by code (256,), read once per pixel."""
from __future__ import annotations

import numpy as np

CLIPPED_CODE = 250  # a channel at this 8-bit code or above is clipped: a JPEG's compression leaves a clipped sun's
# pixels at 250-253 as often as at 255 (noon_grass at -2 ev, q90: 2812 pixels at 254 or more, 3138 at 250), and a
# frame's near-white pixel weighs almost nothing by the hat anyway


def hat(codes: np.ndarray) -> np.ndarray:
    """Debevec's hat weight of 8-bit codes (float32): 1 at 0 rising to 128 at mid-scale and falling again, 0 at
    CLIPPED_CODE or above."""
    z = codes.astype(np.float32)
    return np.where(codes >= CLIPPED_CODE, np.float32(0.0), np.minimum(z + 1.0, 256.0 - z))


def noise_weights(table: np.ndarray) -> np.ndarray:
    """(256,) float32 weights by 8-bit code of a frame decoded through the curve ``table`` (code -> linear radiance):
    the hat (``hat``: nothing from a clipped code, little from the extremes) over the variance a code's noise puts on
    the log radiance it reads, (d ln table / dz)^2 (inverse-variance weighting, as Robertson et al. 2003 and Granados
    et al. 2010 weigh by the curve's own noise). Where the curve is steep in log (the toe of an sRGB or film curve: a
    code of 5 is 1.2x the light of a code of 4) a code's noise is a large error in radiance and weighs little: a short
    frame's dark pixels no longer average their noise into a longer frame's well-exposed ones (fireflies). Scaled to
    at most 1."""
    lt = np.log(np.maximum(np.asarray(table, dtype=np.float64), 1e-12))
    slope = np.maximum(np.gradient(lt), 1e-6)  # d ln E / dz, per code
    w = hat(np.arange(256, dtype=np.uint8)).astype(np.float64) / slope ** 2
    return (w / w.max()).astype(np.float32)


GHOST_RATIO = 2.0  # a pixel whose brightest channel's radiance in a frame is this far from the reference frame's ...
GHOST_CODES = (20, 235)  # ... where both frames see it well exposed (these codes, ``sure_codes``), moved between them
# (a person, a leaf, a wave): that frame gives it nothing. A still scene's frames agree within JPEG's few per cent there
GHOST_NOISE_CODES = 4  # ... and a code is well exposed only where this many codes either way read within GHOST_RATIO:
# in a curve's toe (film's fog at codes 17-21 in Debevec's memorial set: each code 1.4x the last) a code's noise alone
# is a factor 2, and a still pixel at code 20 in the reference had made every well-exposed frame a "ghost"


def sure_codes(table: np.ndarray) -> np.ndarray:
    """(256,) bool: the codes the ghost test trusts for a frame decoded through ``table`` (code -> linear radiance):
    within GHOST_CODES, and where GHOST_NOISE_CODES either way moves the radiance read by less than GHOST_RATIO (a
    curve's toe reads a code's noise as a factor: no evidence of motion)."""
    lt = np.log(np.maximum(np.asarray(table, dtype=np.float64), 1e-12))
    z = np.arange(256)
    n = GHOST_NOISE_CODES
    spread = lt[np.minimum(z + n, 255)] - lt[np.maximum(z - n, 0)]
    return (z >= GHOST_CODES[0]) & (z <= GHOST_CODES[1]) & (spread < np.log(GHOST_RATIO))
