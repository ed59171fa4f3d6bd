"""The paper's losses (Sec. 3.3), in torch, safe at the extremes (zeros, huge values, black images).

L_SH  mean squared coefficient error;
L_RC  solid-angle weighted mean squared error of the reconstructed radiance maps (dense supervision);
L_RL  photometric: alpha * L1 of log(1 + HDR) + (1 - alpha) * (1 - SSIM) / 2 between the original image
      re-rendered (paper Eq. 5) under the true and the predicted lighting;
total = 0.01 L_SH + 0.3 L_RC + 0.7 L_RL.
Scale-free training (``total_loss(..., scale=...)``, what training/neural/train.py uses; targets span 10^4 in
brightness): L_SH takes the per-sample ``scale`` (B,) (the target's mean radiance) and enters as
log(1 + e / scale^2) of each sample's squared error e; L_RC becomes the batch mean of EVALUATION.md's
m-RMSE of the reconstructions (``reconstruction_loss(relative=True)``).
"""
from __future__ import annotations

import torch
import torch.nn.functional as F

from panolight_core import sh
from panolight_core.lighting.relight import relight

WEIGHTS = {"sh": 0.01, "rc": 0.3, "rl": 0.7}


def equirect_pad(x: torch.Tensor, p: int) -> torch.Tensor:
    """Pad (N, C, H, W): circular in width, replicated in height (panolight_core.estimators.nn.ops.pad "equirect")."""
    if p == 0:
        return x
    x = F.pad(x, (p, p, 0, 0), mode="circular")
    return F.pad(x, (0, 0, p, p), mode="replicate")


def _per_sample(err: torch.Tensor, scale) -> torch.Tensor:
    if scale is None:
        return err.mean()
    return torch.log1p(err / scale.to(err.dtype) ** 2).mean()  # relative, and robust to wild outliers


def sh_loss(pred: torch.Tensor, target: torch.Tensor, scale=None) -> torch.Tensor:
    """Mean squared coefficient error of (B, K, 3) sets."""
    return _per_sample(((pred - target) ** 2).flatten(1).mean(-1), scale)


def reconstruction_loss(pred: torch.Tensor, target: torch.Tensor, height: int = 32, relative: bool = False) -> torch.Tensor:
    """Solid-angle weighted L2 of (B, K, 3) coefficient sets reconstructed on a (height, 2 height) grid.

    relative: the batch mean of EVALUATION.md's m-RMSE instead (prediction median-scaled to the target,
    root of the weighted squared error over the target's weighted mean): scale-free, and it punishes a
    light guessed too bright as hard as the evaluation does."""
    w = torch.as_tensor(sh.row_solid_angles(height, 2 * height) / (4 * torch.pi), dtype=pred.dtype)
    q, g = sh.reconstruct(pred, height, 2 * height), sh.reconstruct(target, height, 2 * height)
    if not relative:
        return ((((q - g) ** 2).mean(-1).sum(-1) * w).sum(-1)).mean()
    med_q, med_g = q.flatten(1).median(-1).values, g.flatten(1).median(-1).values
    s = torch.where(med_q > 0, med_g / torch.clamp(med_q, min=torch.finfo(q.dtype).tiny), torch.ones_like(med_q))
    err = (((s[:, None, None, None] * q - g) ** 2).mean(-1).sum(-1) * w).sum(-1)
    mean_g = (g.mean(-1).sum(-1) * w).sum(-1)
    return (torch.sqrt(err + 1e-12) / torch.clamp(mean_g, min=1e-6)).mean()


def _gaussian(window: int, sigma: float, dtype) -> torch.Tensor:
    t = torch.arange(window, dtype=dtype) - (window - 1) / 2
    g = torch.exp(-(t ** 2) / (2 * sigma ** 2))
    return g / g.sum()


def ssim(a: torch.Tensor, b: torch.Tensor, window: int = 7, sigma: float = 1.5) -> torch.Tensor:
    """Mean SSIM of (N, C, H, W) images in [0, ~1] (Wang et al. 2004 constants), equirect-padded."""
    c1, c2 = 0.01 ** 2, 0.03 ** 2
    g = _gaussian(window, sigma, a.dtype)
    kernel = (g[:, None] * g[None, :]).expand(a.shape[1], 1, window, window).contiguous()

    def blur(x):
        return F.conv2d(equirect_pad(x, window // 2), kernel, groups=a.shape[1])

    mu_a, mu_b = blur(a), blur(b)
    var_a = blur(a * a) - mu_a ** 2
    var_b = blur(b * b) - mu_b ** 2
    cov = blur(a * b) - mu_a * mu_b
    s = ((2 * mu_a * mu_b + c1) * (2 * cov + c2)) / ((mu_a ** 2 + mu_b ** 2 + c1) * (var_a + var_b + c2))
    return s.mean()


def photometric_loss(image: torch.Tensor, normals: torch.Tensor, pred: torch.Tensor, target: torch.Tensor,
                     alpha: float = 0.85) -> torch.Tensor:
    """image, normals: (B, H, W, 3); pred, target: (B, K, 3). Compares the relit HDR images in log space."""
    lit_true = torch.log1p(torch.clamp(relight(image, normals, target), min=0.0))
    lit_pred = torch.log1p(torch.clamp(relight(image, normals, pred), min=0.0))
    l1 = (lit_true - lit_pred).abs().mean()
    scale = torch.clamp(lit_true.detach().amax(dim=(1, 2, 3), keepdim=True), min=1e-6)  # SSIM wants ~[0, 1]
    a = (lit_true / scale).permute(0, 3, 1, 2)
    b = (lit_pred / scale).permute(0, 3, 1, 2)
    return alpha * l1 + (1 - alpha) * (1 - ssim(a, b)) / 2


def total_loss(image, normals, pred, target, weights=None, scale=None) -> tuple[torch.Tensor, dict]:
    """The weighted sum and its parts; ``weights`` overrides WEIGHTS (0 switches a term off, for ablations)."""
    w = {**WEIGHTS, **(weights or {})}
    parts = {"sh": sh_loss(pred, target, scale), "rc": reconstruction_loss(pred, target, relative=scale is not None),
             "rl": photometric_loss(image, normals, pred, target) if w["rl"] else pred.sum() * 0}
    total = sum(w[k] * v for k, v in parts.items())
    return total, {k: float(v.detach()) for k, v in parts.items()}
