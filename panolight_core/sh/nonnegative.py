"""Emitters without negative light: the nearest non-negative radiance with the same low bands.

A truncated SH series of real lighting rings: its radiance dips below zero around bright sources and
sky edges (13-47 % of the directions of real photos' estimates at orders 2-4). An emitter made of it
(radiance.exr, the USD dome, Blender's SH world, Mitsuba's envmap) would hold negative light, and
clipping the negatives adds energy. ``nonnegative`` instead returns the map f >= 0 nearest to the SH
radiance r (weighted L2 over the sphere) whose projections onto bands 0..keep_lmax equal r's, so every
diffuse surface (bands 0-2 carry all of Lambertian irradiance) and the total energy (band 0) are
unchanged. Its solution is f = max(r + Y lam, 0), lam (per channel, (keep_lmax + 1)^2 numbers) found
by a semi-smooth Newton method: f is the SH radiance lifted by a smooth band-limited correction where
that is needed, and zero where the ringing was.
"""
from __future__ import annotations

import numpy as np

from .basis import basis
from .grid import pixel_directions, pixel_solid_angles
from .transform import reconstruct


def nonnegative(radiance: np.ndarray, directions: np.ndarray, weights: np.ndarray, keep_lmax: int = 2,
                max_iterations: int = 50, tolerance: float = 1e-9, start=None) -> tuple[np.ndarray, dict]:
    """radiance (..., C) at unit ``directions`` (..., 3) with quadrature ``weights`` (...) (solid angles,
    sr) -> (f, info): f (..., C) >= 0, the weighted-L2-nearest to ``radiance`` with the same weighted
    moments against the real SH of bands 0..keep_lmax. A radiance already >= 0 is returned unchanged. info:
    negative_fraction (of the directions, any channel, before), iterations (the most of any channel),
    moment_error (the largest remaining band 0..keep_lmax difference relative to band 0; ~1e-9 when
    solved; a channel whose mean radiance is <= 0 has no non-negative map and becomes 0), lam ((K', C),
    the correction's coefficients: ``start`` for a finer grid of the same radiance)."""
    r = np.asarray(radiance, dtype=np.float64)
    shape = r.shape
    r = r.reshape(-1, shape[-1])
    w = np.asarray(weights, dtype=np.float64).reshape(-1)
    negative = r.min(axis=1) < 0
    k = (keep_lmax + 1) ** 2
    info = {"negative_fraction": float(negative.mean()), "iterations": 0, "moment_error": 0.0,
            "lam": np.zeros((k, shape[-1]))}
    if not negative.any():
        return np.asarray(radiance).copy(), info
    y = basis(np.asarray(directions, dtype=np.float64).reshape(-1, 3), keep_lmax, check_unit=False)
    wy = w[:, None] * y
    out = np.empty_like(r)
    for ch in range(r.shape[1]):
        lam0 = np.zeros(k) if start is None else np.asarray(start, dtype=np.float64)[:, ch]
        out[:, ch], its, err, info["lam"][:, ch] = _solve(r[:, ch], y, wy, lam0, max_iterations, tolerance)
        info["iterations"] = max(info["iterations"], its)
        info["moment_error"] = max(info["moment_error"], err)
    return out.reshape(shape), info


def _solve(r, y, wy, lam, max_iterations, tolerance):
    """One channel: lam with  wy^T max(r + y lam, 0) = wy^T r  (semi-smooth Newton, backtracking)."""
    target = wy.T @ r
    scale = abs(float(target[0]))
    if target[0] <= 0:  # no non-negative map has this mean: no light at all
        return np.zeros_like(r), 0, 0.0 if scale == 0 else 1.0, lam
    f = r + y @ lam
    residual = wy.T @ np.maximum(f, 0) - target
    its = 0
    for its in range(max_iterations + 1):
        if np.abs(residual).max() <= tolerance * scale:
            break
        active = f > 0
        jac = wy[active].T @ y[active]
        step = np.linalg.lstsq(jac + 1e-12 * scale * np.eye(len(lam)), residual, rcond=None)[0]
        norm, t = np.linalg.norm(residual), 1.0
        while True:  # backtrack until the moment residual shrinks
            trial = lam - t * step
            f_trial = r + y @ trial
            res_trial = wy.T @ np.maximum(f_trial, 0) - target
            if np.linalg.norm(res_trial) < norm or t < 1e-6:
                break
            t *= 0.5
        lam, f, residual = trial, f_trial, res_trial
    return np.maximum(f, 0), its, float(np.abs(residual).max() / scale), lam


def emitter_map(coeffs: np.ndarray, height: int, width: int, keep_lmax: int = 2) -> tuple[np.ndarray, dict]:
    """The emitter of SH radiance ``coeffs`` (K, C) on an equirect (height, width) grid (Blender world
    frame, pixel centres): ``nonnegative`` of its reconstruction, with the pixels' solid angles."""
    c = np.asarray(coeffs, dtype=np.float64)
    start = None
    if height > COARSE:  # Newton on a coarse grid first: the fine grid then needs one or two steps
        coarse = reconstruct(c, COARSE, 2 * COARSE)
        start = nonnegative(coarse, pixel_directions(COARSE, 2 * COARSE), pixel_solid_angles(COARSE, 2 * COARSE),
                            keep_lmax)[1]["lam"]
    rad = reconstruct(c, height, width)
    return nonnegative(rad, pixel_directions(height, width), pixel_solid_angles(height, width), keep_lmax,
                       start=start)


COARSE = 64  # rows of emitter_map's first solve
