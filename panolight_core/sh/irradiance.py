"""Lambertian irradiance from radiance SH (Ramamoorthi & Hanrahan 2001)."""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from .._backend import float_array
from .basis import basis
from .indexing import degrees_orders, lmax_from_count


@lru_cache(maxsize=32)
def lambert_kernel(lmax: int) -> np.ndarray:
    """(lmax+1,) A_l: pi, 2 pi/3, then 0 for odd l, 2 pi (-1)^(l/2-1) / ((l+2)(l-1)) l! / (2^l ((l/2)!)^2).

    Computed in log space so it stays finite for any order.
    """
    a = np.zeros(lmax + 1)
    for l in range(lmax + 1):
        if l == 0:
            a[l] = math.pi
        elif l == 1:
            a[l] = 2.0 * math.pi / 3.0
        elif l % 2 == 0:
            log_ratio = math.lgamma(l + 1) - l * math.log(2.0) - 2.0 * math.lgamma(l // 2 + 1)
            a[l] = 2.0 * math.pi * (-1) ** (l // 2 - 1) / ((l + 2.0) * (l - 1.0)) * math.exp(log_ratio)
    a.setflags(write=False)
    return a


def convolve_lambert(coeffs):
    """Radiance coefficients (..., K, C) -> irradiance coefficients A_l L_lm (same shape and kind)."""
    xp, c = float_array(coeffs, "coeffs")
    lmax = lmax_from_count(c.shape[-2])
    l_idx, _ = degrees_orders(lmax)
    return c * xp.const(np.ascontiguousarray(lambert_kernel(lmax)[l_idx][:, None]), c)


def irradiance(coeffs, normals):
    """Irradiance E(n) = sum_l A_l sum_m L_lm Y_lm(n), any lmax.

    coeffs: (K, C) radiance coefficients (or (B, K, C) with normals (B, ..., 3)).
    normals: (..., 3) unit vectors in the world frame. Returns (..., C) in the units of radiance x sr
    (a constant radiance 1 gives pi). numpy or torch, differentiable in both arguments.
    """
    xp, c = float_array(coeffs, "coeffs")
    _, n = float_array(normals, "normals")
    if c.ndim not in (2, 3):
        raise ValueError(f"coeffs must have shape (K, C) or (B, K, C), got {tuple(c.shape)}")
    lmax = lmax_from_count(c.shape[-2])
    y = basis(n, lmax)  # (..., K)
    ec = convolve_lambert(c)
    if c.ndim == 2:
        return y @ ec
    if n.shape[0] != c.shape[0]:
        raise ValueError(f"batched coeffs {tuple(c.shape)} need normals with the same leading batch size")
    flat = y.reshape(y.shape[0], -1, y.shape[-1])  # (B, N, K)
    return (flat @ ec).reshape(tuple(y.shape[:-1]) + (c.shape[-1],))


# Ramamoorthi-Hanrahan constants of the 4x4 quadratic form (paper Eq. 3).
RH_C1, RH_C2, RH_C3, RH_C4, RH_C5 = 0.429043, 0.511664, 0.743125, 0.886227, 0.247708


def irradiance_matrix(coeffs):
    """(9, C) lmax-2 coefficients -> (C, 4, 4) symmetric matrices M with E(n) = [n, 1]^T M [n, 1].

    The constants are the exact values behind R&H's rounded c1..c5 (c1 = A_2 * 1.092548 / 2 ...),
    so the form agrees with the A_l kernel to float rounding.
    """
    xp, c = float_array(coeffs, "coeffs")
    if tuple(c.shape[-2:-1]) != (9,):
        raise ValueError(f"the matrix form needs lmax = 2 coefficients (9, C), got {tuple(c.shape)}")
    c1, c2, c3, c4, c5 = _rh_constants()
    L = [c[..., k, :] for k in range(9)]  # order: 00, 1-1, 10, 11, 2-2, 2-1, 20, 21, 22
    rows = [
        [c1 * L[8], c1 * L[4], c1 * L[7], c2 * L[3]],
        [c1 * L[4], -c1 * L[8], c1 * L[5], c2 * L[1]],
        [c1 * L[7], c1 * L[5], c3 * L[6], c2 * L[2]],
        [c2 * L[3], c2 * L[1], c2 * L[2], c4 * L[0] - c5 * L[6]],
    ]
    m = xp.stack([xp.stack(r, axis=-1) for r in rows], axis=-2)  # (..., C, 4, 4)
    return m


@lru_cache(maxsize=1)
def _rh_constants():
    """Exact c1..c5 (R&H 2001 Eq. 12 prints them rounded to 6 digits)."""
    a1, a2 = 2.0 * math.pi / 3.0, math.pi / 4.0
    k00 = 0.5 / math.sqrt(math.pi)
    k1 = math.sqrt(3.0 / (4.0 * math.pi))
    k20 = 0.25 * math.sqrt(5.0 / math.pi)  # (3z^2 - 1)
    k22 = 0.25 * math.sqrt(15.0 / math.pi)  # (x^2 - y^2)
    c1 = a2 * k22  # = A_2 * (the xy/yz/xz constant) / 2
    c2 = a1 * k1 / 2.0  # off-diagonal entries appear twice in the quadratic form
    c3 = 3.0 * a2 * k20
    c4 = math.pi * k00
    c5 = a2 * k20
    return c1, c2, c3, c4, c5


def irradiance_rh(coeffs, normals):
    """Irradiance by the paper's 4x4 quadratic form (lmax = 2 only). Shapes as in ``irradiance``."""
    xp, n = float_array(normals, "normals")
    m = irradiance_matrix(coeffs)  # (C, 4, 4)
    ones = n[..., :1] * 0 + 1.0
    eta = xp.concatenate([n, ones], axis=-1)  # (..., 4)
    n_c = m.shape[-3]
    flat = eta.reshape(-1, 4)
    em = (flat @ m.swapaxes(-3, -2).reshape(4, n_c * 4)).reshape(-1, n_c, 4)  # eta^T M per channel
    return (em * flat[:, None, :]).sum(-1).reshape(tuple(n.shape[:-1]) + (n_c,))
