"""Physical units: the one home of PanoLight's absolute scale.

The convention is the one Frostbite, Filament and Unity HDRP use, from ISO 12232's saturation-based speed
with q = 0.65:

- EV100 = log2(N^2 / t) - log2(ISO / 100), t the exposure time (s), N the f-number;
- the sensor's white (a linear picture's clip level, 1 in PanoLight's relative units) is
  1.2 x 2^EV100 cd/m^2 (1.2 = 78 / (100 q)).

Radiance is then in cd/m^2, luminance-weighted (Rec.709: a pixel's luminance, LUMINANCE_WEIGHTS . RGB, times the
scale is its luminance in cd/m^2; the channels keep their ratios). A light's intensity (radiance x sr: the
irradiance on a surface facing it) is then in lux, and lux / LUMENS_PER_WATT is W/m^2 (683 lm/W, Blender's and
Mitsuba's photometric convention).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

LUMENS_PER_WATT = 683.0
SATURATION_Q = 0.65  # ISO 12232's lens and vignetting factor
WHITE_FACTOR = 78.0 / (100.0 * SATURATION_Q)  # 1.2: the sensor's white in cd/m^2 at EV100 0
EV100_RANGE = (-20.0, 40.0)  # a starless night (-10) to beyond a welding arc (26), with room either side
MAX_LUX = 1e7  # direct sunlight is about 1.2e5 lux


def ev100(time_s: float, f_number: float, iso: float) -> float:
    """EV100 of an exposure: log2(N^2 / t) - log2(ISO / 100); each of t (s), N, ISO positive and finite, else
    ValueError naming it."""
    for name, value in (("exposure time", time_s), ("f-number", f_number), ("ISO", iso)):
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be a positive number, got {value!r}")
    return math.log2(f_number ** 2 / time_s) - math.log2(iso / 100.0)


def white_luminance(ev: float) -> float:
    """cd/m^2 of the sensor's white (clip level 1) at EV100 ``ev``: 1.2 x 2^EV100."""
    return WHITE_FACTOR * 2.0 ** ev


@dataclass(frozen=True)
class Scale:
    """How PanoLight's relative units (1 = the camera's white) stand to physical ones. cd_m2: cd/m^2 per unit
    (None: relative, nothing gives the scale); origin: what gave it ("exif", "ev100": --ev100, "lux": --lux);
    ev100: the EV100 it stands for (from --lux, the EV100 that white would have); iso_assumed: the EXIF recorded no
    ISO, and 100 was taken."""

    cd_m2: float | None = None
    origin: str = "none"
    ev100: float | None = None
    iso_assumed: bool = False  # the EXIF recorded no ISO: 100 was taken (the scale is then a guess)

    @property
    def absolute(self) -> bool:
        return self.cd_m2 is not None

    def describe(self) -> dict:
        """lighting.json's ``units`` object (io/lighting.py's schema)."""
        if not self.absolute:
            return {"absolute": False, "radiance": "relative: 1 = the camera's white",
                    "why": "nothing gives the scale: the file records no exposure (EXIF ExposureTime, FNumber, ISO); "
                           "--ev100 or --lux sets it"}
        return {"absolute": True, "radiance": "cd/m^2", "light_intensity": "lux", "watts_per_lumen": 1.0 / LUMENS_PER_WATT,
                "from": self.origin, "ev100": round(self.ev100, 4) if self.ev100 is not None else None,
                "white_cd_m2": self.cd_m2, **({"iso_assumed": True} if self.iso_assumed else {}),
                "convention": "EV100 = log2(N^2/t) - log2(ISO/100); white = 1.2 x 2^EV100 cd/m^2 (ISO 12232 "
                              "saturation speed, q = 0.65); 683 lm/W"}


RELATIVE = Scale()


def from_ev100(ev: float, origin: str = "ev100") -> Scale:
    """The Scale of a picture exposed at EV100 ``ev`` (ValueError outside EV100_RANGE)."""
    if not (math.isfinite(ev) and EV100_RANGE[0] <= ev <= EV100_RANGE[1]):
        raise ValueError(f"EV100 must be within {EV100_RANGE[0]:g}..{EV100_RANGE[1]:g}, got {ev!r}")
    return Scale(white_luminance(ev), origin, float(ev))


def from_exposure(exposure: dict | None) -> Scale:
    """The Scale a photo's EXIF gives ({"time_s", "f_number", "iso"[, "iso_recorded"]}: ``io.capture.read_exposure``'s),
    or RELATIVE where it records none or an EV100 beyond EV100_RANGE; an ISO the file did not record (ISO 100
    taken) is said (``iso_assumed``)."""
    if not exposure:
        return RELATIVE
    try:
        scale = from_ev100(ev100(exposure["time_s"], exposure["f_number"], exposure["iso"]), "exif")
    except (KeyError, TypeError, ValueError):
        return RELATIVE
    return replace(scale, iso_assumed=exposure.get("iso_recorded") is False)


def from_lux(lux: float, upward_illuminance: float) -> Scale:
    """The Scale that makes a model whose upward illuminance is ``upward_illuminance`` (relative units x sr, the
    cosine-weighted integral over the upper hemisphere) read ``lux`` (a light meter at the camera, facing up)."""
    if not (math.isfinite(lux) and 0.0 < lux <= MAX_LUX):
        raise ValueError(f"--lux must be within 0..{MAX_LUX:g} lux, got {lux!r}")
    if not (math.isfinite(upward_illuminance) and upward_illuminance > 0.0):
        raise ValueError("the estimate lights an upward surface with nothing, so no --lux can scale it")
    cd_m2 = lux / upward_illuminance
    return Scale(cd_m2, "lux", math.log2(cd_m2 / WHITE_FACTOR))


def summary(physical: dict | None) -> str:
    """One line of a lighting document's ``physical`` block (``Scale.describe`` and the pipeline's figures), for the
    run's log and Blender's panel: which units the files hold and what one unit is. Never raises on a malformed
    block (a stored estimate a user edited): it says the scale is unknown."""
    try:
        if not physical or not physical.get("absolute"):
            return "relative (1 = the camera's white); no exposure recorded: --ev100 or --lux sets the scale"
        origin = {"exif": "EXIF", "ev100": "--ev100", "lux": "--lux"}.get(physical.get("from"), "?")
        white = float(physical["white_cd_m2"])
        up = physical.get("upward_illuminance_lux")
        lux = f"; {float(up):.3g} lux on an upward surface" if up is not None else ""
        guess = "; no ISO recorded, 100 assumed" if physical.get("iso_assumed") else ""
        if physical.get("applied"):
            return f"cd/m^2 and lux (white {white:.3g} cd/m^2, from {origin}{guess}{lux})"
        return f"relative: 1 = the camera's white = {white:.3g} cd/m^2 (from {origin}{guess}){lux}"
    except (TypeError, ValueError, KeyError, AttributeError):
        return "the stored scale cannot be read"


def document_gain(doc: dict) -> float:
    """A lighting document's values per unit of its photo's relative units (1 = the camera's white): 2^exposure_ev,
    times the camera's white in cd/m^2 where the values carry the absolute scale (``physical.applied``). The plate in
    the document's units is the photo's linear pixels times this. ValueError naming the field where a stored document
    (one a user edited) gives no usable figure."""
    ev = doc.get("exposure_ev", 0.0)
    if not (isinstance(ev, (int, float)) and not isinstance(ev, bool) and math.isfinite(ev) and abs(ev) <= 64):
        raise ValueError(f"'exposure_ev' must be a number within -64..64, got {ev!r}")
    physical = doc.get("physical") or {}
    if not isinstance(physical, dict):
        raise ValueError("'physical' must be an object")
    per = 1.0
    if physical.get("applied"):
        per = physical.get("white_cd_m2")
        if not (isinstance(per, (int, float)) and not isinstance(per, bool) and math.isfinite(per) and per > 0):
            raise ValueError(f"'physical.white_cd_m2' must be a positive number where 'applied' is true, got {per!r}")
    return 2.0 ** ev * float(per)


def blender_factor(physical: dict | None) -> float | None:
    """W/m^2/sr per unit of a lighting document's values (its ``physical`` block), Blender's radiometric units at
    683 lm/W: the camera's white / 683 for relative values, 1 / 683 for values already in cd/m^2 (``applied``); None
    where no scale is known or the block cannot be read (a stored estimate a user edited)."""
    try:
        if not physical or not physical.get("absolute"):
            return None
        per = 1.0 if physical.get("applied") else float(physical["white_cd_m2"])
    except (TypeError, ValueError, KeyError, AttributeError):
        return None
    return per / LUMENS_PER_WATT if math.isfinite(per) and per > 0 else None
