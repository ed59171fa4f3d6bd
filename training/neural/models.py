"""The paper's networks in torch (Sec. 3.3-3.4): an LDR-to-HDR autoencoder and a lighting encoder.

Autoencoder (HDR-CNN in spirit): a strided-convolution encoder and a nearest-upsampling decoder with
skip connections predict y, a log correction of the clipped excess radiance b that the physical
highlight model guesses (panolight_core.estimators.nn.inputs: colour x, clipped fraction a, log b per cell), and
hdr = linear(x) + a * b * exp(y): unclipped cells pass through unchanged, clipped ones get back the
energy the camera cut off. Its last layer starts at zero, so training starts from the physical model.
Lighting encoder: 7 convolutions (3 x 3, ELU) and 2 fully connected layers (ELU, then a linear head)
regressing (lmax + 1)^2 x 3 SH coefficients from log(1 + hdr); the spectral prior is optional.
Config "head": "encoder" (the paper: the coefficients are the encoder's) or "residual" (the encoder's
output is added to the exact SH projection of the autoencoder's HDR map, so it learns a correction).
All convolutions pad equirect-style (circular in width, replicated in height). Parameter names are
the contract with the numpy inference in panolight_core.estimators.nn.model.
"""
from __future__ import annotations

import json
from pathlib import Path

import torch
import torch.nn as nn
import torch.nn.functional as F

from panolight_core import sh
from panolight_core.camera.color import srgb_to_linear
from panolight_core.estimators.nn.inputs import CHANNELS
from panolight_core.estimators.nn.prior import spectral_prior
from training.neural.losses import equirect_pad

CONFIGS = Path(__file__).resolve().parent / "configs"


def load_config(name_or_path) -> dict:
    """A config by name (training/neural/configs/NAME.json, e.g. "small", "ablation/full-prior") or path.
    A config with "base" is that config with its own keys on top (the ablation variants)."""
    p = Path(name_or_path)
    if not p.suffix:
        p = CONFIGS / f"{name_or_path}.json"
    if not p.is_file():
        from panolight_core.errors import PanoLightError

        known = sorted(str(q.relative_to(CONFIGS).with_suffix("")) for q in CONFIGS.rglob("*.json"))
        raise PanoLightError(f"{name_or_path}: no such config (known: {', '.join(known)})")
    cfg = json.loads(p.read_text())
    base = cfg.pop("base", None)
    return {**load_config(base), **cfg} if base else cfg


class Conv(nn.Module):
    def __init__(self, cin, cout, stride=1):
        super().__init__()
        self.conv = nn.Conv2d(cin, cout, 3, stride=stride, padding=0)
        self.stride = stride

    def forward(self, x):
        return self.conv(equirect_pad(x, 1))


class Autoencoder(nn.Module):
    def __init__(self, widths):
        super().__init__()
        self.enc = nn.ModuleList()
        cin = CHANNELS
        for w in widths:
            self.enc.append(Conv(cin, w, stride=2))
            cin = w
        self.dec = nn.ModuleList()
        skips = [CHANNELS] + list(widths[:-1])  # the input and every encoder output but the last
        for w_skip in reversed(skips):
            cout = max(w_skip, 16)
            self.dec.append(Conv(cin + w_skip, cout))  # upsampled features + the skip at that scale
            cin = cout
        self.out = Conv(cin, 3)
        nn.init.zeros_(self.out.conv.weight)  # start from the physical model's guess
        nn.init.zeros_(self.out.conv.bias)

    def forward(self, x):
        feats, h = [x], x
        for conv in self.enc:
            h = F.elu(conv(h))
            feats.append(h)
        for conv, skip in zip(self.dec, reversed(feats[:-1])):
            h = F.interpolate(h, scale_factor=2, mode="nearest")
            h = F.elu(conv(torch.cat([h, skip], dim=1)))
        log_gain = torch.clamp(self.out(h) + x[:, 4:7], max=20.0)
        srgb, a = x[:, :3], x[:, 3:4]
        lin = srgb_to_linear(srgb)
        return lin + a * torch.exp(log_gain)


class LightingEncoder(nn.Module):
    def __init__(self, widths, strides, hidden, lmax, input_height):
        super().__init__()
        self.convs = nn.ModuleList()
        cin, h, w = 3, input_height, 2 * input_height
        for width, s in zip(widths, strides):
            self.convs.append(Conv(cin, width, stride=s))
            cin = width
            h, w = (h - 1) // s + 1, (w - 1) // s + 1
        self.fc1 = nn.Linear(cin * h * w, hidden)
        self.fc2 = nn.Linear(hidden, (lmax + 1) ** 2 * 3)
        self.k = (lmax + 1) ** 2

    def forward(self, hdr):
        h = torch.log1p(torch.clamp(hdr, min=0.0))
        for conv in self.convs:
            h = F.elu(conv(h))
        h = F.elu(self.fc1(h.flatten(1)))
        return self.fc2(h).view(-1, self.k, 3)


class LightingNet(nn.Module):
    """Network input (N, 7, H, 2H) (panolight_core.estimators.nn.inputs) -> (N, K, 3) SH coefficients and the
    (N, 3, H, 2H) HDR estimate, both in the units of the LDR's linear values (1 = the camera's clip level)."""

    def __init__(self, config: dict):
        super().__init__()
        self.config = config
        self.ae = Autoencoder(config["ae_widths"])
        self.encoder = LightingEncoder(config["encoder_widths"], config["encoder_strides"], config["hidden"],
                                       config["lmax"], config["input_height"])
        if config.get("head", "encoder") == "residual":  # start (almost) from the projection itself;
            nn.init.normal_(self.encoder.fc2.weight, std=1e-4)  # not exactly 0: the prior's norm has no
            nn.init.zeros_(self.encoder.fc2.bias)  # gradient there

    def forward(self, x):
        hdr = self.ae(x)
        coeffs = self.encoder(hdr)
        if self.config.get("prior", True):
            coeffs = spectral_prior(coeffs)
        if self.config.get("head", "encoder") == "residual":  # the encoder corrects the HDR map's projection
            coeffs = coeffs + sh.project(hdr.permute(0, 2, 3, 1), self.config["lmax"])
        return coeffs, hdr
