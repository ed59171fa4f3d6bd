"""Projection of equirect maps onto SH and reconstruction, by separable per-row evaluation.

On an equirect grid Y_lm(y, x) = Pbar_l^|m|(row y) * trig_m(column x), so no (H, W, K) basis is
ever built. Two contraction orders, chosen by cost (both one GEMM-shaped product per row block):
- rows first (lmax <= 8): (Q, H) @ (H, W*C) with Q = (lmax+1)(lmax+2)/2 Legendre rows, then a tiny
  per-coefficient sum over columns;
- columns first (lmax > 8): (H*C, W) @ (W, 2 lmax + 1), then a small batched product over rows.
Images are processed in row blocks so 8192 x 4096 inputs allocate no large temporaries.
"""
from __future__ import annotations

from .._backend import _NUMPY, float_array
from ..packed import PackedImage
from .grid import grid_tables
from .indexing import check_lmax, lmax_from_count

_BLOCK_ELEMS = 1 << 22  # ~4M input values (16 MB float32) per row block
ROWS_FIRST_MAX_LMAX = 8  # measured crossover on a 2-core x86 machine (training/benchmarks/bench_sh.py)


def _check_image(img):
    if img.ndim < 3:
        raise ValueError(f"image must have shape (H, W, C) or (..., H, W, C), got {tuple(img.shape)}")
    h, w, c = img.shape[-3:]
    if h < 1 or w < 1 or c < 1:
        raise ValueError(f"image is empty: shape {tuple(img.shape)}")
    return h, w, c


def _row_block(shape_lead, width, channels) -> int:
    batch = 1
    for n in shape_lead:
        batch *= n
    return max(1, _BLOCK_ELEMS // max(1, batch * width * channels))


def project(image, lmax: int, weights: str = "cell"):
    """SH coefficients of an equirect radiance map.

    image: (H, W, C) or batched (..., H, W, C) linear radiance, numpy or torch (any float dtype), or a
      ``packed.PackedImage`` (read by row blocks, as its float32 or float64 array would be).
    weights: "cell" (default): the exact projection of the image taken as piecewise-constant
      radiance over its pixels' cells (exact pixel solid angles; a constant map gives exactly
      L_00 = sqrt(4 pi) * value at any size); "centre": basis at pixel centres times the exact
      pixel solid angle (agrees with "cell" to O(1/H^2)); "quadrature": Fejer weights, exact for
      band-limited maps when H, W > 2 lmax (use it for round trips at high order).
    Returns (..., K, C), K = (lmax+1)^2, same array kind and float dtype as the input.
    """
    lmax = check_lmax(lmax)
    xp, img = (_NUMPY, image) if isinstance(image, PackedImage) else float_array(image, "image")
    h, w, c = _check_image(img)
    tab = grid_tables(h, w, lmax, weights)
    lead = tuple(img.shape[:-3])
    rows = _row_block(lead, w, c)
    if lmax <= ROWS_FIRST_MAX_LMAX:
        pq = xp.const(tab.weighted_q, img)  # (Q, H)
        z = None
        for y0 in range(0, h, rows):
            blk = img[..., y0:y0 + rows, :, :]
            part = pq[:, y0:y0 + rows] @ blk.reshape(lead + (blk.shape[-3], w * c))
            z = part if z is None else z + part
        z = z.reshape(lead + (-1, w, c))[..., tab.k_q, :, :]  # (..., K, W, C)
        trig_k = xp.const(tab.trig[tab.k_j][:, None, :], img)  # (K, 1, W)
        return (trig_k @ z)[..., 0, :]
    trig_t = xp.const(tab.trig.T.copy(), img)  # (W, M)
    parts = []
    for y0 in range(0, h, rows):
        blk = xp.contiguous(img[..., y0:y0 + rows, :, :].swapaxes(-1, -2))  # (..., rows, C, W)
        n_rows = blk.shape[-3]
        parts.append((blk.reshape(-1, w) @ trig_t).reshape(lead + (n_rows, c, -1)))  # (..., rows, C, M)
    g = parts[0] if len(parts) == 1 else xp.concatenate(parts, axis=-3)
    weighted = xp.const(tab.weighted, img)  # (M, L+1, H)
    dense = weighted @ xp.contiguous(g.swapaxes(-1, -2).swapaxes(-3, -2))  # (..., M, H, C)
    return dense[..., tab.k_j, tab.k_l, :]  # (..., M, L+1, C) -> (..., K, C)


def reconstruct(coeffs, height: int, width: int):
    """Radiance map of SH coefficients sampled at pixel centres.

    coeffs: (K, C) or batched (..., K, C) with K = (lmax+1)^2. Returns (..., H, W, C), same kind/dtype.
    """
    xp, c = float_array(coeffs, "coeffs")
    if c.ndim < 2:
        raise ValueError(f"coeffs must have shape (K, C) or (..., K, C), got {tuple(c.shape)}")
    lmax = lmax_from_count(c.shape[-2])
    tab = grid_tables(height, width, lmax)
    lead, n_c = tuple(c.shape[:-2]), c.shape[-1]
    if lmax <= ROWS_FIRST_MAX_LMAX:
        # Z[q, x, c] = sum over k with Legendre row q of trig_k(x) c_k, then one (H, Q) @ (Q, W*C) GEMM.
        trig_k = xp.const(tab.trig[tab.k_j], c)  # (K, W)
        zk = trig_k[:, :, None] * c[..., :, None, :]  # (..., K, W, C)
        z = xp.const(tab.q_from_k, c) @ zk.reshape(lead + (zk.shape[-3], width * n_c))  # (..., Q, W*C)
        out = xp.const(tab.legendre_q, c) @ z  # (H, Q) @ (..., Q, W*C)
        return out.reshape(lead + (height, width, n_c))
    n_m = 2 * lmax + 1
    dense = xp.zeros(lead + (n_m, lmax + 1, n_c), like=c)
    dense[..., tab.k_j, tab.k_l, :] = c
    g = xp.const(tab.legendre, c) @ dense  # (M, H, L+1) @ (..., M, L+1, C) -> (..., M, H, C)
    g = xp.contiguous(g.swapaxes(-3, -2).swapaxes(-2, -1))  # (..., H, C, M)
    out = (g.reshape(-1, n_m) @ xp.const(tab.trig, c)).reshape(lead + (height, n_c, width))
    return xp.contiguous(out.swapaxes(-1, -2))
