"""Coefficient indexing: k = l*l + l + m, K = (lmax+1)^2 (CONVENTIONS.md)."""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np


def num_coeffs(lmax: int) -> int:
    """Number of coefficients K = (lmax+1)^2 for bands 0..lmax."""
    return (check_lmax(lmax) + 1) ** 2


def check_lmax(lmax) -> int:
    """Validate an SH order: a non-negative integer. Returns it as int."""
    if isinstance(lmax, bool) or not isinstance(lmax, (int, np.integer)) or lmax < 0:
        raise ValueError(f"lmax must be a non-negative integer, got {lmax!r}")
    return int(lmax)


def lmax_from_count(k: int) -> int:
    """Inverse of num_coeffs; raises ValueError if ``k`` is not a perfect square."""
    lmax = math.isqrt(int(k)) - 1
    if k < 1 or (lmax + 1) ** 2 != k:
        raise ValueError(f"{k} SH coefficients is not (lmax+1)^2 for any lmax")
    return lmax


@lru_cache(maxsize=64)
def degrees_orders(lmax: int) -> tuple[np.ndarray, np.ndarray]:
    """(l, m) integer arrays of length K in coefficient order."""
    l = np.concatenate([np.full(2 * b + 1, b) for b in range(lmax + 1)])
    m = np.concatenate([np.arange(-b, b + 1) for b in range(lmax + 1)])
    l.setflags(write=False)
    m.setflags(write=False)
    return l, m
