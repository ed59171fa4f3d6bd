"""Recovering the energy an LDR panorama clipped (sun, lamps, bright windows).

An 8-bit panorama stores nothing above its clip level, so the lost energy has to come from a model.
PanoLight's is physical and has no fitted constants, so users can judge it:

Around a compact bright source radiance falls off as a power law of the angle to its centre,
L(t) ~ t^-p (a sun's aureole, a lamp's glare). A clipped blob of solid angle O has an equivalent radius
t_c = sqrt(O / pi), where the true radiance crosses the clip level 1. The unclipped ring
t_c < t < 3 t_c around it gives p (weighted least squares of log L on log t, clamped to 0..4) and the
source colour. Integrating the law inside the blob, down to a core of 0.27 degrees (the sun's angular
radius) where it is held flat, gives the blob's energy and so its mean radiance G >= 1, which fills
the blob in the ring's colour. Flat surroundings (p ~ 0: a hard-edged window) give back about the clip
level; steep glare (p ~ 2-3) gives back a bright source; a larger clipped area (a brighter exposure)
extrapolates further.

Known limits: a source with no glare around it (a lamp behind a diffuser, a sun in a clamped HDRI)
is under- or over-estimated, since the ring is all the model sees; training/synth/evaluate.py
reports its behaviour on synthetic skies and rooms. Everything runs on an area-averaged map of
``work_height`` rows (128 by default), so a 16k panorama costs no more than a 1k one beyond decoding.
"""

from __future__ import annotations

import math

import numpy as np

from .. import sh
from ..camera.color import LUMINANCE_WEIGHTS, SRGB8_TO_LINEAR
from ..camera.resample import area_downsample, area_mean_lut, clipped_fractions
from ..errors import PanoLightError
from ..sh.blobs import label_blobs

CLIP_LEVEL = 0.99  # linear value of sRGB 254/255 is 0.991: at or above counts as clipped
CORE_RADIUS = math.radians(0.2666)  # the sun's angular radius
MAX_EXPONENT = 4.0
RING_FACTOR = 3.0
RING_GAP = 1.0  # work cells skipped between a blob's edge and its ring: edge cells are partly clipped and JPEG rings within a block of a clipped edge
MAX_FITTED_BLOBS = 64  # ring fits for the largest clipped regions; smaller speckles keep the clip level
WORK_HEIGHT = 128  # rows of the per-source model's work map (1.4 degree cells): a 0.5 degree sun still marks its cells


def region_sums(labels: np.ndarray, n: int, *values: np.ndarray) -> list[np.ndarray]:
    """Per region, the sum of each (h, w) or (h, w, k) array over its cells: (n,) or (n, k) each."""
    m = labels >= 0
    lab = labels[m]
    out = []
    for v in values:
        v = v[m]
        out.append(np.bincount(lab, v, n) if v.ndim == 1 else
                   np.stack([np.bincount(lab, v[:, k], n) for k in range(v.shape[1])], -1))
    return out


def region_cells(labels: np.ndarray, n: int) -> list:
    """Each region's cells: n flat index arrays into ``labels`` (h, w), ascending (the map's order, as a
    boolean mask ``labels == i`` selects them), found in one sort instead of n passes over the map."""
    flat = labels.ravel()
    order = np.argsort(flat, kind="stable")
    bounds = np.searchsorted(flat[order], np.arange(n + 1))
    return [order[bounds[i]:bounds[i + 1]] for i in range(n)]


def region_centres(labels: np.ndarray, frac_all: np.ndarray, n: int) -> np.ndarray:
    """(n, 3) unit clipped-area centroid of each region (straight up for a region with none)."""
    h, w = labels.shape
    wc = (sh.pixel_solid_angles(h, w) * frac_all)[..., None] * sh.pixel_directions(h, w)
    centre = region_sums(labels, n, wc)[0]
    norms = np.linalg.norm(centre, axis=1, keepdims=True)
    return np.where(norms > 0, centre / np.maximum(norms, 1e-30), np.array([0.0, 0.0, 1.0]))


def _ring_fit(ang, lum, wts):
    """Weighted least-squares slope of log(lum) on log(ang): returns -slope (the exponent p)."""
    x, y = np.log(ang), np.log(lum)
    sw = wts.sum()
    mx, my = (wts * x).sum() / sw, (wts * y).sum() / sw
    var = (wts * (x - mx) ** 2).sum()
    return 0.0 if var <= 0 else float(-(wts * (x - mx) * (y - my)).sum() / var)


def blob_features(small: np.ndarray, frac: np.ndarray):
    """Clipped blobs of a work-resolution map.

    small: (h, w, 3) area-averaged linear radiance; frac: (h, w) clipped fraction per cell.
    Returns (labels, blobs): labels (h, w) with -1 outside blobs; blobs[i] has direction, solid_angle
    (sr), exponent p and color (unit luminance) of label i (None for a degenerate blob).
    """
    h, w = frac.shape
    mask = frac >= 0.5
    labels, count = label_blobs(mask)
    if count == 0:
        return labels, []
    dirs = sh.pixel_directions(h, w)
    omega = sh.pixel_solid_angles(h, w)
    lum = small @ LUMINANCE_WEIGHTS
    clear = ~mask
    ys, xs = np.nonzero(mask)
    lab = labels[ys, xs]
    weight = omega * frac
    area, centres = region_sums(labels, count, weight, weight[..., None] * dirs)
    row_lo = np.full(count, h)
    row_hi = np.zeros(count, dtype=int)
    np.minimum.at(row_lo, lab, ys)
    np.maximum.at(row_hi, lab, ys)
    d_theta, d_phi = math.pi / h, 2 * math.pi / w
    fitted = set(np.argsort(-area)[:MAX_FITTED_BLOBS].tolist())
    blobs = []
    for b in range(count):
        norm = float(np.linalg.norm(centres[b]))
        if area[b] <= 0 or norm < 1e-9 * area[b] or b not in fitted:
            blobs.append(None)
            continue
        centre = centres[b] / norm
        t_c = min(math.sqrt(area[b] / math.pi), math.pi / 2)
        reach = RING_FACTOR * t_c + d_phi
        pad_gap = RING_GAP * d_theta
        pad = int(math.ceil((reach + pad_gap) / d_theta)) + 1
        rows = np.arange(max(0, row_lo[b] - pad), min(h, row_hi[b] + pad + 1))
        sin_min = max(math.sin(math.pi * (rows[0]) / h), math.sin(math.pi * (rows[-1] + 1) / h), 1e-9) \
            if rows[0] > 0 and rows[-1] < h - 1 else 0.0
        x_c = int(math.floor(float(sh.grid.pixel_coordinates(centre, h, w)[1]) + 0.5)) % w  # its column
        half = w if sin_min <= 0 else int(math.ceil((reach + pad_gap) / (sin_min * d_phi))) + 2
        cols = np.arange(w) if 2 * half + 1 >= w else (x_c + np.arange(-half, half + 1)) % w
        win = np.ix_(rows, cols)
        ang = np.arccos(np.clip(dirs[win] @ centre, -1.0, 1.0))
        ring = clear[win] & (ang > t_c + RING_GAP * d_theta) & (ang < reach + RING_GAP * d_theta) & (lum[win] > 0)
        if ring.sum() >= 3:
            om = omega[win][ring]
            p = float(np.clip(_ring_fit(ang[ring], lum[win][ring], om), 0.0, MAX_EXPONENT))
            color = (small[win][ring] * om[:, None]).sum(0)
            color = color / max(float(color @ LUMINANCE_WEIGHTS), 1e-12)
        else:
            p, color = 0.0, np.ones(3)
        blobs.append({"direction": centre, "solid_angle": float(area[b]), "exponent": p, "color": color})
    return labels, blobs


def power_law_gain(solid_angle: float, exponent: float) -> float:
    """Mean radiance G (clip level = 1) inside a clipped blob under the power-law model.

    L(t) = (t_c / t)^p for CORE_RADIUS < t < t_c (t_c = sqrt(solid_angle / pi), L(t_c) = 1), flat at its
    core value inside CORE_RADIUS; G = energy / solid_angle, at least 1.
    """
    t_c = min(math.sqrt(max(solid_angle, 0.0) / math.pi), math.pi / 2)
    if t_c <= 0:
        return 1.0
    t0 = min(CORE_RADIUS, t_c)
    p = exponent
    if abs(p - 2.0) < 1e-9:
        integral = math.log(t_c / t0)
    else:
        integral = (t_c ** (2.0 - p) - t0 ** (2.0 - p)) / (2.0 - p)
    energy = 2.0 * math.pi * t_c ** p * integral + math.pi * t0 * t0 * (t_c / t0) ** p
    return max(1.0, energy / (math.pi * t_c * t_c))


def work_maps(ldr: np.ndarray, height: int = WORK_HEIGHT):
    """uint8 sRGB (H, W, 3) -> (radiance (h, 2h, 3) float64 linear, any-channel clipped fraction (h, 2h),
    all-channels clipped fraction (h, 2h)), the area means of the sRGB-decoded pixels and of
    ``clipped_mask`` (a channel / every channel at 254 or more), h = min(height, H), by row blocks on every
    thread: a 16K panorama has no room for full-resolution float copies."""
    a = np.asarray(ldr)
    if a.dtype != np.uint8 or a.ndim != 3 or a.shape[-1] != 3:
        raise PanoLightError(f"work maps need (H, W, 3) uint8 sRGB pixels, got {a.dtype} {a.shape}")
    h = min(height, a.shape[0])
    fr = clipped_fractions(a, h)
    return area_mean_lut(a, h, SRGB8_TO_LINEAR), fr[..., 0], fr[..., 1]


def recover_highlights(linear: np.ndarray, work_height: int = 128):
    """Re-inflate clipped regions of an LDR panorama.

    linear: (H, W, 3) uint8 sRGB pixels (preferred: clipping is then exact and the path is fused), or
    float sRGB-linearised values in [0, 1] (pixels >= CLIP_LEVEL count as clipped).
    Returns (map, blobs): map is (work_height, 2 work_height, 3) float64 radiance in the input's
    exposure units (clip level = 1); blobs lists each clipped region's direction, solid angle (sr), ring
    exponent p, colour and recovered mean radiance G, which fills the blob in the ring's colour.
    """
    img = np.asarray(linear)
    if img.dtype == np.uint8:
        rad, frac, _ = work_maps(img, work_height)
    else:
        sat = np.maximum(np.maximum(img[..., 0], img[..., 1]), img[..., 2]) >= CLIP_LEVEL
        rad = area_downsample(img, work_height)
        frac = area_downsample(sat[..., None].astype(np.float32), work_height)[..., 0]
    return recover_work_maps(rad, frac)


def recover_work_maps(rad: np.ndarray, frac: np.ndarray):
    """``recover_highlights`` on work maps already made (``work_maps``): rad (h, 2h, 3) linear
    radiance, updated in place and returned, frac (h, 2h) clipped fraction. Returns (map, blobs)."""
    labels, feats = blob_features(rad, frac)
    if not feats:
        return rad, []
    gain_color = np.zeros((len(feats), 3))
    blobs = []
    for i, f in enumerate(feats):
        if f is None:
            continue
        g = power_law_gain(f["solid_angle"], f["exponent"])
        gain_color[i] = g * f["color"]
        blobs.append({"direction": f["direction"].tolist(), "solid_angle": f["solid_angle"],
                      "exponent": f["exponent"], "color": f["color"].tolist(), "mean_radiance": g})
    m = labels >= 0
    fr = frac[m][:, None]
    rad[m] = np.maximum(rad[m], gain_color[labels[m]] * fr + rad[m] * (1.0 - fr))
    return rad, blobs
