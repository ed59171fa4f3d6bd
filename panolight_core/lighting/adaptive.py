"""The adaptive lighting model: explicit lights for compact sources plus the smallest SH order that
is good enough for the rest, deringed only when ringing would show.

fit_model(map) takes a linear equirect radiance map (an HDR panorama, or an LDR estimator's recovered
map) and returns a LightingModel; everything it chose, and why, is in ``model.info`` and goes into
lighting.json. Irradiance of the model = lights rendered analytically (sum I c max(0, n . d)) plus the
SH residual's irradiance (A_l kernel).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from .. import sh
from ..packed import PackedImage
from .lights import MAX_LIGHTS, extract_lights, light_coeffs, light_irradiance
from .order import DEFAULT_MAX_ORDER, DEFAULT_TOLERANCE, select_order

IRRADIANCE_RINGING = 0.01  # negative irradiance beyond 1 % of the mean irradiance shows on diffuse surfaces
_GRID = (64, 128)


@dataclass
class LightingModel:
    """lights (lighting-file dicts), SH residual coefficients (K, 3), and what was chosen and why."""

    lights: list
    coeffs: np.ndarray
    info: dict = field(default_factory=dict)

    @property
    def parameter_count(self) -> int:
        """Floats stored: 3 per SH coefficient, 8 per light (direction 3, colour 3, intensity, angle)."""
        return int(self.coeffs.size) + 8 * len(self.lights)

    def project(self, lmax: int) -> np.ndarray:
        """(K, 3) SH of the whole model at order lmax: lights as uniform disks (exact cap projection)
        plus the SH part truncated or zero-padded to lmax (EVALUATION.md's whole-model scoring)."""
        k = (lmax + 1) ** 2
        out = light_coeffs(self.lights, lmax)
        n = min(k, self.coeffs.shape[0])
        out[:n] += self.coeffs[:n]
        return out

    def irradiance(self, normals: np.ndarray) -> np.ndarray:
        """(..., 3) irradiance at unit normals (..., 3)."""
        return light_irradiance(self.lights, normals) + sh.irradiance(self.coeffs, np.asarray(normals, dtype=np.float64))

    def irradiance_map(self, height: int, width: int) -> np.ndarray:
        """(H, W, 3) irradiance for a surface facing each pixel's direction."""
        d = sh.pixel_directions(height, width)
        return light_irradiance(self.lights, d) + sh.irradiance_map(self.coeffs, height, width)


def _lights_mean_irradiance(lights) -> float:
    # a directional light's max(0, n . d) averages 1/4 over all normals
    return sum(l["intensity"] for l in lights) / 4.0


def ringing(coeffs: np.ndarray, lights=()) -> dict:
    """Most negative SH radiance and model irradiance on a grid, relative to their means."""
    c = np.asarray(coeffs, dtype=np.float64)
    rad = sh.reconstruct(c, *_GRID)
    w = sh.pixel_solid_angles(*_GRID)[..., None]
    mean_rad = float((w * rad).sum() / (w.sum() * 3))
    irr = sh.irradiance_map(c, *_GRID) + light_irradiance(lights, sh.pixel_directions(*_GRID))
    mean_irr = float((w * irr).sum() / (w.sum() * 3))
    return {"min_radiance_rel": float(rad.min()) / mean_rad if mean_rad > 0 else 0.0,
            "min_irradiance_rel": float(irr.min()) / mean_irr if mean_irr > 0 else 0.0}


EMITTERS_NOTE = ("the SH radiance rings below zero; every emitter PanoLight writes (radiance.exr, the USD dome, "
                 "Blender's SH world, Mitsuba's envmap) is its nearest non-negative map with the same bands 0-2 "
                 "(sh.nonnegative): the same diffuse lighting and energy, no negative light, nothing clipped")


def _ringing_why(ring: dict, window, deringing: str) -> str:
    """One sentence on the irradiance and the radiance ringing of the model as written."""
    if deringing != "auto":
        head = f"deringing {deringing!r} requested"
    elif window:
        head = "deringed: the irradiance dipped below the threshold"
    else:
        head = "no visible ringing in the irradiance"
    low = ring["min_radiance_rel"]
    tail = f"; the SH radiance dips to {low:.2g} x its mean" if low < 0 else "; the SH radiance is non-negative"
    return head + tail


def fit_model(radiance: np.ndarray, *, lights: bool = True, lmax="auto", tolerance: float = DEFAULT_TOLERANCE,
              deringing: str = "auto", light_threshold: float | None = None, known_lights=(), exclude=()
              ) -> LightingModel:
    """Fit lights + SH to a linear (H, W, 3) radiance map.

    lights: extract explicit lights (False: SH only). lmax: "auto" (smallest order 0..DEFAULT_MAX_ORDER whose
    diffuse relighting error against order DEFAULT_MAX_ORDER is <= tolerance of the model's mean irradiance)
    or an int. deringing: "auto" applies the weakest sinc^4 window only when ringing would show: the model's
    irradiance dips below -IRRADIANCE_RINGING x its mean (dark patches on diffuse surfaces). (Not when the SH
    radiance alone dips: a residual with bright sky or windows rings in radiance at every useful order, and
    windowing it costs 2-10x in irradiance accuracy on the Blender HDRIs.) "none" disables it; a window
    family name forces that window.
    light_threshold: see lights.extract_lights (the clip level for LDR-derived maps).
    known_lights: lights found before (an estimator's key lights), whose energy is not in ``radiance``: they
    come first, and no light is extracted within ``exclude`` ((direction, radius) pairs). With lights=False
    they are projected into the SH part instead.
    """
    known_lights = [dict(light) for light in known_lights]
    t0 = time.perf_counter()
    info: dict = {"mode": "lights+sh" if lights else "sh"}
    if lights:
        extracted, residual, linfo = extract_lights(radiance, threshold=light_threshold, exclude=exclude,
                                                    max_lights=MAX_LIGHTS - len(known_lights))
        found = known_lights + extracted
        fraction = linfo["energy_fraction_in_lights"]
        if known_lights:  # their energy is not in the map: add it to both sides
            known_e, total = sum(light["intensity"] for light in known_lights), linfo["map_energy"]
            fraction = (known_e + fraction * total) / (known_e + total) if known_e + total > 0 else 0.0
        info["lights"] = {"count": len(found), "energy_fraction": round(fraction, 6)}
        if known_lights:
            info["lights"]["key_lights"] = len(known_lights)
        if not found:
            info["lights"]["why_none"] = linfo.get("reason")
    else:
        found, residual = [], (radiance.astype(np.float64) if isinstance(radiance, PackedImage)
                               else np.asarray(radiance, dtype=np.float64))
    auto = lmax == "auto"
    max_order = DEFAULT_MAX_ORDER
    order = max_order if auto else int(lmax)
    coeffs = sh.project(residual, order).astype(np.float64)
    if known_lights and not lights:  # a fixed SH recipe holds the key lights in its coefficients
        coeffs = coeffs + light_coeffs(known_lights, order)
    if auto:
        chosen, errs = select_order(coeffs, tolerance, _lights_mean_irradiance(found))
        coeffs = coeffs[:(chosen + 1) ** 2]
        info["order"] = {"mode": "auto", "lmax": chosen, "tolerance": tolerance, "max_order": max_order,
                         "irradiance_error_per_order": [round(e, 6) for e in errs],
                         "why": f"the smallest order whose diffuse relighting error is <= {tolerance:g} of "
                                f"the model's mean irradiance"}
    else:
        info["order"] = {"mode": "fixed", "lmax": order}
    ring = ringing(coeffs, found)
    window = None
    if deringing == "auto":
        target = "irradiance" if ring["min_irradiance_rel"] < -IRRADIANCE_RINGING else None
        if target is not None and coeffs.shape[0] > 1:
            width = sh.auto_window_width(coeffs, "sinc4", target)
            if math.isfinite(width):
                coeffs = sh.window(coeffs, "sinc4", width)
                window = {"kind": "sinc4", "width": width, "target": target}
    elif deringing != "none":
        from ..sh.window import default_width

        width = default_width(sh.lmax_from_count(coeffs.shape[0]))
        coeffs = sh.window(coeffs, deringing, width)
        window = {"kind": deringing, "width": width, "target": "fixed"}
    info["ringing"] = {**{k: round(v, 6) for k, v in ring.items()}, "irradiance_threshold": IRRADIANCE_RINGING,
                       "radiance_threshold": None, "window": window,
                       "why": _ringing_why(ring, window, deringing),
                       "emitters": EMITTERS_NOTE if ring["min_radiance_rel"] < 0 else "the SH radiance is non-negative"}
    model = LightingModel(found, coeffs, info)
    info["parameters"] = model.parameter_count
    info["fit_s"] = round(time.perf_counter() - t0, 6)
    return model
