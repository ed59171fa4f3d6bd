"""The learned estimator at inference time: shipped weights, loaded without torch or pickle.

``DEFAULT_WEIGHTS`` (panolight_core/models/small.safetensors, with its model card beside it) holds the
trained ``small`` configuration; its JSON config travels in the safetensors metadata. ``predict`` runs
the numpy forward pass (panolight_core.estimators.nn.model), the same numbers as the torch modules to ~1e-5.
Coefficients are in the LDR's linear units (1 = the camera's clip level), Blender world frame.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from ... import sh
from ...errors import PanoLightError
from .inputs import CHANNELS, network_input
from .model import forward
from .safetensors_np import load_safetensors

MODEL_DIR = Path(__file__).resolve().parents[2] / "models"
DEFAULT_WEIGHTS = MODEL_DIR / "small.safetensors"
REQUIRED = ("input_height", "lmax", "ae_widths", "encoder_widths", "encoder_strides", "hidden")


@dataclass(frozen=True)
class Model:
    weights: dict
    config: dict
    path: Path


@lru_cache(maxsize=8)
def load_model(path=DEFAULT_WEIGHTS) -> Model:
    """Weights + config of a model file; PanoLightError naming the file when it is missing or unusable."""
    path = Path(path)
    if not path.is_file():
        raise PanoLightError(f"{path}: no model weights there (the learned estimator ships them in "
                             f"panolight_core/models/; train your own with 'panolight train')")
    weights, meta = load_safetensors(path)
    try:
        config = json.loads(meta["config"])
    except (KeyError, TypeError, json.JSONDecodeError):
        raise PanoLightError(f"{path}: the weights carry no model config (export with training.train.export)") from None
    missing = [k for k in REQUIRED if k not in config]
    if missing:
        raise PanoLightError(f"{path}: the model config lacks {', '.join(missing)}")
    first = weights.get("ae.enc.0.conv.weight")
    if first is None or first.ndim != 4 or first.shape[1] != CHANNELS:
        raise PanoLightError(f"{path}: not a PanoLight lighting network (unexpected first layer)")
    return Model({k: v.astype(np.float32) for k, v in weights.items()}, config, path)


def predict(model: Model, ldr: np.ndarray, lmax: int) -> tuple[np.ndarray, np.ndarray]:
    """(H, 2H, 3) uint8 sRGB panorama -> ((K, 3) float64 SH radiance, (h, 2h, 3) float64 HDR estimate).

    Bands up to the model's order come from the lighting encoder; higher bands (lmax above it) from the
    projection of the autoencoder's HDR map, so any order can be asked for."""
    x = network_input(ldr, model.config["input_height"], model.config.get("guess", "analytic"),
                      model.config.get("source_model"))
    coeffs, hdr = forward(model.weights, model.config, x[None])
    hdr = np.moveaxis(hdr[0].astype(np.float64), 0, -1)
    out = sh.project(hdr, lmax).astype(np.float64)
    k = min(out.shape[0], coeffs.shape[1])
    out[:k] = coeffs[0, :k]
    return out, hdr
