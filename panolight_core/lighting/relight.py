"""The paper's relighting (Eq. 5) and the lighting manipulations used to make training pairs.

relight(I, N, L) = E(N, L) * I: every pixel of a panorama I, taken as a diffuse surface with normal N,
is lit by SH radiance L (its irradiance E from the A_l kernel). numpy or torch (differentiable), batched.
Training inputs follow the paper (Sec. 3.2-3.4): two HDR lighting maps blended with weight lambda
(blending commutes with projection, so it is done on coefficients), scaled x100 for LDR relighting,
deringed, and the relit HDR image turned into the camera's 8-bit LDR (EVALUATION.md model).
"""
from __future__ import annotations

import numpy as np

from .. import sh
from .._backend import float_array

LDR_SCALE = 100.0  # the paper scales the blended coefficients by 100 before relighting LDR panoramas


def relight(image, normals, coeffs):
    """E(normals, coeffs) * image.

    image: (..., H, W, 3) (numpy or torch), normals: (..., H, W, 3) unit vectors in the world frame
    (zero vectors for pixels without a surface give 0), coeffs: (K, 3) or batched (B, K, 3) matching a
    leading batch of image and normals. Returns (..., H, W, 3), differentiable in all three with torch.
    """
    xp, img = float_array(image, "image")
    _, n = float_array(normals, "normals")
    _, c = float_array(coeffs, "coeffs")
    if tuple(img.shape) != tuple(n.shape):
        raise ValueError(f"image {tuple(img.shape)} and normals {tuple(n.shape)} must have the same shape")
    lmax = sh.lmax_from_count(c.shape[-2])
    y = sh.basis(n, lmax, check_unit=False)  # (..., H, W, K)
    ec = sh.convolve_lambert(c)
    if c.ndim == 2:
        e = y @ ec
    else:
        b = c.shape[0]
        e = (y.reshape(b, -1, y.shape[-1]) @ ec).reshape(tuple(y.shape[:-1]) + (c.shape[-1],))
    surface = ((n * n).sum(-1, keepdims=True) > 0.25) * 1.0  # zero normals: no surface, no light
    return e * img * surface


def blend(coeffs_a, coeffs_b, lam):
    """lambda * a + (1 - lambda) * b: the SH of the blended lighting maps (projection is linear)."""
    return lam * coeffs_a + (1.0 - lam) * coeffs_b


def training_lighting(coeffs_a, coeffs_b, lam: float, scale: float = LDR_SCALE, window_width: float | None = None):
    """The lighting of one training pair: blend, scale for LDR relighting, sinc^4-dering (width default
    2 (lmax+1), the paper's 6 at lmax 2). Returns (target coefficients, coefficients used to relight)."""
    target = blend(coeffs_a, coeffs_b, lam)
    return target, sh.window(target * scale, "sinc4", window_width)


def simulate_ldr(relit: np.ndarray) -> np.ndarray:
    """The relit HDR panorama as the camera would store it at ev 0 (uint8, EVALUATION.md exposure model; the mean
    stands in for the median when most pixels are black, as when a sky is masked)."""
    from ..camera import hdr_to_ldr

    return hdr_to_ldr(np.asarray(relit, dtype=np.float64), 0.0, None, robust=True)
