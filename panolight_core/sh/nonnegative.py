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

from functools import lru_cache

import numpy as np

from .basis import basis
from .grid import directions_at, pixel_directions, pixel_solid_angles, row_solid_angles
from .transform import reconstruct

KEEP_LMAX = 2  # the emitter keeps bands 0..2 exactly: every diffuse surface's irradiance
MAX_ITERATIONS = 50  # Newton steps of one solve (it converges in a few)
SWEEPS = 8  # full-grid Newton sweeps after the coarse solve


def nonnegative(radiance: np.ndarray, directions: np.ndarray, weights: np.ndarray, keep_lmax: int = 2,
                tolerance: float = 1e-9, start=None) -> tuple[np.ndarray, dict]:
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
        out[:, ch], its, err, info["lam"][:, ch] = _solve(r[:, ch], y, wy, lam0, MAX_ITERATIONS, tolerance)
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
    for its in range(max_iterations + 1):  # noqa: B007 (the count is returned)
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


def emitter_map(coeffs: np.ndarray, height: int, width: int) -> tuple[np.ndarray, dict]:
    """The emitter of SH radiance ``coeffs`` (K, C) on an equirect (height, width) grid (Blender world
    frame, pixel centres): ``nonnegative`` of its reconstruction with the pixels' solid angles, as float64
    (H, W, C). Solved on a coarse grid first, then refined and applied by row blocks on the full grid, so
    the memory is the map plus a block whatever the size."""
    c = np.asarray(coeffs, dtype=np.float64)
    rad = reconstruct(c, height, width)
    keep_lmax = KEEP_LMAX
    k = (keep_lmax + 1) ** 2
    negative = sum(int((rad[r0:r1].min(axis=-1) < 0).sum()) for r0, r1 in _blocks(height, width))
    info = {"negative_fraction": negative / (height * width), "iterations": 0, "moment_error": 0.0,
            "lam": np.zeros((k, c.shape[-1]))}
    if not negative:
        return rad, info
    ch = min(height, COARSE)
    coarse = reconstruct(c, ch, 2 * ch)
    lam = nonnegative(coarse, pixel_directions(ch, 2 * ch), pixel_solid_angles(ch, 2 * ch), keep_lmax)[1]["lam"]
    lam, sweeps, err, dark = _refine(rad, height, width, keep_lmax, lam)
    for r0, r1 in _blocks(height, width):  # the emitter, in place
        y = _block_basis(r0, r1, height, width, keep_lmax)
        np.maximum(rad[r0:r1] + (y @ lam).reshape(r1 - r0, width, -1), 0.0, out=rad[r0:r1])
        rad[r0:r1, :, dark] = 0.0  # no non-negative map has a mean <= 0: no light
    err = 1.0 if dark.any() else err
    info.update(iterations=sweeps, moment_error=err, lam=lam)
    return rad, info


COARSE = 64  # rows of emitter_map's first solve
BLOCK = 1 << 18  # pixels per row block of emitter_map's full-grid passes


def _blocks(height: int, width: int):
    step = max(1, BLOCK // width)
    return [(r, min(height, r + step)) for r in range(0, height, step)]


@lru_cache(maxsize=4)
def _block_basis(r0: int, r1: int, height: int, width: int, keep_lmax: int) -> np.ndarray:
    """(n, K') real SH of bands 0..keep_lmax at the pixel centres of rows r0..r1 (the last few blocks
    are kept: a default-size map is one block, made once for all the passes)."""
    rows, cols = np.meshgrid(np.arange(r0, r1), np.arange(width), indexing="ij")
    y = basis(directions_at(rows.ravel(), cols.ravel(), height, width), keep_lmax, check_unit=False)
    y.setflags(write=False)
    return y


@lru_cache(maxsize=4)
def _block_terms(r0: int, r1: int, height: int, width: int, keep_lmax: int):
    """(y, w y, its Gram matrix (w y)^T y) of a row block: what every Newton pass needs of the grid."""
    y = _block_basis(r0, r1, height, width, keep_lmax)
    wy = np.repeat(row_solid_angles(height, width)[r0:r1], width)[:, None] * y
    gram = wy.T @ y
    for a in (wy, gram):
        a.setflags(write=False)
    return y, wy, gram


def _refine(rad, height, width, keep_lmax, lam, tolerance: float = 1e-9):
    """Newton sweeps of ``_solve`` on the full grid, accumulated by row blocks (the first also takes the
    target moments); the Jacobian of the first pass is kept while each step shrinks the error at least
    tenfold (the active set barely moves after the coarse solve). Returns (lam, sweeps, moment error relative to band 0, the channels whose mean is
    <= 0)."""
    n_c, k = rad.shape[-1], lam.shape[0]
    target = None
    err, done = np.inf, 0
    last = np.inf
    jac = np.zeros((n_c, k, k))
    fresh = True  # the Jacobian is made on the first pass and again only when a step did not pay
    for done in range(SWEEPS + 1):
        first = target is None
        moments = np.zeros_like(lam) if first else None
        g = np.zeros_like(lam)
        if fresh:
            jac = np.zeros((n_c, k, k))
        for r0, r1 in _blocks(height, width):
            y, wy, gram = _block_terms(r0, r1, height, width, keep_lmax)
            r = rad[r0:r1].reshape(-1, n_c)
            if first:
                moments += wy.T @ r
            f = r + y @ lam
            off = f <= 0
            np.maximum(f, 0.0, out=f)
            g += wy.T @ f
            if fresh:  # the active pixels' Gram: the block's, less the pixels switched off
                for ch in range(n_c):
                    idle = off[:, ch]
                    jac[ch] += gram - wy[idle].T @ y[idle] if idle.any() else gram
        if first:
            target = moments
            live = target[0] > 0  # a channel of no light stays at zero
            scale = np.maximum(np.abs(target[0]), np.finfo(float).tiny)
            if not live.all():
                lam = np.where(live, lam, 0.0)
                continue
        g -= target
        err = float(np.max(np.abs(g[:, live]) / scale[live])) if live.any() else 0.0
        if err <= tolerance or done == SWEEPS:
            break
        fresh = err > 0.1 * last  # a chord step that shrank the error tenfold keeps its Jacobian
        last = err
        if fresh and not first:
            continue  # make it afresh on the next pass, at this lam
        for ch in np.flatnonzero(live):
            lam[:, ch] -= np.linalg.lstsq(jac[ch] + 1e-12 * scale[ch] * np.eye(k), g[:, ch], rcond=None)[0]
    return lam, done, err, ~live
