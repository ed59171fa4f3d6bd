"""Choosing the SH order a scene needs (``--lmax auto``).

The diffuse relighting error of order l is the solid-angle weighted RMS difference between the
irradiance of the coefficients truncated to l and of the full set (order ``lmax_max``), divided by the
mean irradiance (no median scaling: a truncation changes shape, not scale). ``select_order`` returns
the smallest order whose error is at most ``tolerance``.
"""
from __future__ import annotations

import math

import numpy as np

from .. import sh

DEFAULT_TOLERANCE = 0.01
DEFAULT_MAX_ORDER = 8
_GRID = (64, 128)


def truncation_errors(coeffs: np.ndarray, extra_mean: float = 0.0) -> list[float]:
    """Relative irradiance error of truncating (K, C) coefficients to each order 0..lmax.

    extra_mean: mean irradiance of parts of the model that truncation leaves alone (explicit lights),
    added to the normaliser so the error is relative to the whole model's mean irradiance.
    """
    c = np.asarray(coeffs, dtype=np.float64)
    lmax = sh.lmax_from_count(c.shape[0])
    full = sh.irradiance_map(c, *_GRID)
    w = sh.pixel_solid_angles(*_GRID)[..., None]
    mean = float((w * full).sum() / (w.sum() * c.shape[1])) + extra_mean
    if not mean > 0:
        return [0.0 if not np.any(c) else math.inf] * (lmax + 1)
    errs = []
    for l in range(lmax + 1):
        t = sh.irradiance_map(c[:(l + 1) ** 2], *_GRID)
        errs.append(math.sqrt(float((w * (t - full) ** 2).sum() / (w.sum() * c.shape[1]))) / mean)
    return errs


def select_order(coeffs: np.ndarray, tolerance: float = DEFAULT_TOLERANCE,
                 extra_mean: float = 0.0) -> tuple[int, list[float]]:
    """(smallest order with truncation error <= tolerance, the error of every order)."""
    if not tolerance >= 0:
        raise ValueError(f"tolerance must be >= 0, got {tolerance}")
    errs = truncation_errors(coeffs, extra_mean)
    for l, e in enumerate(errs):
        if e <= tolerance:
            return l, errs
    return len(errs) - 1, errs
