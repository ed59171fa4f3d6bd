"""The paper's spectral prior (Sec. 3.4): tau(L) = ||L|| softmax(L), per colour channel.

The magnitude of each channel's coefficient vector is kept, its direction replaced by a softmax over
the coefficients, which pushes the distribution towards a few strong low-order terms. numpy or torch
(differentiable); the norm is computed on the vector scaled by its largest entry and the softmax is
shifted by its maximum, so huge inputs never overflow, and an all-zero vector maps to zero.
"""
from __future__ import annotations

import numpy as np

from ..._backend import backend, float_array


def spectral_prior(coeffs):
    """(..., K, C) -> (..., K, C): each channel's column becomes ||L|| softmax(L) over its K entries."""
    xp, c = float_array(coeffs, "coeffs")
    if xp.name == "torch":
        t = xp.t
        m = t.clamp(c.abs().amax(dim=-2, keepdim=True), min=t.finfo(c.dtype).tiny)
        norm = m * t.linalg.vector_norm(c / m, dim=-2, keepdim=True)  # scaled: no overflow
        return norm * t.softmax(c, dim=-2)
    m = np.maximum(np.abs(c).max(axis=-2, keepdims=True), np.finfo(c.dtype).tiny)
    norm = m * np.linalg.norm(c / m, axis=-2, keepdims=True)
    e = np.exp(c - c.max(axis=-2, keepdims=True))
    return norm * e / e.sum(axis=-2, keepdims=True)


__all__ = ["spectral_prior", "backend"]
