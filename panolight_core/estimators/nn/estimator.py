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
from ...io.safetensors_np import load_safetensors
from .inputs import CHANNELS, network_input
from .model import forward

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
    except (KeyError, TypeError, json.JSONDecodeError, RecursionError):
        raise PanoLightError(f"{path}: the weights carry no model config (export with training.neural.train.export)") from None
    if not isinstance(config, dict):
        raise PanoLightError(f"{path}: the model config is not a JSON object")
    missing = [k for k in REQUIRED if k not in config]
    if missing:
        raise PanoLightError(f"{path}: the model config lacks {', '.join(missing)}")
    _check_config(path, config)
    first = weights.get("ae.enc.0.conv.weight")
    if first is None or first.ndim != 4 or first.shape[1] != CHANNELS:
        raise PanoLightError(f"{path}: not a PanoLight lighting network (unexpected first layer)")
    weights = {k: v.astype(np.float32) for k, v in weights.items()}
    for name, v in weights.items():
        if not np.isfinite(v).all():
            raise PanoLightError(f"{path}: tensor {name!r} holds NaN or Inf weights (a diverged training run?)")
    h = config["input_height"]
    try:  # one dry pass: every tensor the config needs is there, with a shape that fits
        with np.errstate(all="ignore"):
            forward(weights, config, np.zeros((1, CHANNELS, h, 2 * h), np.float32))
    except KeyError as exc:
        raise PanoLightError(f"{path}: the weights lack the tensor {exc.args[0]!r} that the model config needs") from None
    except (ValueError, IndexError, TypeError) as exc:
        raise PanoLightError(f"{path}: the weights do not fit the model config ({exc})") from None
    return Model(weights, config, path)


MAX_INPUT_HEIGHT = 1024  # the network's own input rows (the shipped models use 64-128)


def _check_config(path, config: dict) -> None:
    """The config's numbers are of the kind and size a lighting network has, before any array is made."""
    def ints(v, lo, hi):
        return isinstance(v, int) and not isinstance(v, bool) and lo <= v <= hi

    def int_list(v, lo, hi):
        return isinstance(v, list) and 0 < len(v) <= 16 and all(ints(x, lo, hi) for x in v)

    problems = []
    if not ints(config["input_height"], 8, MAX_INPUT_HEIGHT):
        problems.append(f"input_height {config['input_height']!r} (8 to {MAX_INPUT_HEIGHT})")
    if not ints(config["lmax"], 0, 16):
        problems.append(f"lmax {config['lmax']!r} (0 to 16)")
    for key, lo, hi in (("ae_widths", 1, 4096), ("encoder_widths", 1, 4096), ("encoder_strides", 1, 4)):
        if not int_list(config[key], lo, hi):
            problems.append(f"{key} {config[key]!r} (a list of integers {lo} to {hi})")
    if not ints(config["hidden"], 1, 1 << 16):
        problems.append(f"hidden {config['hidden']!r} (1 to 65536)")
    if not problems and config["input_height"] % (2 ** len(config["ae_widths"])):
        problems.append(f"input_height {config['input_height']} (a multiple of 2^{len(config['ae_widths'])}, "
                        f"the autoencoder's depth)")
    if problems:
        raise PanoLightError(f"{path}: the model config has an impossible {'; '.join(problems)}")


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
