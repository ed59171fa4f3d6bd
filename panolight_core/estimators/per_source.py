"""The per-source estimators (``sources``, ``keylight``): every clipped region weighed by the model learned from
real HDR panoramas (``sources``), an HDR file's clipped plateau restored, and the key lights made (``keylight``); and
the operations on their estimates: the key lights' strength and the artist's sun."""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from .. import sh
from ..camera.ceiling import find_ceiling, pointed_ceiling, scan_rows
from .basic import Estimate, _exact_hdr


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
    """``est`` with a sun at ``direction`` (``keylight.with_pointed_sun``), recorded in its info as
    ``pointed_sun`` with where the direction came from: the artist (``origin`` None), or the photo's own capture
    metadata (``origin`` says which: ``keylight.METADATA_DEFERS_DEG``): that one gives way to a sun the photo
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


def with_sky_sun(est: Estimate) -> Estimate:
    """``est`` with the sun its sky's gradient alone suggests put back (``--sky-sun``: the bolder rule,
    ``keylight.KeyLightParams.sky_alone_sun``), where the sun search refused it for that reason alone
    (``keylight.find.SKY_ALONE``); recorded in its info's ``sun_search``. Any other estimate is returned as it is."""
    rec = est.recovery
    from .keylight import PARAMS, with_key_lights
    from .keylight.find import SKY_ALONE

    if rec is None or (rec.sun_search or {}).get("refused") != [SKY_ALONE]:
        return est
    undecided = replace(rec, log_ratio=rec.log_ratio if rec.decided is None else rec.decided)
    info = {k: v for k, v in est.info.items() if k not in ("clipped_regions", "sun_search")}
    return _recovery_estimate(with_key_lights(undecided, replace(PARAMS, sky_alone_sun=True)), est.lmax,
                              est.estimator, info)


def per_source_key_lights(pixels: np.ndarray, lmax: int, restore: bool = True, pointer=None) -> Estimate:
    return per_source(pixels, lmax, key_lights=True, restore=restore, pointer=pointer)
