"""Lighting estimators: panorama pixels -> SH radiance coefficients (K, 3), Blender world frame.

Inputs are the pixels ``read_image(..., ldr_as_uint8=True)`` returns: uint8 sRGB for 8-bit LDR files,
float32 linear radiance for HDR (and 16-bit) files.

- ambient:  L_00 of the naive projection only (a constant environment).
- naive:    sRGB -> linear, then the exact projection (no highlight recovery).
- analytic: HDR -> the exact projection; LDR -> sRGB -> linear, clipped highlights re-inflated by the
            physical power-law model of ``highlights``, projection of the recovered map.
- sources:  per-source energy (``sources``): every clipped region gets the energy a model learned from
            real HDR panoramas predicts for it (the expected-error optimum of its predicted ratio).
- keylight: ``sources`` plus explicit key lights: each clipped region that holds a compact sun or lamp
            becomes one light at its centroid, weighed by a clear-sky fit or the per-source model
            (``keylight``; docs/keylight.md has what it gains and what it costs). The default.
- neural:   the paper's learned estimator (LDR -> HDR autoencoder -> lighting encoder) with the shipped
            weights (panolight_core/models), numpy only; HDR inputs are projected exactly.
- auto:     the best estimator available (see ``resolve``).
LDR results are in units of the camera's clip level (1 = white); HDR results in the file's units.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from functools import partial

import numpy as np

from .. import __version__, sh
from ..camera import linear
from ..camera.ceiling import find_ceiling, pointed_ceiling, scan_rows
from ..errors import PanoLightError
from .highlights import recover_highlights

ANALYTIC_WORK_HEIGHT = 64  # rows of the analytic estimator's work map (the per-source one's is highlights.WORK_HEIGHT,
# 128); 64 and 128 score alike on synthetic scenes (training/synth/evaluate.py)


@dataclass
class Estimate:
    """An estimate: coefficients (K, 3) float64 radiance SH, the estimator and what it found.

    radiance: the linear equirect map the coefficients are the projection of (the input itself for HDR,
    the recovered work map for the analytic LDR path), less the explicit ``lights`` the estimator found
    itself (the per-source estimator's key lights); the adaptive model fits the rest to it.
    """

    coeffs: np.ndarray
    estimator: str
    info: dict = field(default_factory=dict)
    radiance: np.ndarray | None = None
    recovery: object | None = None  # sources.Recovery for the per-source estimator (hdr.exr is made from it)
    lights: list = field(default_factory=list)  # explicit key lights (lighting-file dicts) not in ``radiance``
    light_exclusions: list = field(default_factory=list)  # (direction, radius rad): no second light there

    @property
    def lmax(self) -> int:
        return sh.lmax_from_count(self.coeffs.shape[0])


def ambient(pixels: np.ndarray, lmax: int) -> Estimate:
    lin = linear(pixels)
    c = sh.project(lin, lmax).astype(np.float64)
    c[1:] = 0.0
    flat = np.broadcast_to(c[0] / np.sqrt(4.0 * np.pi), lin.shape)
    return Estimate(c, "ambient", radiance=flat)


def naive(pixels: np.ndarray, lmax: int) -> Estimate:
    lin = linear(pixels)
    return Estimate(sh.project(lin, lmax).astype(np.float64), "naive", radiance=lin)


def _exact_hdr(pixels: np.ndarray, lmax: int, name: str) -> Estimate:
    """HDR input needs no recovery: its exact projection."""
    return Estimate(sh.project(pixels, lmax).astype(np.float64), name, {"input": "hdr"}, pixels)


def analytic(pixels: np.ndarray, lmax: int) -> Estimate:
    if pixels.dtype != np.uint8:
        return _exact_hdr(pixels, lmax, "analytic")
    work = max(ANALYTIC_WORK_HEIGHT, 4 * (lmax + 1))
    recovered, blobs = recover_highlights(pixels, work)
    return Estimate(sh.project(recovered, lmax), "analytic",
                    {"input": "ldr", "work_height": work, "clipped_regions": blobs}, recovered)


def per_source(pixels: np.ndarray, lmax: int, key_lights: bool = False, model_path=None, restore: bool = True,
               hdr_model_path=None, pointer=None) -> Estimate:
    """The per-source estimate (``keylight`` with key lights, else ``sources``) with the shipped per-source
    energy model or the one in ``model_path``. An HDR file is its exact projection, unless it clips its own source
    (``camera.ceiling``): then, with ``restore``, its plateau is weighed as a photo's clipped sun is
    (``sources.restore``), and every other pixel kept, by the model in ``hdr_model_path`` (default: ``model_path``
    when given, else the shipped ``sources.HDR_MODEL_PATH``, trained on clipped HDR files too). pointer: the unit
    direction of the artist's sun (CONVENTIONS.md frame): where the file holds no plateau (a file resampled after its
    merge keeps its clipped sun as a soft bump, no exact ties), the patch it points at is declared clipped
    (``camera.ceiling.pointed_ceiling``) and restored as a found one is; where it finds nothing to restore, the
    exact projection says why in its info (``pointed_restoration``)."""
    name = "keylight" if key_lights else "sources"
    from . import sources
    from .sources.restore import declared_source

    if pixels.dtype == np.uint8:
        model = sources.load_source_model(sources.MODEL_PATH if model_path is None else model_path)
        rec, info = sources.recover(pixels, model), {"input": "ldr"}
    else:
        scan = scan_rows(pixels) if pointer is not None and restore else None  # read once for both
        ceiling, why_not = find_ceiling(pixels, scan), None
        if ceiling is None and scan is not None:
            ceiling, said = pointed_ceiling(pixels, pointer, scan)
            why_not = None if ceiling is not None else said
        if ceiling is None or not restore or ceiling.implausible:
            est = _exact_hdr(pixels, lmax, name)
            if ceiling is not None:
                why = ("--restore none: the file as it is, its clipped plateau unweighed" if not ceiling.implausible
                       else f"its plateau sits at {ceiling.level:.3g}, beyond any real radiance: an overflow or a "
                            f"sentinel, not a clipped source, so the file is taken as it is")
                est.info["restoration"] = {**ceiling.describe(), "restored": False, "why": why}
            if why_not is not None:
                est.info["pointed_restoration"] = why_not
            return est
        model = sources.load_source_model(hdr_model_path or model_path or sources.HDR_MODEL_PATH)
        rec, info = sources.recover_hdr(declared_source(pixels, ceiling), model), {"input": "hdr"}
    if key_lights:  # also without regions: a sun the photo does not show
        from .keylight import with_key_lights

        rec = with_key_lights(rec)
    return _recovery_estimate(rec, lmax, name, {**info, "work_height": rec.frac.shape[0],
                                                "model": model.path.name, "decision": rec.decision})


def _recovery_estimate(rec, lmax: int, name: str, info: dict) -> Estimate:
    """The Estimate of a ``sources.Recovery``: its work map's SH, its diffuse map (what the adaptive model fits)
    and its key lights; ``info`` plus the regions and the sun search. A restored HDR's (``rec.source``) is in the
    file's units: its pixels as they are, and the recovery's energy (in clip units) times the clip level."""
    src = rec.source
    if src is None:
        return Estimate(sh.project(rec.work, lmax), name,
                        {**info, "clipped_regions": rec.region_info(),
                         **({"sun_search": rec.sun_search} if rec.sun_search is not None else {})}, rec.diffuse, rec,
                        rec.lights(), rec.key_exclusions())
    level = src.level
    coeffs = src.projection(lmax) + level * sh.project(rec.work - rec.base, lmax)
    regions = [dict(r, held_energy=r["held_energy"] * level, energy=r["energy"] * level) for r in rec.region_info()]
    lights = [dict(light, intensity=light["intensity"] * level, energy_68=[v * level for v in light["energy_68"]])
              for light in rec.lights()]
    restoration = {**src.ceiling.describe(), "restored": True, "clip_level": level,
                   "why": (src.ceiling.declared or "the file clips its own source") + ": its plateau is weighed as a "
                          "photo's clipped sun is, and every other pixel kept"}
    return Estimate(coeffs, name, {**info, "restoration": restoration, "clipped_regions": regions,
                                   **({"sun_search": rec.sun_search} if rec.sun_search is not None else {})},
                    src.filled(rec, keys=False), rec, lights, rec.key_exclusions())


def with_key_strength(est: Estimate, strength: float) -> Estimate:
    """``est`` with its key lights (the suns and lamps the per-source estimator weighed, and a sun put back from
    the sky) times ``strength`` (>= 0), in its lights, its maps and the HDRI made from it alike
    (``sources.Recovery.with_key_strength``); recorded in its info as ``key_light_strength``. An estimate without
    key lights is returned as it is (HDR input, other estimators, a photo with no compact source)."""
    rec = est.recovery
    if strength == 1.0 or rec is None or not rec.keys:
        return est
    info = {k: v for k, v in est.info.items() if k not in ("clipped_regions", "sun_search")}
    return _recovery_estimate(rec.with_key_strength(strength), est.lmax, est.estimator,
                              {**info, "key_light_strength": float(strength)})


def with_pointed_sun(est: Estimate, direction, contrast: float | None = None, origin: str | None = None) -> Estimate:
    """``est`` with a sun at ``direction`` (``pointed_sun.with_pointed_sun``), recorded in its info as
    ``pointed_sun`` with where the direction came from: the artist (``origin`` None), or the photo's own capture
    metadata (``origin`` says which: ``pointed_sun.METADATA_DEFERS_DEG``): that one gives way to a sun the photo
    itself places surely, and to a sky that cannot weigh it (recorded as ``sun_metadata``, unused, and why). An
    estimate without a per-source recovery (an HDR input, whose sun is in its pixels, or another estimator) is
    returned as it is."""
    rec = est.recovery
    if rec is None:
        return est
    from .keylight import SkyCannotWeigh, photo_places_sun
    from .keylight import with_pointed_sun as point

    info = {k: v for k, v in est.info.items() if k not in ("clipped_regions", "sun_search")}
    said = {"direction": [round(float(v), 6) for v in direction],
            **({"contrast": float(contrast)} if contrast is not None else {}),
            "from": "the artist" if origin is None else origin}
    why = photo_places_sun(rec) if origin is not None else None
    if why is None:
        try:
            return _recovery_estimate(point(rec, direction, contrast), est.lmax, est.estimator,
                                      {**info, "pointed_sun": said})
        except SkyCannotWeigh as exc:
            if origin is None:  # the artist asked for it: say why it cannot be
                raise
            why = f"no clear sky weighs a sun there: {exc.reason}"
    return replace(est, info={**est.info, "sun_metadata": {**said, "used": False, "why": why}})


def per_source_key_lights(pixels: np.ndarray, lmax: int, restore: bool = True, pointer=None) -> Estimate:
    return per_source(pixels, lmax, key_lights=True, restore=restore, pointer=pointer)



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
                      "photo does not show (retouched out) put back where its clear sky places it (exact for HDR, but "
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
