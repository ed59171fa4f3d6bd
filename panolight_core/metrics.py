"""Metrics of EVALUATION.md, in float64, in the CONVENTIONS.md frame and basis.

m-RMSE: reconstruct ground truth G and prediction Q on a 256 x 128 grid; s = median(G) / median(Q)
(1 if median(Q) <= 0); m-RMSE = sqrt(sum_i w_i mean_c (s Q - G)^2) / (sum_i w_i mean_c G), w_i = pixel
solid angle / 4 pi. irr-RMSE: the same on irradiance maps. Dominant light: angle between directions,
the true one being the luminance-weighted centroid of pixels above 50 % of the peak luminance.
"""
from __future__ import annotations

import math

import numpy as np

from . import sh
from .camera.color import luminance

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


def m_rmse(gt_coeffs, pred_coeffs) -> float:
    """Median-scaled, solid-angle weighted RMSE of the radiance maps, divided by the mean GT radiance."""
    g = sh.reconstruct(np.asarray(gt_coeffs, dtype=np.float64), GRID_H, GRID_W)
    q = sh.reconstruct(np.asarray(pred_coeffs, dtype=np.float64), GRID_H, GRID_W)
    return _relative_weighted_rmse(g, q)


def irr_rmse(gt_coeffs, pred_coeffs) -> float:
    """The same relative error on the irradiance maps (A_l convolution) of both coefficient sets."""
    g = sh.irradiance_map(np.asarray(gt_coeffs, dtype=np.float64), GRID_H, GRID_W)
    q = sh.irradiance_map(np.asarray(pred_coeffs, dtype=np.float64), GRID_H, GRID_W)
    return _relative_weighted_rmse(g, q)


def dominant_light_direction(hdr: np.ndarray, threshold: float = 0.5) -> np.ndarray:
    """Unit vector: luminance-weighted centroid of the pixels above ``threshold`` x peak luminance."""
    lum = luminance(np.asarray(hdr, dtype=np.float64))
    peak = lum.max()
    if not peak > 0:
        raise ValueError("the image has no positive luminance; there is no dominant light")
    wts = np.where(lum >= threshold * peak, lum, 0.0)
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
