"""Metrics of EVALUATION.md, in float64, in the CONVENTIONS.md frame and basis.

m-RMSE: reconstruct ground truth G and prediction Q on a 256 x 128 grid; s = median(G) / median(Q)
(1 if median(Q) <= 0); m-RMSE = sqrt(sum_i w_i mean_c (s Q - G)^2) / (sum_i w_i mean_c G), w_i = pixel
solid angle / 4 pi. irr-RMSE: the same on irradiance maps. Dominant light: angle between directions,
the true one being the luminance-weighted centroid of pixels above 50 % of the peak luminance.
"""
from __future__ import annotations

import math
import statistics

import numpy as np

from . import sh
from .camera.color import LUMINANCE_WEIGHTS, luminance
from .harm import HARM_MARGIN, HARM_RATIO, harmed  # noqa: F401  (the evaluation's harm, one home)

GRID_H, GRID_W = 128, 256


def _relative_weighted_rmse(g: np.ndarray, q: np.ndarray) -> float:
    w = sh.pixel_solid_angles(g.shape[0], g.shape[1]) / (4.0 * math.pi)
    med_q = float(np.median(q))
    s = float(np.median(g)) / med_q if med_q > 0 else 1.0
    num = math.sqrt(float((w * ((s * q - g) ** 2).mean(axis=-1)).sum()))
    den = float((w * g.mean(axis=-1)).sum())
    return num / den if den != 0 else math.inf


def irr_rmse_maps(gt_irradiance: np.ndarray, pred_irradiance: np.ndarray) -> float:
    """irr-RMSE between two (H, W, 3) irradiance maps (for models that are not pure SH, e.g. lights + SH)."""
    return _relative_weighted_rmse(np.asarray(gt_irradiance, dtype=np.float64),
                                   np.asarray(pred_irradiance, dtype=np.float64))


def scale_defined(gt_coeffs) -> bool:
    """Whether m-RMSE's median scaling means what it says for this truth: its radiance map reconstructed at the
    coefficients' order has a positive median. A dominant sun or studio light rings at lmax 2, and over half the
    sphere can go negative (8 of the 115 un-clipped real HDRs; Blender's sunrise); EVALUATION.md's s = median(G) /
    median(Q) is then negative, and m-RMSE compares a sign-flipped estimate with the truth (so does the naive one's).
    Studies report such scenes apart; the metric itself stays as EVALUATION.md defines it."""
    return float(np.median(sh.reconstruct(np.asarray(gt_coeffs, dtype=np.float64), GRID_H, GRID_W))) > 0.0


def m_rmse(gt_coeffs, pred_coeffs) -> float:
    """Median-scaled, solid-angle weighted RMSE of the radiance maps, divided by the mean GT radiance (see
    ``scale_defined`` for the truths whose median scale flips the estimate's sign)."""
    g = sh.reconstruct(np.asarray(gt_coeffs, dtype=np.float64), GRID_H, GRID_W)
    q = sh.reconstruct(np.asarray(pred_coeffs, dtype=np.float64), GRID_H, GRID_W)
    return _relative_weighted_rmse(g, q)


def irr_rmse(gt_coeffs, pred_coeffs) -> float:
    """The same relative error on the irradiance maps (A_l convolution) of both coefficient sets."""
    g = sh.irradiance_map(np.asarray(gt_coeffs, dtype=np.float64), GRID_H, GRID_W)
    q = sh.irradiance_map(np.asarray(pred_coeffs, dtype=np.float64), GRID_H, GRID_W)
    return _relative_weighted_rmse(g, q)


DOMINANT_THRESHOLD = 0.5  # the dominant light: the pixels above this share of the peak luminance


def dominant_light_direction(hdr: np.ndarray) -> np.ndarray:
    """Unit vector: luminance-weighted centroid of the pixels above DOMINANT_THRESHOLD x peak luminance."""
    lum = luminance(np.asarray(hdr, dtype=np.float64))
    peak = lum.max()
    if not peak > 0:
        raise ValueError("the image has no positive luminance; there is no dominant light")
    wts = np.where(lum >= DOMINANT_THRESHOLD * peak, lum, 0.0)
    d = (sh.pixel_directions(*lum.shape) * wts[..., None]).sum(axis=(0, 1))
    n = np.linalg.norm(d)
    if n < 1e-12 * wts.sum():
        raise ValueError("the bright pixels cancel out (opposite directions); the dominant direction is undefined")
    return d / n


def angle_deg(a, b) -> float:
    """Angle in degrees between two direction vectors."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    c = float(a @ b / (np.linalg.norm(a) * np.linalg.norm(b)))
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


SOURCE_CONE_DEG = 5.0  # EVALUATION.md: the dominant source's energy is measured within 5 degrees
DOMINANT_SHARE = 0.15  # ... and a scene has one when at least 15 % of its luminance energy lies there


def cone_energy(hdr: np.ndarray, direction) -> float:
    """Luminance energy (luminance x pixel solid angle, sr) of an equirect (H, W, 3) map within
    SOURCE_CONE_DEG of the unit ``direction`` (Blender world frame)."""
    lum = luminance(np.asarray(hdr, dtype=np.float64))
    h, w = lum.shape
    cos = sh.pixel_directions(h, w) @ np.asarray(direction, dtype=np.float64)
    inside = cos >= math.cos(math.radians(SOURCE_CONE_DEG))
    return float((lum * sh.pixel_solid_angles(h, w))[inside].sum())


def dominant_source(hdr: np.ndarray) -> dict:
    """EVALUATION.md's dominant compact source of a ground-truth HDR (H, W, 3): its direction (unit
    vector), its cone energy (within SOURCE_CONE_DEG), that energy's share of the map's luminance energy,
    and whether the scene has one (share >= DOMINANT_SHARE)."""
    lum = luminance(np.asarray(hdr, dtype=np.float64))
    d = dominant_light_direction(hdr)
    e = cone_energy(hdr, d)
    total = float((lum * sh.pixel_solid_angles(*lum.shape)).sum())
    share = e / total if total > 0 else 0.0
    return {"direction": d, "energy": e, "share": share, "dominant": share >= DOMINANT_SHARE}


def source_energy_ratio(truth: np.ndarray, estimate: np.ndarray, direction) -> float:
    """EVALUATION.md's energy ratio r = s E_est(cone) / E_true(cone) of the source at the TRUE
    ``direction``, both maps (H, W, 3) at the same resolution (the truth and ``hdr.exr``), s = median
    luminance of the truth / median luminance of the estimate (over pixels; 1 if the latter is not
    positive). 1 is exact; 0.02 a vanished sun; 5 a blinding one."""
    t, q = np.asarray(truth, dtype=np.float64), np.asarray(estimate, dtype=np.float64)
    if t.shape != q.shape:
        raise ValueError(f"the truth {t.shape} and the estimate {q.shape} must have the same resolution")
    med_q = float(np.median(luminance(q)))
    s = float(np.median(luminance(t))) / med_q if med_q > 0 else 1.0
    e_true = cone_energy(t, direction)
    return s * cone_energy(q, direction) / e_true if e_true > 0 else math.inf


def ratio_within(ratios) -> float | None:
    """EVALUATION.md's summary of ratios to the truth (energy ratios ``r``, ``source_energy_ratio``; shadow
    contrasts C_est / C_true, ``shadow_contrast``): "within 2^x", x the median of |log2| over them (floored at
    1e-12: a vanished source counts as about 40 stops off, not infinitely); None for none."""
    lr = [abs(math.log2(max(float(r), 1e-12))) for r in ratios]
    return 2 ** statistics.median(lr) if lr else None


# The public set's scores beyond the two RMSEs (``apps.evaluation``): the sun's share of the irradiance facing
# it, the brightest direction of an SH map, and the relighting error of a whole lighting model.
SUN_CONE_DEG = 3.0  # the true sun: pixels within this angle of the dominant direction, above their ring


def true_sun_share(hdr: np.ndarray, direction, cone_deg: float = SUN_CONE_DEG) -> float:
    """Share of the irradiance facing ``direction`` that comes from the source there: the pixels within
    ``cone_deg``, less the median of the ring out to twice that (HDR ground truth)."""
    h, w = hdr.shape[:2]
    dirs = sh.pixel_directions(h, w)
    omega = sh.pixel_solid_angles(h, w)
    d = np.asarray(direction, dtype=np.float64)
    cos = dirs @ d
    ang = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    lum = np.asarray(hdr, dtype=np.float64) @ LUMINANCE_WEIGHTS
    ring = (ang > cone_deg) & (ang < 2 * cone_deg)
    bg = float(np.median(lum[ring])) if ring.any() else 0.0
    core = ang <= cone_deg
    sun = float((np.maximum(lum[core] - bg, 0.0) * omega[core] * np.maximum(cos[core], 0.0)).sum())
    total = float((lum * omega * np.maximum(cos, 0.0)).sum())
    return sun / total if total > 0 else 0.0


def brightest_light(lights) -> dict | None:
    """The light of largest luminous intensity (intensity x luminance of its colour); None for none."""
    return max(lights, key=lambda light: light["intensity"] * float(np.asarray(light["color"]) @ LUMINANCE_WEIGHTS),
               default=None)


def model_sun_share(model, direction) -> float | None:
    """Share of the model's irradiance facing ``direction`` carried by its brightest light (0 without
    lights; None where the model's irradiance there is not positive)."""
    key = brightest_light(model.lights)
    if key is None:
        return 0.0
    from .lighting.lights import light_irradiance

    n = np.asarray(direction, dtype=np.float64)[None]
    sun = float(light_irradiance([key], n)[0] @ LUMINANCE_WEIGHTS)
    total = float(model.irradiance(n)[0] @ LUMINANCE_WEIGHTS)
    return sun / total if total > 0 else None


MAX_CONTRAST = 1000.0  # a share of 0.999: an SH part ringing below zero where a light shines can push the
# share to 1 or past it, which no lit/shadow pair shows


def shadow_contrast(share: float | None) -> float:
    """EVALUATION.md's lit/shadow contrast C = 1 / (1 - share) of a surface whose key light has ``share`` of
    its irradiance (None, 0 or no light: 1, no shadow), at most MAX_CONTRAST."""
    share = min(max(float(share or 0.0), 0.0), 1.0 - 1.0 / MAX_CONTRAST)
    return 1.0 / (1.0 - share)


def true_shadow_contrast(hdr: np.ndarray, direction) -> float:
    """The truth's C facing its source at ``direction``: the pixels within SOURCE_CONE_DEG (5 degrees) less the
    median of the ring from 5 to 10 degrees, over the whole sphere's (EVALUATION.md)."""
    return shadow_contrast(true_sun_share(hdr, direction, SOURCE_CONE_DEG))


def model_shadow_contrast(model, direction) -> float:
    """A lighting model's C facing the TRUE ``direction``: its brightest light's share of its irradiance there."""
    return shadow_contrast(model_sun_share(model, direction))


def estimated_direction(coeffs: np.ndarray):
    """Brightest direction of the SH radiance on a 256 x 128 grid; None for a constant map."""
    c = np.asarray(coeffs, dtype=np.float64)
    if not np.any(c[1:]):
        return None
    lum = sh.reconstruct(c, GRID_H, GRID_W) @ LUMINANCE_WEIGHTS
    iy, ix = np.unravel_index(np.argmax(lum), lum.shape)
    return sh.pixel_directions(GRID_H, GRID_W)[iy, ix]


EXACT_ORDER = 24  # "exact" irradiance: A_l at l = 24 is 2e-4 of A_0, far below the errors compared


def score_lighting(hdr: np.ndarray, coeffs: np.ndarray, lights, ldr_linear: np.ndarray) -> dict:
    """Diffuse relighting error (irr-RMSE, metrics.GRID) of a lighting model (SH coeffs + lights) against
    the HDR's exact irradiance, beside the naive lmax 2 projection of the linearised LDR it came from."""
    from .lighting.adaptive import LightingModel

    grid = (GRID_H, GRID_W)
    truth = sh.irradiance_map(sh.project(hdr, EXACT_ORDER), *grid)
    ours = LightingModel(lights, coeffs).irradiance_map(*grid)
    naive = sh.irradiance_map(sh.project(ldr_linear, 2), *grid)
    return {"irr_rmse": irr_rmse_maps(truth, ours), "naive_irr_rmse": irr_rmse_maps(truth, naive)}


def sphere_scores(truth: dict, estimate: dict) -> dict:
    """The three-sphere protocol's scores (``lighting.spheres.render_spheres`` of the truth and of an estimate): per
    sphere, the RMSE and the scale-invariant RMSE (the estimate scaled by its least-squares factor first), both over
    the truth sphere's RMS (unitless, so scenes of any units compare), and the mean RGB angular error (degrees)."""
    out = {}
    for name, g in truth.items():
        g, e = np.asarray(g, dtype=np.float64), np.asarray(estimate[name], dtype=np.float64)
        norm = math.sqrt(float((g * g).mean())) or 1.0
        ee = float((e * e).sum())
        alpha = float((e * g).sum()) / ee if ee > 0 else 0.0
        cos = (e * g).sum(axis=-1) / np.maximum(np.linalg.norm(e, axis=-1) * np.linalg.norm(g, axis=-1), 1e-300)
        out[name] = {"rmse": math.sqrt(float(((e - g) ** 2).mean())) / norm,
                     "si_rmse": math.sqrt(float(((alpha * e - g) ** 2).mean())) / norm,
                     "angular_deg": float(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))).mean())}
    return out
