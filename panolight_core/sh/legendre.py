"""Normalised associated Legendre functions by the stable three-term recurrence in l.

One recurrence serves two uses:
- ``sin_theta`` given: Pbar_l^m(z) including the sin^m(theta) factor (equirect grid rows; no division
  anywhere, values underflow gracefully to 0 near the poles at high m);
- ``sin_theta=None``: the polynomial part Qbar_l^m(z) = Pbar_l^m / sin^m (for direction vectors,
  where sin^m(theta) cos(m phi) is computed as Re((x + i y)^m) without square roots, so it is
  differentiable everywhere, poles included).
Normalisation: Y_lm = Pbar_l^|m| * (1 for m = 0, sqrt(2) cos / sin(|m| phi) otherwise), i.e. Pbar
already contains sqrt((2l+1)/(4 pi) (l-m)!/(l+m)!), no Condon-Shortley phase.
"""
from __future__ import annotations

import math


def legendre_table(z, lmax: int, sin_theta=None):
    """Dict {(l, m): array like z} for 0 <= m <= l <= lmax (works for numpy and torch)."""
    out = {}
    pmm = None
    for m in range(lmax + 1):
        if m == 0:
            pmm = z * 0 + 1.0 / math.sqrt(4.0 * math.pi)
        else:
            factor = math.sqrt((2.0 * m + 1.0) / (2.0 * m))
            pmm = pmm * factor if sin_theta is None else pmm * (factor * sin_theta)
        out[(m, m)] = pmm
        if m == lmax:
            break
        p_prev, p_cur = pmm, z * (math.sqrt(2.0 * m + 3.0)) * pmm
        out[(m + 1, m)] = p_cur
        for l in range(m + 2, lmax + 1):
            a = math.sqrt((4.0 * l * l - 1.0) / (l * l - m * m))
            b = math.sqrt(((l - 1.0) ** 2 - m * m) / (4.0 * (l - 1.0) ** 2 - 1.0))
            p_prev, p_cur = p_cur, a * (z * p_cur - b * p_prev)
            out[(l, m)] = p_cur
    return out
