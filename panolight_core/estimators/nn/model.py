"""The learned estimator's forward pass in numpy (no torch): same weights, same numbers as
training/neural/models.py (to ~1e-5), so a stock Blender can run it. Weights: {name: array} with the torch
parameter names; config: the dict of training/neural/configs/*.json."""
from __future__ import annotations

import numpy as np

from ... import sh
from ...camera.color import srgb_to_linear
from .ops import conv2d, elu, linear, upsample_nearest2x
from .prior import spectral_prior


def _conv(x, weights, name, stride=1):
    return conv2d(x, weights[f"{name}.conv.weight"], weights[f"{name}.conv.bias"], stride, 1, "equirect")


def forward(weights: dict, config: dict, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """x: (N, 7, H, 2H) float32 from inputs.network_input -> ((N, K, 3) coefficients, (N, 3, H, 2H) HDR
    estimate), in the LDR's linear units (1 = the camera's clip level)."""
    x = np.asarray(x, dtype=np.float32)
    feats, h = [x], x
    for i in range(len(config["ae_widths"])):
        h = elu(_conv(h, weights, f"ae.enc.{i}", stride=2))
        feats.append(h)
    for i, skip in enumerate(reversed(feats[:-1])):
        h = elu(_conv(np.concatenate([upsample_nearest2x(h), skip], axis=1), weights, f"ae.dec.{i}"))
    log_gain = np.minimum(_conv(h, weights, "ae.out") + x[:, 4:7], 20.0)
    srgb, a = x[:, :3], x[:, 3:4]
    lin = srgb_to_linear(srgb)
    hdr = lin + a * np.exp(log_gain)
    h = np.log1p(np.maximum(hdr, 0.0))
    for i, s in enumerate(config["encoder_strides"]):
        h = elu(_conv(h, weights, f"encoder.convs.{i}", stride=s))
    h = elu(linear(h.reshape(h.shape[0], -1), weights["encoder.fc1.weight"], weights["encoder.fc1.bias"]))
    k = (config["lmax"] + 1) ** 2
    coeffs = linear(h, weights["encoder.fc2.weight"], weights["encoder.fc2.bias"]).reshape(-1, k, 3)
    if config.get("prior", True):
        coeffs = spectral_prior(coeffs.astype(np.float64)).astype(np.float32)
    if config.get("head", "encoder") == "residual":
        coeffs = coeffs + sh.project(np.moveaxis(hdr, 1, -1), config["lmax"]).astype(np.float32)
    return coeffs, hdr
