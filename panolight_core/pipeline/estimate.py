"""Pixels in, lighting out: ``estimate_lighting`` is the one path the CLI, ``batch`` and Blender take."""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from .. import sh, threads
from ..camera import units
from ..camera.ceiling import IMPLAUSIBLE
from ..camera.color import LUMINANCE_WEIGHTS
from ..errors import PanoLightError
from ..estimators import Estimate, estimate, with_key_strength, with_pointed_sun, with_sky_sun
from ..estimators.highlights import CLIP_LEVEL
from ..estimators.solar import sun_position
from ..io.lighting import make_lighting
from ..lighting.adaptive import LightingModel, fit_model
from ..lighting.order import DEFAULT_MAX_ORDER, DEFAULT_TOLERANCE
from ..packed import PackedImage
from ..sh.window import default_width
from .settings import MODELS, Settings, check_choice, direction_from_az_el

UNITS_HDR = "input radiance units"
UNITS_LDR = "relative: 1 = the LDR camera's clip level (white)"
UNITS_ABSOLUTE = "cd/m^2 (Rec.709 luminance-weighted); lights: lux on a surface facing them"


def fit_pixels(pixels: np.ndarray, *, lmax=None, estimator: str = "auto", model: str = "auto"):
    """Panorama pixels (uint8 sRGB LDR or float linear HDR) -> (LightingModel, Estimate), unscaled, with the
    model's own deringing and the default tolerance. lmax: None (auto for model "auto", 2 for "sh"), "auto" or an
    int. (``estimate_lighting`` takes every setting.)"""
    check_choice("model", model, MODELS)
    lmax = ("auto" if model == "auto" else "2") if lmax is None else str(lmax)
    est = estimate_pixels(pixels, lmax, estimator)
    return fit_estimate(est, hdr_input=pixels.dtype != np.uint8, lmax=lmax, model=model,
                        tolerance=DEFAULT_TOLERANCE, deringing=None), est


def estimate_pixels(pixels: np.ndarray, lmax="auto", estimator: str = "auto", *, pointed_sun=None,
                    sun_strength: float = 1.0, restore: bool = True, sky_sun: bool = False) -> Estimate:
    """The estimator's step of ``fit_pixels``: ``estimators.estimate`` at order ``lmax`` ("auto": the adaptive
    range's largest; an int), then a pointed sun (``pointed_sun``: (unit direction, lit/shadow contrast or None[,
    where it came from: the photo's metadata]), ``estimators.with_pointed_sun``) and the key lights times
    ``sun_strength`` (``estimators.with_key_strength``). restore: an HDR file that clips its own source has it
    weighed (``estimators.estimate``). sky_sun: a sun only the sky's gradient suggests is put back
    (``estimators.with_sky_sun``), before any pointed sun."""
    threads.check_cancelled()
    artist = pointed_sun is not None and len(pointed_sun) < 3  # on an HDR file, the clipped patch it points at
    est = estimate(pixels, DEFAULT_MAX_ORDER if str(lmax) == "auto" else int(lmax), estimator, restore,
                   pointed_sun[0] if artist and restore else None)
    if sky_sun:
        est = with_sky_sun(est)
    if pointed_sun is not None:
        est = with_pointed_sun(est, *pointed_sun)
    est = with_key_strength(est, sun_strength)
    threads.check_cancelled()
    return est


def fit_estimate(est, *, hdr_input: bool, **kw) -> LightingModel:
    """``fit_radiance`` of an ``estimators.Estimate``: its radiance map plus the key lights it found itself."""
    return fit_radiance(est.radiance, hdr_input=hdr_input, known_lights=est.lights,
                        exclude=est.light_exclusions, **kw)


def fit_radiance(radiance: np.ndarray, *, hdr_input: bool, lmax="auto", model: str = "auto",
                 tolerance: float = DEFAULT_TOLERANCE, deringing: str | None = None, known_lights=(),
                 exclude=()) -> LightingModel:
    """The lighting model of an estimator's linear radiance map (the second half of ``fit_pixels``; the
    evaluation scores estimates with it). hdr_input: the map is an HDR file's (lights above the median,
    not above the LDR clip level). lmax: "auto" or an int (as a string or int). known_lights: lights the
    estimator found itself, not in ``radiance`` (a fixed SH recipe, model "sh", projects them into its SH);
    exclude: (direction, radius) where no further light is taken (``lighting.adaptive.fit_model``)."""
    return fit_model(radiance, lights=model == "auto", lmax=str(lmax), tolerance=tolerance,
                     deringing=deringing or ("auto" if model == "auto" else "none"),
                     light_threshold=None if hdr_input else CLIP_LEVEL, known_lights=known_lights, exclude=exclude)


BLACK = 1e-30  # an HDR panorama whose brightest pixel is below this holds no light (1e-40: denormals)
CLIPPED_WHITE = 0.9  # an LDR panorama this much white (every channel >= 250) has no recoverable lighting


def input_warnings(pixels: np.ndarray) -> list[str]:
    """What makes a panorama's lighting meaningless though computable, one sentence each: no light at
    all (all black), values no real radiance has (1e30, float max), or an LDR photo clipped white almost
    everywhere. pixels: (H, W, 3) uint8 sRGB or float linear. Reads the image by row blocks."""
    found = []
    peak = (pixels.peak() if isinstance(pixels, PackedImage) else
            max(float(pixels[r:r + 256].max()) for r in range(0, pixels.shape[0], 256)))
    if (pixels.dtype == np.uint8 and peak == 0) or (pixels.dtype != np.uint8 and peak < BLACK):
        found.append(f"the panorama is black (brightest value {peak:g}): the lighting is zero")
    elif pixels.dtype != np.uint8 and peak > IMPLAUSIBLE:
        found.append(f"pixel values reach {peak:.3g}, beyond any real radiance: the lighting carries them "
                     f"(check the file's units, or repair it)")
    if pixels.dtype == np.uint8:
        step = max(1, int(math.ceil(math.sqrt(pixels.shape[0] * pixels.shape[1] / 2.0 ** 18))))  # ~260 K pixels
        sub = pixels[::step, ::step]
        white = float((np.minimum(np.minimum(sub[..., 0], sub[..., 1]), sub[..., 2]) >= 250).mean())
        if white >= CLIPPED_WHITE:
            found.append(f"{100 * white:.0f}% of the pixels are clipped white: this exposure holds almost no "
                         f"lighting information, and the estimate is a guess (use a darker exposure)")
    return found


def narrow_warning(shape: tuple, est: Estimate) -> str | None:
    """One sentence when the per-source model weighed clipped suns or lamps (``est.recovery``'s regions) of a
    panorama narrower than its training cameras framed (``sources.TRAINED_MIN_WIDTH``), else None. shape: the
    pixels' (H, W, 3). Out of fold on the 43 real HDRs with a dominant source (docs/studies/small_inputs.md), at
    256 wide a JPEG's sun comes back 73x off (median; 13x at 1024), and a clipped HDR's whole model scores 0.67 of
    its own projection's m-RMSE (0.51)."""
    rec = est.recovery
    if rec is None or rec.regions.count == 0:
        return None
    from ..estimators.sources import TRAINED_MIN_WIDTH

    if shape[1] >= TRAINED_MIN_WIDTH:
        return None
    return (f"the panorama is only {shape[1]} x {shape[0]} pixels: its clipped suns and lamps were weighed by a model "
            f"that learned from panoramas {TRAINED_MIN_WIDTH} or more wide, so their energy is far less certain "
            f"(use the full-size file if you have it)")


@dataclass
class Result:
    """What ``estimate_lighting`` found. document: the lighting.json content (io.lighting schema) without
    the input file's identity, which the caller adds as ``source``; model: the lights + SH it describes
    (Blender world frame, scaled by 2^exposure_ev); estimate: the estimator's output (hdr_panorama needs it);
    warnings: ``input_warnings`` of the pixels (the caller names the file and shows them)."""

    document: dict
    model: LightingModel
    estimate: Estimate
    warnings: tuple = ()

    @property
    def scale(self) -> float:
        """The factor the model (and the HDRI) carry over the estimate's relative units: 2^exposure_ev, times the
        cd/m^2 of the camera's white where the values are absolute (``physical.applied``)."""
        return units.document_gain(self.document)

    def hdr_panorama(self, pixels: np.ndarray) -> np.ndarray:
        """The full-resolution HDR panorama (pipeline.hdri) in the document's units: (H, W, 3) float32."""
        from .hdri import assemble

        return assemble(pixels.shape, self.hdr_blocks(pixels))

    def hdr_blocks(self, pixels: np.ndarray, sun_strength: float = 1.0):
        """``hdr_panorama`` by row blocks: a ``pipeline.hdri.HdrRows`` (iterate for (first row, float32
        (n, W, 3)); ``peak`` bounds its values), what hdr.exr is streamed from. sun_strength: its key lights
        times this, on top of the estimate's own (``estimators.with_key_strength``; Blender's Sun lamp strength
        for a world lit by the HDRI)."""
        from .hdri import HdrRows

        return HdrRows(pixels, with_key_strength(self.estimate, sun_strength), self.scale)


def capture_sun(capture) -> tuple | None:
    """(unit direction in the panorama's frame, where it came from in words) of the sun when a photo was taken,
    from its capture metadata (``io.capture.Capture``: GPS position, UTC time, heading of the panorama's centre;
    ``solar.sun_position``), or None when any of the three is missing: nothing is guessed."""
    if capture is None or capture.missing:
        return None
    azimuth, elevation = sun_position(capture.latitude, capture.longitude, capture.utc)
    return (direction_from_az_el(azimuth - capture.heading, elevation),
            f"the photo's metadata ({capture.describe()}): the sun {elevation:.1f} deg up, {azimuth:.1f} deg from "
            f"north")


def estimate_lighting(pixels: np.ndarray, settings: Settings = Settings(), capture=None, exposure=None) -> Result:
    """Panorama pixels (uint8 sRGB LDR or float32 linear HDR, (H, W, 3), equirect, Blender world frame) ->
    Result: estimator, lighting model (lights + the SH order the scene needs, or a fixed recipe), the
    requested deringing and exposure. capture: the photo's ``io.capture.Capture`` (with ``settings.sun_metadata``
    and no ``sun_direction``: the sun's direction where the photo does not place one). exposure: the photo's EXIF
    exposure ({"time_s", "f_number", "iso"}: ``io.capture.read_exposure``; a bracket set's reference frame's), which
    gives the absolute scale (``physical_scale``). Raises PanoLightError on bad settings or pixels."""
    t1 = time.perf_counter()
    pointed = None
    if settings.sun_direction is not None:
        pointed = (settings.sun_direction, settings.sun_contrast)
    elif settings.sun_metadata and (found := capture_sun(capture)) is not None:
        pointed = (found[0], None, found[1])
    est = estimate_pixels(pixels, settings.order, settings.estimator, pointed_sun=pointed,
                          sun_strength=settings.sun_strength, restore=settings.restore != "none",
                          sky_sun=settings.sky_sun)
    fitted = fit_estimate(est, hdr_input=pixels.dtype != np.uint8, lmax=settings.order, model=settings.model,
                          tolerance=settings.tolerance, deringing=None if settings.window == "none" else "none")
    threads.check_cancelled()
    coeffs, window_info = fitted.coeffs, fitted.info["ringing"]["window"]
    if settings.window == "auto":
        width = sh.auto_window_width(coeffs, target="radiance")
        window_info = {"kind": "sinc4", "mode": "auto", "target": "radiance",
                       "width": None if math.isinf(width) else width}
        if not math.isinf(width):
            coeffs = sh.window(coeffs, "sinc4", width)
    elif settings.window != "none":
        width = settings.window_width or default_width(sh.lmax_from_count(coeffs.shape[0]))
        coeffs = sh.window(coeffs, settings.window, width)
        window_info = {"kind": settings.window, "mode": "fixed", "width": width}
    scale = 2.0 ** settings.exposure_ev
    with np.errstate(over="ignore", invalid="ignore"):
        lights = [dict(light, intensity=light["intensity"] * scale) for light in fitted.lights]
        model = LightingModel(lights, coeffs * scale, fitted.info)
    physical = physical_scale(model, settings, exposure)
    if settings.absolute and physical.absolute:
        with np.errstate(over="ignore", invalid="ignore"):
            lights = [dict(light, intensity=light["intensity"] * physical.cd_m2) for light in lights]
            model = LightingModel(lights, model.coeffs * physical.cd_m2, fitted.info)
    require_finite({"the SH coefficients": model.coeffs,
                    "the lights": np.array([light["intensity"] for light in lights], dtype=np.float64)},
                   settings.exposure_ev)
    model_info = dict(fitted.info, window=window_info)
    hdr = pixels.dtype != np.uint8
    applied = settings.absolute and physical.absolute
    doc = make_lighting(
        model.coeffs, lights=lights, units=UNITS_ABSOLUTE if applied else UNITS_HDR if hdr else UNITS_LDR,
        physical=physical_block(model, physical, applied),
        estimator={k: v for k, v in est.info.items() if k not in ("clipped_regions", "estimate_s")},
        model=model_info, order=model_info["order"], window=window_info, exposure_ev=settings.exposure_ev,
        sun_strength=settings.sun_strength,
        clipped_regions=est.info.get("clipped_regions", []),
        timings={"estimate_s": round(est.info["estimate_s"], 6),
                 "model_s": round(time.perf_counter() - t1 - est.info["estimate_s"], 6)},
    )
    warnings = input_warnings(pixels)
    if (narrow := narrow_warning(pixels.shape, est)) is not None:
        warnings.append(narrow)
    if settings.sun_strength != 1.0 and "key_light_strength" not in est.info:
        warnings.append(f"sun strength {settings.sun_strength:g} changes nothing: the estimate has no key light "
                        f"(a sun or lamp weighed in a clipped photo) to scale")
    if settings.sun_direction is not None and "pointed_sun" not in est.info:
        warnings.append("the sun's direction changes nothing: " + (
            est.info.get("pointed_restoration", "an HDR input holds its own sun in its pixels") if hdr else
            f"the {est.estimator} estimator weighs no key light (use --estimator keylight or sources)"))
    return Result(doc, model, est, tuple(warnings))


def upward_illuminance(model: LightingModel) -> float:
    """The luminance-weighted illuminance of ``model`` (lights and SH) on an upward surface at the camera, in its
    own units x sr (lux where the model is in cd/m^2)."""
    return float(model.irradiance(np.array([[0.0, 0.0, 1.0]]))[0] @ LUMINANCE_WEIGHTS)


def physical_scale(model: LightingModel, settings: Settings, exposure: dict | None) -> units.Scale:
    """How the relative ``model`` stands to cd/m^2 (``camera.units``): a light meter's ``settings.lux`` (the model's
    upward illuminance made E), else ``settings.ev100``, else the photo's EXIF ``exposure``, else relative."""
    if settings.lux is not None:
        try:
            return units.from_lux(settings.lux, upward_illuminance(model))
        except ValueError as exc:
            raise PanoLightError(f"--lux {settings.lux:g}: {exc}") from None
    if settings.ev100 is not None:
        return units.from_ev100(settings.ev100)
    return units.from_exposure(exposure)


def physical_block(model: LightingModel, scale: units.Scale, applied: bool) -> dict:
    """lighting.json's ``physical``: the scale (``units.Scale.describe``), whether the file's values carry it
    (``applied``: the default where a scale is known, not with --relative), and in absolute units the upward illuminance (lux) and each light's illuminance on a
    surface facing it (lux, and W/m^2 at 683 lm/W), in the order of ``lights``."""
    out = {**scale.describe(), "applied": bool(applied)}
    if scale.absolute:
        per = 1.0 if applied else scale.cd_m2  # the model's units to cd/m^2
        out["upward_illuminance_lux"] = upward_illuminance(model) * per
        out["lights"] = [{"illuminance_lux": float(light["intensity"]) * per,
                          "irradiance_w_m2": float(light["intensity"]) * per / units.LUMENS_PER_WATT}
                         for light in model.lights]
    return out


def require_finite(outputs: dict, exposure_ev: float, what: str = "") -> None:
    """Refuse (PanoLightError) when any named array holds values that are NaN/Inf in 32-bit floats
    (every output is float32: EXRs, Blender images and lamps): an all-Inf EXR is a silent wrong answer.
    Checked by row blocks (a 16K HDRI has no second full-size copy to spare)."""
    def finite(block):
        with np.errstate(over="ignore", invalid="ignore"):
            return np.isfinite(block.astype(np.float32, copy=False)).all()

    bad = [name for name, a in outputs.items() if not all(finite(a[r:r + 256]) for r in range(0, max(len(a), 1), 256))]
    if bad:
        raise PanoLightError(f"{what}{', '.join(bad)} would not be finite (the input's radiance times "
                             f"2^{exposure_ev:g} overflows 32-bit floats); lower --exposure or rescale the input")
