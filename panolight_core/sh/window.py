"""Deringing windows: per-band attenuation w_l applied to L_lm (Sloan 2008, 2017; paper Sec. 3.4).

Every family is a function of t = l / width that is 1 at t = 0 and 0 for t >= 1:
  sinc4   : (sin(pi t) / (pi t))^4   (the paper's window; its code uses width 6 at lmax 2)
  lanczos : sin(pi t) / (pi t)
  hanning : (1 + cos(pi t)) / 2
Larger width = weaker window; width = inf is the identity and width = 1 keeps only L_00.
"auto" finds the weakest window of a family whose reconstruction is non-negative on a dense grid.
"""
from __future__ import annotations

import math

import numpy as np

from .._backend import backend, float_array
from .grid import check_grid
from .indexing import check_lmax, degrees_orders, lmax_from_count

FAMILIES = ("sinc4", "lanczos", "hanning")


def default_width(lmax: int) -> float:
    """The default width 2 (lmax + 1): 6 at lmax 2, as in the paper's code."""
    return 2.0 * (check_lmax(lmax) + 1)


def window_weights(lmax: int, kind: str = "sinc4", width: float | None = None) -> np.ndarray:
    """(lmax+1,) float64 band weights w_l of a window family at a width (> 0; inf = identity)."""
    lmax = check_lmax(lmax)
    if kind not in FAMILIES:
        raise ValueError(f"window kind must be one of {FAMILIES + ('auto',)}, got {kind!r}")
    width = default_width(lmax) if width is None else float(width)
    if not width > 0:
        raise ValueError(f"window width must be positive, got {width}")
    t = np.arange(lmax + 1) / width
    if kind == "hanning":
        w = 0.5 * (1.0 + np.cos(np.pi * t))
    else:
        w = np.sinc(t) ** (4 if kind == "sinc4" else 1)
    return np.where(t < 1.0, w, 0.0)


def window(coeffs, kind: str = "sinc4", width: float | None = None, *, target: str = "radiance",
           tolerance: float = 1e-6):
    """Apply a deringing window to (..., K, C) coefficients (numpy or torch; differentiable).

    kind: "sinc4" | "lanczos" | "hanning" with ``width`` (default 2 (lmax+1)), or "auto": the weakest
    sinc4 window keeping the reconstructed ``target`` ("radiance" or "irradiance") >= -tolerance x
    its mean on a dense grid, chosen per batch item (see ``auto_window_width``).
    """
    xp, c = float_array(coeffs, "coeffs")
    lmax = lmax_from_count(c.shape[-2])
    l_idx, _ = degrees_orders(lmax)
    if kind == "auto":
        flat = xp.to_numpy(c).reshape((-1,) + tuple(c.shape[-2:]))
        widths = [auto_window_width(item, "sinc4", target, tolerance) for item in flat]
        w = np.stack([window_weights(lmax, "sinc4", wd)[l_idx] for wd in widths])
        w = w.reshape(tuple(c.shape[:-2]) + (l_idx.size, 1))
    else:
        w = window_weights(lmax, kind, width)[l_idx][:, None]
    return c * xp.const(np.ascontiguousarray(w), c)


def min_over_grid(coeffs: np.ndarray, target: str = "radiance") -> np.ndarray:
    """(C,) minimum of the reconstructed radiance or irradiance over a dense equirect grid.

    coeffs: (K, C). The grid has max(64, 8 (lmax+1)) rows, enough to resolve lobes of band lmax.
    """
    from .irradiance import convolve_lambert
    from .transform import reconstruct

    c = np.asarray(coeffs, dtype=np.float64)
    lmax = lmax_from_count(c.shape[-2])
    if target not in ("radiance", "irradiance"):
        raise ValueError(f"target must be 'radiance' or 'irradiance', got {target!r}")
    if target == "irradiance":
        c = convolve_lambert(c)
    h = max(64, 8 * (lmax + 1))
    check_grid(h, 2 * h)
    return reconstruct(c, h, 2 * h).reshape(-1, c.shape[-1]).min(axis=0)


BISECTIONS = 40  # bisection steps of auto_window_width: the width to 2^-40 of its range


def auto_window_width(coeffs, family: str = "sinc4", target: str = "radiance", tolerance: float = 1e-6) -> float:
    """Largest width (weakest window) of ``family`` with the reconstruction non-negative.

    Returns math.inf when no window is needed. Bisection on 1/width in (0, 1]; width 1 keeps L_00
    only, which is feasible exactly when L_00 >= 0 in every channel. Raises ValueError when the mean
    radiance is negative (no window can make such lighting non-negative).
    """
    c = np.asarray(backend(coeffs).to_numpy(coeffs), dtype=np.float64)
    if c.ndim != 2:
        raise ValueError(f"auto window needs (K, C) coefficients, got {c.shape}")
    lmax = lmax_from_count(c.shape[0])
    if not np.all(np.isfinite(c)):
        raise ValueError("coefficients contain NaN or Inf; cannot choose a window")
    if np.any(c[0] < 0):
        raise ValueError("L_00 is negative (negative mean radiance): no window makes this lighting non-negative")
    l_idx, _ = degrees_orders(lmax)
    scale = np.maximum(c[0] / math.sqrt(4.0 * math.pi), np.finfo(float).tiny)
    if target == "irradiance":
        scale = scale * math.pi

    def ok(width: float) -> bool:
        w = window_weights(lmax, family, width)[l_idx][:, None]
        return bool(np.all(min_over_grid(c * w, target) >= -tolerance * scale))

    if ok(math.inf):
        return math.inf
    lo, hi = 0.0, 1.0  # strength s = 1 / width; s = hi is feasible
    for _ in range(BISECTIONS):
        mid = 0.5 * (lo + hi)
        if ok(1.0 / mid):
            hi = mid
        else:
            lo = mid
    return 1.0 / hi
