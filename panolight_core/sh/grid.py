"""Equirectangular grid geometry (CONVENTIONS.md) and cached separable SH tables.

Pixel (x, y) of an H x W image has its centre at u = (x+0.5)/W, v = (y+0.5)/H,
theta = pi v (polar angle from +Z), phi = pi - 2 pi u (azimuth from +X towards +Y), so
d = (-sin(theta) cos(2 pi u), sin(theta) sin(2 pi u), cos(theta)).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .indexing import check_lmax, degrees_orders
from .legendre import legendre_table

MAX_SIDE = 1 << 16  # 65536: larger equirect images are refused as absurd


def check_grid(height: int, width: int) -> tuple[int, int]:
    """Validate an equirect size (positive ints, at most 65536 on a side). Returns (H, W)."""
    for name, v in (("height", height), ("width", width)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
            raise ValueError(f"{name} must be a positive integer, got {v!r}")
        if v > MAX_SIDE:
            raise ValueError(f"{name} {v} exceeds the supported maximum of {MAX_SIDE} pixels")
    return int(height), int(width)


def elevation_deg(direction) -> float:
    """Degrees above the horizon (the XY plane) of a direction (3,) in the Blender world frame (Z up); the
    direction need not be unit length (a zero vector is at 0)."""
    d = np.asarray(direction, dtype=np.float64)
    return math.degrees(math.asin(float(np.clip(d[2] / max(float(np.linalg.norm(d)), 1e-300), -1.0, 1.0))))


@lru_cache(maxsize=8)
def pixel_directions(height: int, width: int) -> np.ndarray:
    """(H, W, 3) float64 unit view directions of the pixel centres (cached, read-only)."""
    height, width = check_grid(height, width)
    theta = np.pi * (np.arange(height) + 0.5) / height
    u = (np.arange(width) + 0.5) / width
    st, ct = np.sin(theta)[:, None], np.cos(theta)[:, None]
    out = np.stack(np.broadcast_arrays(-st * np.cos(2 * np.pi * u), st * np.sin(2 * np.pi * u), ct), axis=-1)
    out.setflags(write=False)
    return out


def directions_at(rows, cols, height: int, width: int) -> np.ndarray:
    """(..., 3) float64 view directions of the pixel centres (rows, cols) of an H x W equirect image.
    Integer indices look the sines and cosines up in per-row and per-column tables (the same numbers,
    without millions of trigonometric calls)."""
    rows, cols = np.asarray(rows), np.asarray(cols)
    if rows.dtype.kind in "iu" and cols.dtype.kind in "iu" and rows.size > height + width:
        theta = np.pi * (np.arange(height) + 0.5) / height
        phi = 2 * np.pi * ((np.arange(width) + 0.5) / width)
        st, ct, cp, sp = np.sin(theta), np.cos(theta), np.cos(phi), np.sin(phi)
        st_r = st[rows]
        return np.stack([-st_r * cp[cols], st_r * sp[cols], ct[rows]], axis=-1)
    theta = np.pi * (rows + 0.5) / height
    u = (cols + 0.5) / width
    st = np.sin(theta)
    return np.stack([-st * np.cos(2 * np.pi * u), st * np.sin(2 * np.pi * u), np.cos(theta)], axis=-1)


def pixel_coordinates(directions, height: int, width: int):
    """The inverse of ``directions_at``: continuous (rows, cols) of unit ``directions`` (..., 3) in an H x W
    equirect image, pixel centres at integers (row 0.0 is the top row's centre; cols in [-0.5, W - 0.5))."""
    d = np.asarray(directions, dtype=np.float64)
    u = np.mod(0.5 - np.arctan2(d[..., 1], d[..., 0]) / (2 * np.pi), 1.0)
    theta = np.arccos(np.clip(d[..., 2] / np.linalg.norm(d, axis=-1), -1.0, 1.0))
    return theta / np.pi * height - 0.5, u * width - 0.5


def pixel_at(direction, height: int, width: int) -> tuple[int, int]:
    """(row, col) of the pixel of an H x W equirect image that holds the unit ``direction`` (3,)."""
    y, x = pixel_coordinates(np.asarray(direction, dtype=np.float64)[None], height, width)
    return int(np.clip(np.floor(y[0] + 0.5), 0, height - 1)), int(np.floor(x[0] + 0.5)) % width


def row_solid_angles(height: int, width: int) -> np.ndarray:
    """(H,) exact solid angle of one pixel in each row: (cos(pi y/H) - cos(pi (y+1)/H)) 2 pi / W."""
    height, width = check_grid(height, width)
    edges = np.cos(np.pi * np.arange(height + 1) / height)
    return (edges[:-1] - edges[1:]) * (2.0 * np.pi / width)


@lru_cache(maxsize=8)
def pixel_solid_angles(height: int, width: int) -> np.ndarray:
    """(H, W) exact pixel solid angles in steradians, summing to 4 pi (cached, read-only)."""
    out = np.broadcast_to(row_solid_angles(height, width)[:, None], (height, width)).copy()
    out.setflags(write=False)
    return out


def row_quadrature_weights(height: int, width: int) -> np.ndarray:
    """(H,) Fejer's first-rule weights per pixel: exact for band-limited maps with H, W > 2 lmax.

    The row centres theta_y = pi (2y+1) / (2H) are Chebyshev nodes in z = cos(theta); Fejer's rule
    integrates polynomials in z of degree < H exactly, the W uniform columns integrate trigonometric
    polynomials of degree < W exactly. Weights sum to 4 pi like the solid angles.
    """
    height, width = check_grid(height, width)
    theta = np.pi * (2 * np.arange(height) + 1) / (2 * height)
    j = np.arange(1, height // 2 + 1)
    s = (np.cos(2 * np.outer(theta, j)) / (4.0 * j * j - 1.0)).sum(axis=1)
    return (2.0 / height) * (1.0 - 2.0 * s) * (2.0 * np.pi / width)


WEIGHTS = ("cell", "centre", "quadrature")


@dataclass(frozen=True)
class GridTables:
    """Separable tables for an H x W grid at order lmax (float64, read-only).

    trig: (M, W) with M = 2 lmax + 1, row j = m + lmax: cos(m phi) (m > 0), 1 (m = 0), sin(|m| phi) (m < 0).
    legendre: (M, H, lmax+1): sqrt(2)^[m != 0] Pbar_l^|m|(z_y) at row centres, 0 where l < |m|.
    weighted: (M, lmax+1, H): projection weights, so that L_lm = sum_y weighted[j, l, y] (trig @ I[y])[j].
    k_j, k_l: (K,) position of coefficient k in the (M, lmax+1) layout.
    Rows-first layout, with Q = (lmax+1)(lmax+2)/2 distinct (l, |m|) Legendre rows:
    k_q: (K,) row q of coefficient k; weighted_q: (Q, H); legendre_q: (H, Q); q_from_k: (Q, K) 0/1.
    """

    trig: np.ndarray
    legendre: np.ndarray
    weighted: np.ndarray
    k_j: np.ndarray
    k_l: np.ndarray
    k_q: np.ndarray
    weighted_q: np.ndarray
    legendre_q: np.ndarray
    q_from_k: np.ndarray


def _legendre_rows(z, s, lmax, out):
    """Fill out[(m + lmax), i, l] = sqrt(2)^[m != 0] Pbar_l^|m| at points (z, s) (blocked for memory)."""
    n_pairs = (lmax + 1) * (lmax + 2) // 2
    block = max(1, (1 << 22) // n_pairs)
    for i0 in range(0, z.shape[0], block):
        table = legendre_table(z[i0:i0 + block], lmax, sin_theta=s[i0:i0 + block])
        for (l, m), v in table.items():
            out[lmax + m, i0:i0 + block, l] = v if m == 0 else math.sqrt(2.0) * v
            if m:
                out[lmax - m, i0:i0 + block, l] = out[lmax + m, i0:i0 + block, l]


def _cell_row_integrals(height: int, lmax: int) -> np.ndarray:
    """(M, H, L+1): integral over each row's theta span of sqrt(2)^[m!=0] Pbar_l^|m|(cos t) sin t dt.

    Gauss-Legendre in theta per row; the integrand is analytic, so n = 8 + (lmax+1) * row width
    nodes are exact to float64 rounding (checked against scipy in the tests).
    """
    h = np.pi / height
    n = 8 + int(math.ceil((lmax + 1) * h))
    xg, wg = np.polynomial.legendre.leggauss(n)
    t = (np.arange(height)[:, None] + 0.5 + 0.5 * xg[None, :]) * h  # (H, n)
    vals = np.zeros((2 * lmax + 1, height * n, lmax + 1))
    _legendre_rows(np.cos(t).ravel(), np.sin(t).ravel(), lmax, vals)
    wts = (0.5 * h * wg[None, :] * np.sin(t)).ravel()  # dt Jacobian and sin(theta)
    return (vals * wts[None, :, None]).reshape(2 * lmax + 1, height, n, lmax + 1).sum(axis=2)


@lru_cache(maxsize=16)
def grid_tables(height: int, width: int, lmax: int, weights: str = "cell") -> GridTables:
    """Cached tables for project/reconstruct (see GridTables).

    weights: "cell" integrates the basis exactly over each pixel's cell (the image is taken as
    piecewise constant radiance: exact pixel solid angles, and a constant map projects exactly at any
    size); "centre" samples the basis at pixel centres times the exact pixel solid angle (O(1/H^2) off
    "cell"); "quadrature" uses Fejer's rule, exact for maps band-limited below min(H, W) / 2.
    """
    height, width = check_grid(height, width)
    lmax = check_lmax(lmax)
    if weights not in WEIGHTS:
        raise ValueError(f"weights must be one of {WEIGHTS}, got {weights!r}")
    theta = np.pi * (np.arange(height) + 0.5) / height
    phi = np.pi - 2.0 * np.pi * (np.arange(width) + 0.5) / width
    n_m = 2 * lmax + 1
    ms = np.arange(-lmax, lmax + 1)
    trig = np.where(ms[:, None] > 0, np.cos(ms[:, None] * phi), np.sin(-ms[:, None] * phi))
    trig[lmax] = 1.0
    leg = np.zeros((n_m, height, lmax + 1))
    _legendre_rows(np.cos(theta), np.sin(theta), lmax, leg)
    dphi = 2.0 * np.pi / width
    if weights == "cell":
        half = np.abs(ms) * dphi / 2.0
        col = dphi * np.where(half > 0, np.sin(half) / np.where(half > 0, half, 1.0), 1.0)  # exact column integral
        rows = _cell_row_integrals(height, lmax)
        weighted = rows * col[:, None, None]
    else:
        w = row_solid_angles(height, width) if weights == "centre" else row_quadrature_weights(height, width)
        weighted = leg * w[None, :, None]
    weighted = np.ascontiguousarray(weighted.transpose(0, 2, 1))
    l_idx, m_idx = degrees_orders(lmax)
    k_j, k_l = (m_idx + lmax).astype(np.int64), l_idx.astype(np.int64)
    q_l = np.concatenate([np.arange(m, lmax + 1) for m in range(lmax + 1)])
    q_m = np.concatenate([np.full(lmax + 1 - m, m) for m in range(lmax + 1)])
    q_index = {(int(l), int(m)): q for q, (l, m) in enumerate(zip(q_l, q_m))}
    k_q = np.array([q_index[(int(l), abs(int(m)))] for l, m in zip(l_idx, m_idx)], dtype=np.int64)
    q_from_k = np.zeros((q_l.size, k_q.size))
    q_from_k[k_q, np.arange(k_q.size)] = 1.0
    out = GridTables(
        trig, leg, weighted, k_j, k_l, k_q,
        weighted_q=np.ascontiguousarray(weighted[q_m + lmax, q_l, :]),
        legendre_q=np.ascontiguousarray(leg[q_m + lmax, :, q_l].T),
        q_from_k=q_from_k,
    )
    for a in (out.trig, out.legendre, out.weighted, out.weighted_q, out.legendre_q, out.q_from_k):
        a.setflags(write=False)  # float tables; the int index arrays stay writable so torch can index with them
    return out
