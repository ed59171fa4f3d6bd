"""Real orthonormal SH basis (no Condon-Shortley phase) evaluated at direction vectors."""
from __future__ import annotations

import math

from .._backend import float_array
from .indexing import check_lmax
from .legendre import legendre_table

_SQRT2 = math.sqrt(2.0)


def basis(directions, lmax: int, check_unit: bool = True):
    """Y_lm at unit vectors.

    directions: (..., 3) unit vectors (x, y, z) in the Blender world frame (Z up), numpy or torch.
    Returns (..., K) with K = (lmax+1)^2, index k = l*l + l + m; torch in -> torch out (differentiable).
    Uses the polynomial form: sin^m cos(m phi) = Re((x + i y)^m), so poles are exact and no
    square root or division is taken. Raises ValueError if vectors are not unit length (tol 1e-3)
    unless ``check_unit`` is False.
    """
    lmax = check_lmax(lmax)
    xp, d = float_array(directions, "directions")
    if d.ndim < 1 or d.shape[-1] != 3:
        raise ValueError(f"directions must have shape (..., 3), got {tuple(d.shape)}")
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    n = d.numel() if xp.name == "torch" else d.size
    if check_unit and n:
        err = float(xp.to_numpy(abs(x * x + y * y + z * z - 1.0).max()))
        if not err <= 1e-3:
            raise ValueError(f"directions must be unit vectors (largest | |d|^2 - 1 | = {err:.3g})")
    q = legendre_table(z, lmax)
    # c[m] = Re((x+iy)^m) = sin^m(theta) cos(m phi), s[m] = Im(...) = sin^m(theta) sin(m phi)
    c, s = [z * 0 + 1.0], [z * 0]
    for _ in range(lmax):
        c_prev, s_prev = c[-1], s[-1]
        c.append(x * c_prev - y * s_prev)
        s.append(x * s_prev + y * c_prev)
    cols = []
    for l in range(lmax + 1):
        for m in range(-l, l + 1):
            if m < 0:
                cols.append((_SQRT2 * q[(l, -m)]) * s[-m])
            elif m == 0:
                cols.append(q[(l, 0)])
            else:
                cols.append((_SQRT2 * q[(l, m)]) * c[m])
    return xp.stack(cols, axis=-1)
