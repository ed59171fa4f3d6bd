"""numpy inference operators matching torch.nn.functional (NCHW float32), for torch-free inference.

conv2d uses an im2col + one matrix product per call; padding modes "zeros" and "equirect" (circular in
width, replicated in height: the natural padding of a 360-degree panorama).
"""
from __future__ import annotations

import numpy as np


def pad(x: np.ndarray, p: int, mode: str = "zeros") -> np.ndarray:
    """Pad (N, C, H, W) by p on every side: "zeros", or "equirect" (wrap in W, edge in H)."""
    if p == 0:
        return x
    if mode == "zeros":
        return np.pad(x, ((0, 0), (0, 0), (p, p), (p, p)))
    if mode == "equirect":
        x = np.concatenate([x[..., -p:], x, x[..., :p]], axis=-1)
        return np.pad(x, ((0, 0), (0, 0), (p, p), (0, 0)), mode="edge")
    raise ValueError(f"padding mode must be 'zeros' or 'equirect', got {mode!r}")


def conv2d(x: np.ndarray, weight: np.ndarray, bias: np.ndarray | None = None, stride: int = 1,
           padding: int = 0, mode: str = "zeros") -> np.ndarray:
    """(N, Cin, H, W) * (Cout, Cin, k, k) -> (N, Cout, H', W'), as torch.nn.functional.conv2d."""
    n, cin, _, _ = x.shape
    cout, cin_w, k, k2 = weight.shape
    if cin != cin_w or k != k2:
        raise ValueError(f"conv2d: input has {cin} channels, weight {weight.shape}")
    xp = pad(x, padding, mode)
    hp, wp = xp.shape[-2:]
    ho, wo = (hp - k) // stride + 1, (wp - k) // stride + 1
    s = xp.strides
    cols = np.lib.stride_tricks.as_strided(
        xp, shape=(n, cin, k, k, ho, wo), strides=(s[0], s[1], s[2], s[3], s[2] * stride, s[3] * stride),
        writeable=False)
    cols = cols.reshape(n, cin * k * k, ho * wo)
    out = weight.reshape(cout, -1).astype(x.dtype) @ cols  # (N, Cout, Ho*Wo)
    if bias is not None:
        out += bias.astype(x.dtype)[None, :, None]
    return out.reshape(n, cout, ho, wo)


def elu(x: np.ndarray) -> np.ndarray:
    """ELU (alpha 1, as torch's default the networks were trained with): x for x > 0, exp(x) - 1 otherwise (expm1,
    no overflow for large x)."""
    return np.where(x > 0, x, np.expm1(np.minimum(x, 0.0)))


def linear(x: np.ndarray, weight: np.ndarray, bias: np.ndarray | None = None) -> np.ndarray:
    """(..., in) @ (out, in)^T + bias, as torch.nn.functional.linear."""
    out = x @ weight.T.astype(x.dtype)
    return out + bias.astype(x.dtype) if bias is not None else out


def upsample_nearest2x(x: np.ndarray) -> np.ndarray:
    """(N, C, H, W) -> (N, C, 2H, 2W), as F.interpolate(scale_factor=2, mode="nearest")."""
    return x.repeat(2, axis=-2).repeat(2, axis=-1)
