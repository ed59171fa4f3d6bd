"""Rotations (and reflections) of SH coefficient sets.

rotate_z is closed form for any order. rotate handles any orthogonal 3x3 matrix (rotations, and
the improper axis swaps used by some engines) band by band: D_l solves Y_l(R^T d_i) = D_l Y_l(d_i)
in float64 least squares over a well-spread point set, exact to ~1e-13 (tested against rotate_z and
against resampling the map).
"""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from .._backend import float_array
from .basis import basis
from .indexing import degrees_orders, lmax_from_count


def rotate_z(coeffs, angle: float):
    """Coefficients of the environment turned by ``angle`` radians about +Z (counter-clockwise seen
    from above): new(d) = old(Rz(-angle) d). (..., K, C), numpy or torch, differentiable in coeffs.

    A Blender world Mapping node with rotation Z = a shows the texture turned by +a, so pass angle = a.
    """
    xp, c = float_array(coeffs, "coeffs")
    lmax = lmax_from_count(c.shape[-2])
    l_idx, m_idx = degrees_orders(lmax)
    k = np.arange(l_idx.size)
    partner = k - 2 * m_idx  # index of (l, -m)
    cos_m = np.cos(np.abs(m_idx) * angle)
    sin_m = np.sin(np.abs(m_idx) * angle)
    # m > 0 (cos part): c' = c cos - s sin ; m < 0 (sin part): s' = s cos + c sin
    sign = np.where(m_idx > 0, -1.0, np.where(m_idx < 0, 1.0, 0.0))
    a = xp.const(np.ascontiguousarray(cos_m[:, None]), c)
    b = xp.const(np.ascontiguousarray((sign * sin_m)[:, None]), c)
    return c * a + c[..., partner, :] * b


@lru_cache(maxsize=8)
def _fibonacci_points(n: int) -> np.ndarray:
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    phi = math.pi * (1.0 + math.sqrt(5.0)) * i
    r = np.sqrt(1.0 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=-1)


def rotation_matrices(matrix, lmax: int) -> list[np.ndarray]:
    """Per-band (2l+1, 2l+1) float64 matrices D_l with coeffs'_l = D_l @ coeffs_l for new(d) = old(R^T d)."""
    r = np.asarray(matrix, dtype=np.float64)
    if r.shape != (3, 3) or not np.allclose(r @ r.T, np.eye(3), atol=1e-6):
        raise ValueError(f"rotate needs an orthogonal 3x3 matrix, got {r.tolist()}")
    pts = _fibonacci_points(max(64, 4 * (lmax + 1) ** 2))
    y_new = basis(pts, lmax)  # Y(d)
    y_old = basis(pts @ r, lmax, check_unit=False)  # Y(R^T d), rows are (R^T d_i)^T = d_i^T R
    mats = []
    for l in range(lmax + 1):
        s = slice(l * l, (l + 1) * (l + 1))
        # sum c_k Y_k(R^T d) = sum c'_k Y_k(d) with c' = D c  =>  Y_old[:, s] = Y_new[:, s] @ D
        d_l, *_ = np.linalg.lstsq(y_new[:, s], y_old[:, s], rcond=None)
        mats.append(d_l)
    return mats


def rotate(coeffs, matrix):
    """Coefficients of the environment transformed by an orthogonal 3x3 ``matrix``: new(d) = old(R^T d).

    (..., K, C), numpy or torch (differentiable in coeffs).
    """
    xp, c = float_array(coeffs, "coeffs")
    lmax = lmax_from_count(c.shape[-2])
    k = (lmax + 1) ** 2
    full = np.zeros((k, k))
    for l, d in enumerate(rotation_matrices(matrix, lmax)):
        full[l * l:(l + 1) * (l + 1), l * l:(l + 1) * (l + 1)] = d
    return xp.const(full, c) @ c
