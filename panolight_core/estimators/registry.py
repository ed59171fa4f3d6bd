"""The estimators by name: the registry ``estimate`` runs from (``auto`` resolved to the best measured), and the
labels a study or an evaluation registers for a trained model."""
from __future__ import annotations

import time
from dataclasses import dataclass
from functools import partial

import numpy as np

from .. import __version__
from ..camera.ceiling import find_ceiling
from ..errors import PanoLightError
from .basic import Estimate, _exact_hdr, ambient, analytic, naive
from .per_source import per_source, per_source_key_lights


def neural_estimator(weights=None, label: str = "neural"):
    """An estimator function running the learned model in ``weights`` (default: the shipped file)."""

    def run(pixels: np.ndarray, lmax: int) -> Estimate:
        from .nn import estimator as nn_estimator

        if pixels.dtype != np.uint8:
            return _exact_hdr(pixels, lmax, label)
        model = nn_estimator.load_model(weights or nn_estimator.DEFAULT_WEIGHTS)
        coeffs, hdr = nn_estimator.predict(model, pixels, lmax)
        return Estimate(coeffs, label, {"input": "ldr", "weights": model.path.name,
                                        "model": model.config.get("name", "?")}, hdr)

    return run


def register_model(label: str, weights) -> str:
    """Make a learned model file usable as estimator ``label`` (evaluation of trained variants)."""
    from .nn.estimator import load_model

    _check_label(label)
    load_model(weights)  # fail now, naming the file, not in the middle of an evaluation
    _REGISTRY[label] = Entry(neural_estimator(weights, label), label, f"the trained model {weights}")
    return label


def register_source_model(label: str, path, key_lights: bool = True, hdr_path=None) -> str:
    """Make a per-source energy model file usable as estimator ``label``: ``keylight`` (or, without
    ``key_lights``, ``sources``) with that model instead of the shipped one, e.g. a cross-validation fold's
    model that never saw the scene it estimates (training/keylight/cv.py --fold-models); ``hdr_path``: the model
    that restores a clipped HDR file (default ``path``)."""
    from . import sources

    _check_label(label)
    for p in (path, hdr_path) if hdr_path else (path,):
        sources.load_source_model(p)  # fail now, naming the file, not in the middle of an evaluation
    run = partial(per_source, key_lights=key_lights, model_path=path, hdr_model_path=hdr_path)
    _REGISTRY[label] = Entry(run, label, f"{'keylight' if key_lights else 'sources'} with the per-source model {path}",
                             True)
    return label


def _check_label(label: str) -> None:
    if label in BUILTIN + ("auto",) or not label.replace("-", "").replace("_", "").isalnum():
        raise PanoLightError(f"{label!r} cannot name a trained model: use letters, digits, '-' or '_', and not "
                             f"a built-in estimator's name")


def _neural_shipped() -> bool:
    from .nn import estimator as nn_estimator

    return nn_estimator.DEFAULT_WEIGHTS.is_file()


@dataclass(frozen=True)
class Entry:
    """A registered estimator: run(pixels, lmax) -> Estimate, a menu label and a one-line description; restores:
    whether run takes ``restore`` (it weighs an HDR file's clipped source, ``sources.restore``)."""

    run: object
    label: str
    description: str
    restores: bool = False


_REGISTRY = {
    "ambient": Entry(ambient, "Ambient", "A constant environment (the naive L00)"),
    "naive": Entry(naive, "Naive", "sRGB to linear only"),
    "analytic": Entry(analytic, "Analytic", "sRGB to linear with power-law highlight recovery; exact for HDR"),
    "sources": Entry(per_source, "Per-source energy", "Each clipped sun, lamp or window gets the energy a model "
                     "learned from real HDR panoramas predicts; exact for HDR, but for a sun or lamp the file itself "
                     "clipped", True),
    "keylight": Entry(per_source_key_lights, "Per-source + key lights", "Per-source energy, and each clipped "
                      "region holding a compact sun or lamp made one explicit light that casts shadows; a sun the "
                      "photo does not show (retouched out) located from its clear sky and reported (exact for HDR, but "
                      "for a sun or lamp the file itself clipped)", True),
    "neural": Entry(neural_estimator(), "Neural", "The paper's network (numpy; no torch needed)"),
}
BUILTIN = tuple(_REGISTRY)  # register_model and register_source_model add labels beside these
DESCRIPTIONS = {name: (e.label, e.description) for name, e in _REGISTRY.items()}  # CLI help, Blender menus
AUTO = "keylight"  # what ``auto`` means: cross-validated by scene over the real HDRs, far better than ``sources``
# on the dominant source's energy and its shadow; on the m-RMSE median better at ev -2 and level at 0 / +2 over
# the 105 un-clipped of the 111, its means hurt by a few invented suns (docs/keylight.md, studies/keylight_111.md)


def available() -> tuple[str, ...]:
    """Estimator names usable here."""
    return tuple(n for n in _REGISTRY if n != "neural" or _neural_shipped())


def resolve(name: str) -> str:
    """Map ``auto`` to a concrete estimator; raise PanoLightError for unknown or unavailable names."""
    if name == "auto":
        return AUTO
    if name == "neural" and not _neural_shipped():
        raise PanoLightError("the neural estimator's weights are missing from this installation "
                             "(panolight_core/models/small.safetensors); use --estimator analytic (or auto)")
    if name not in _REGISTRY:
        raise PanoLightError(f"unknown estimator {name!r}; choose from {', '.join(available() + ('auto',))}")
    return name


def estimate(pixels: np.ndarray, lmax: int = 2, estimator: str = "auto", restore: bool = True, pointer=None
             ) -> Estimate:
    """Run an estimator on panorama pixels (uint8 sRGB LDR or float linear HDR); records its time. restore: an HDR
    file that clips its own source has it weighed by the estimators that can (``Entry.restores``); an estimator that
    cannot records that it took the file as it is. pointer: the artist's sun (a unit direction), which points such an
    estimator at the clipped patch of a file that lost its plateau (``per_source``)."""
    name = resolve(estimator)
    if pixels.ndim != 3 or pixels.shape[-1] != 3:
        raise PanoLightError(f"panorama pixels must be (H, W, 3), got {pixels.shape}")
    t0 = time.perf_counter()
    entry = _REGISTRY[name]
    est = entry.run(pixels, lmax, restore=restore, pointer=pointer) if entry.restores else entry.run(pixels, lmax)
    if not entry.restores and pixels.dtype != np.uint8 and (ceiling := find_ceiling(pixels)) is not None:
        est.info["restoration"] = {**ceiling.describe(), "restored": False,
                                   "why": f"the {name} estimator takes an HDR file as it is (keylight and sources "
                                          f"weigh a clipped plateau)"}
    est.info.update({"name": name, "version": __version__, "estimate_s": time.perf_counter() - t0})
    return est
