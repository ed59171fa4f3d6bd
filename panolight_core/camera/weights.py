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


def weighted_median(values: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """(k,) the weighted median of each column of (n, k) ``values`` under non-negative (n, k) ``weights`` (each column
    holding some weight): the smallest value with at least half the column's weight at or below it."""
    order = np.argsort(values, axis=0, kind="stable")
    v = np.take_along_axis(values, order, axis=0)
    cum = np.cumsum(np.take_along_axis(weights, order, axis=0), axis=0)
    first = np.argmax(cum >= 0.5 * cum[-1:], axis=0)
    return v[first, np.arange(values.shape[1])]


def sure_readings(level: np.ndarray, sure: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """(256 * 256,) float32, read at (the reference's code) x 256 + (the frame's code) of a pixel's brightest channel:
    the radiance ``level`` (256,) the frame's code reads, where ``outlying_frames`` trusts it (a ``sure_codes`` code,
    ``sure``, that the frame's merge weight table ``weight``, of the same index, weighs), NaN elsewhere."""
    ok = np.asarray(sure, bool)[None, :] & (np.asarray(weight).reshape(256, 256) > 0)
    return np.where(ok, np.asarray(level, np.float32)[None, :], np.float32(np.nan)).astype(np.float32).ravel()


def outlying_frames(readings, weights, ref: int):
    """Per frame, None or the (n, W) bool pixels of a ``merge_brackets`` block where the frame's reading is an outlier:
    trusted there yet GHOST_RATIO off the weighted median of the trusted readings of every frame. ``readings[i]``
    (n, W) float32: frame i's brightest-channel radiance where the frame sees the pixel well exposed and weighs it
    (``sure_readings``), NaN elsewhere; ``weights[i]`` its (n, W) merge weights. A speck of dust, a scanner's edge
    or a hot pixel is one frame's reading against its neighbours' in exposure, which the ghost test (each frame against
    the reference alone) cannot see where the reference is in its toe. The reference frame is never dropped (what
    moved is the reference's), nor the median's own frame, so every pixel keeps a frame. Only pixels whose trusted
    readings spread over GHOST_RATIO are looked at closely (a few per set)."""
    n = len(readings)
    low, high = readings[0].copy(), readings[0].copy()
    for level in readings[1:]:  # fmin and fmax pass over NaN: the trusted readings' range
        np.fmin(low, level, out=low)
        np.fmax(high, level, out=high)
    spread = high > np.float32(GHOST_RATIO) * low  # two trusted readings that disagree (NaN compares False)
    if not spread.any():
        return None
    values = np.stack([level[spread] for level in readings]).astype(np.float64)
    trusted = ~np.isnan(values)
    weight = np.stack([np.where(trusted[i], weights[i][spread], 0.0) for i in range(n)]).astype(np.float64)
    median = weighted_median(np.where(trusted, values, np.inf), weight)
    off = (weight > 0) & ((values > GHOST_RATIO * median) | (values < median / GHOST_RATIO))
    off[ref] = False
    out = []
    for i in range(n):
        if not off[i].any():
            out.append(None)
            continue
        mask = np.zeros(spread.shape, bool)
        mask[spread] = off[i]
        out.append(mask)
    return out
