"""The per-source model: gradient-boosted regression trees stored as arrays, and their loading.

``models/sources.safetensors`` (trained on real HDR panoramas by ``training/source_energy/fit.py``) maps a region's
FEATURES to the log of its energy ratio r = true energy / energy its cells hold, as a mean mu and a spread
sigma (the uncertainty). No pickle: safetensors arrays and a JSON header.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from ...errors import PanoLightError
from .features import FEATURES

MODEL_PATH = Path(__file__).resolve().parents[2] / "models" / "sources.safetensors"
HDR_MODEL_PATH = MODEL_PATH.with_name("sources_hdr.safetensors")  # the same trees, trained on clipped HDR files too:
# what restores an HDR file that clips its own source (``restore``)
TRAINED_MIN_WIDTH = 512  # the narrowest panorama (pixels) the shipped models' training cameras framed
# (training/source_energy/data.scene_view): in a narrower file a clipped source is weighed outside what they saw


@dataclass(frozen=True)
class TreeEnsemble:
    """Gradient-boosted regression trees as flat arrays (nodes of all trees concatenated).

    feature (N,) int (-1 at leaves), threshold (N,), left/right (N,) int (absolute node indices),
    value (N,) (leaf outputs, already multiplied by the learning rate), roots (T,) int; prediction =
    base + sum over trees of the leaf reached (x[feature] <= threshold goes left)."""

    feature: np.ndarray
    threshold: np.ndarray
    left: np.ndarray
    right: np.ndarray
    value: np.ndarray
    roots: np.ndarray
    base: float

    def predict(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=np.float64)
        if x.shape[0] == 0:
            return np.zeros(0)
        node = np.repeat(self.roots[None, :], x.shape[0], 0)  # (n, T)
        rows = np.arange(x.shape[0])[:, None]
        for _ in range(64):
            f = self.feature[node]
            inner = f >= 0
            if not inner.any():
                break
            go_left = x[rows, np.maximum(f, 0)] <= self.threshold[node]
            node = np.where(inner, np.where(go_left, self.left[node], self.right[node]), node)
        return self.base + self.value[node].sum(axis=1)


@dataclass(frozen=True)
class SourceModel:
    """mean: trees for mu = E[log r]; spread: trees for E|log r - mu| (sigma = sqrt(pi/2) x it). features: the
    names the trees' columns stand for, any of FEATURES in any order (a model trained on fewer still runs)."""

    mean: TreeEnsemble
    spread: TreeEnsemble
    shrink: float
    features: tuple
    meta: dict
    path: Path

    def predict(self, feats: np.ndarray):
        """(n, len(FEATURES)) features, in FEATURES' order (``Regions.features``) -> (mu, sigma, reported log
        ratio), each (n,), natural log."""
        feats = np.asarray(feats, dtype=np.float64)
        if tuple(self.features) != FEATURES:
            feats = feats[:, [FEATURES.index(n) for n in self.features]]
        mu = self.mean.predict(feats)
        sigma = math.sqrt(math.pi / 2.0) * np.maximum(self.spread.predict(feats), 0.02)
        return mu, sigma, np.maximum(mu - self.shrink * sigma ** 2, 0.0)


def ensemble_arrays(prefix: str, e: TreeEnsemble) -> dict:
    """Arrays to store an ensemble (safetensors names ``prefix.*``)."""
    return {f"{prefix}.feature": e.feature.astype(np.int32), f"{prefix}.threshold": e.threshold.astype(np.float64),
            f"{prefix}.left": e.left.astype(np.int32), f"{prefix}.right": e.right.astype(np.int32),
            f"{prefix}.value": e.value.astype(np.float64), f"{prefix}.roots": e.roots.astype(np.int32),
            f"{prefix}.base": np.array([e.base], dtype=np.float64)}


def _ensemble(t: dict, prefix: str, path: Path, n_features: int) -> TreeEnsemble:
    try:
        parts = {k: t[f"{prefix}.{k}"] for k in ("feature", "threshold", "left", "right", "value", "roots", "base")}
    except KeyError as exc:
        raise PanoLightError(f"{path}: not a PanoLight source-energy model (missing tensor {exc.args[0]})") from None
    n = parts["feature"].size
    for k in ("threshold", "left", "right", "value"):
        if parts[k].shape != (n,):
            raise PanoLightError(f"{path}: source-energy model tensor {prefix}.{k} has the wrong shape")
    inner = parts["feature"] >= 0
    kids = np.concatenate([parts["left"][inner], parts["right"][inner], parts["roots"]])
    if kids.size and (kids.min() < 0 or kids.max() >= n) or parts["feature"].max(initial=-1) >= n_features:
        raise PanoLightError(f"{path}: source-energy model has node or feature indices out of range")
    return TreeEnsemble(parts["feature"].astype(np.int64), parts["threshold"], parts["left"].astype(np.int64),
                        parts["right"].astype(np.int64), parts["value"], parts["roots"].astype(np.int64),
                        float(parts["base"][0]))


@lru_cache(maxsize=4)
def load_source_model(path=MODEL_PATH) -> SourceModel:
    """The source-energy model in ``path`` (safetensors, no pickle); PanoLightError naming the file."""
    import json

    from ...io.safetensors_np import load_shipped

    path = Path(path)
    tensors, meta = load_shipped(path, "source-energy model")
    feats = tuple(json.loads(meta.get("features", "[]")))
    unknown = [n for n in feats if n not in FEATURES]
    if not feats or unknown or len(set(feats)) != len(feats):
        why = f"features this PanoLight does not compute ({', '.join(unknown)})" if unknown else "no valid feature list"
        raise PanoLightError(f"{path}: the source-energy model was trained on {why}; retrain it with "
                             f"training/source_energy/fit.py")
    n = len(feats)
    return SourceModel(_ensemble(tensors, "mean", path, n), _ensemble(tensors, "spread", path, n),
                       float(meta.get("shrink", 1.0)), feats, dict(meta), path)
