"""The artist's sun: a sun where the artist says it is (``--sun``, ``--sun-direction``, Blender's *Pick sun*, or
the photo's capture metadata), weighed by the clear sky with the sun fixed there or by the photo's lit / shadow
ground (``--sun-contrast``), in place of any sun the estimate found (docs/keylight.md "The artist's sun")."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ... import sh
from ...camera.ceiling import POINTED_REACH_DEG
from ...camera.color import LUMINANCE_WEIGHTS
from ...errors import PanoLightError
from .. import sky as clear_sky
from .light import KeyLight
from .params import PARAMS, SUN_DIAMETER_DEG, KeyLightParams
from .weighing import camera_colour, clear_sky_energy, weigh

POINTED_CELLS = 1.0  # a pointed sun stands for the clipped region it lies in, or within this many work cells of
METADATA_DEFERS_DEG = 5.0  # a sun from the capture's metadata gives way to one the photo shows and places within this
# (68 %): a compact clipped sun is placed within a degree or two, a phone's or 360 camera's compass heading seldom
# better than 5-10 degrees


class SkyCannotWeigh(PanoLightError):
    """A pointed sun that no clear sky weighs (below the horizon, overcast, indoors); ``reason`` says which."""

    def __init__(self, message: str, reason: str):
        super().__init__(message)
        self.reason = reason


def photo_places_sun(rec) -> str | None:
    """Why the photo's own sun is surer than its metadata's (a clear-sky sun found in a clipped region and placed
    within METADATA_DEFERS_DEG for 68 %), or None: no sun found, a hidden one put back from the sky alone, or a
    wide patch (where the metadata's direction is the better evidence)."""
    for k in rec.keys:
        if k.method.startswith("clear-sky") and math.degrees(k.direction_68) <= METADATA_DEFERS_DEG:
            return (f"the photo shows its sun, placed within {math.degrees(k.direction_68):.1f} deg (68 %): surer than "
                    f"a compass heading")
    return None


def with_pointed_sun(rec, direction, contrast: float | None = None, params: KeyLightParams = PARAMS):
    """A per-source recovery (with or without its key lights) with the artist's sun at unit ``direction``
    (CONVENTIONS.md frame) in place of any sun the estimate found (one sun in the sky; lamps stay). Weighed by
    the clear-sky fit of the visible sky with the sun fixed there (x sky_correction, its 68 % range the fit's, as a
    found sun's), or, with ``contrast`` R (lit / shadow of a white surface facing it, the photo's own ground), so
    that the sun carries 1 - 1/R of that surface's irradiance (EVALUATION.md's shadow contrast) against the rest of
    the lighting to SH order 2. A sun in (or next to) a clipped region stands for it: its energy comes out of the
    region's fill first, so the total stays honest; elsewhere (a sun the photo hides) it is added. An HDR file's
    restored plateau (``rec.source``) is weighed as the restoration weighs a found one (its belief: the trees' mean,
    and with a clear sky the geometric mean of it and the fit's), only placed where the artist says.
    PanoLightError when the sky cannot weigh it (below the horizon, no clear sky): give ``contrast`` then."""
    d = np.asarray(direction, dtype=np.float64)
    d = d / np.linalg.norm(d)
    rad, frac_any, frac_all = rec.maps
    regions = rec.regions
    h = rad.shape[0]
    region = -1
    if regions.count:
        apart = np.arccos(np.clip(regions.centre @ d, -1.0, 1.0))
        near = apart - np.sqrt(regions.clipped_sr / math.pi)
        reach = POINTED_CELLS * math.pi / h
        if rec.source is not None:  # an HDR file's plateau: the one the click is on or next to (pointed_ceiling's)
            reach = max(reach, math.radians(POINTED_REACH_DEG))
        if near.min() <= reach:
            region = int(np.argmin(near))
    others = [k for k in rec.keys if not (k.method.startswith(("clear-sky", "hidden sun")) or
                                          (region >= 0 and region in (k.region, *k.parts)))]
    elevation = sh.elevation_deg(d)
    fit = clear_sky.fit_clear_sky(rad, frac_any == 0, frac_all > 0.5, d) if d[2] > 0 else None
    if contrast is not None:
        held = rec.with_keys(others)  # the lighting without a sun: what the pointed one is weighed against
        rest = float(sh.irradiance(sh.project(held.work, 2), d[None])[0] @ LUMINANCE_WEIGHTS)
        excess = (float(np.expm1(held.log_ratio[region]) * regions.held[region]) if region >= 0 else 0.0)
        energy = (contrast - 1.0) * max(rest - excess, 0.0)  # the sun took the region's whole fill
        if energy < excess:  # ... or only part of it: E = (R - 1) (rest - E)
            energy = (contrast - 1.0) * rest / contrast
        weight = weigh(None, given=energy, params=params)
        color = camera_colour(fit.sun_rgb, elevation, params) if fit is not None and fit.clear else np.ones(3)
        method = f"the artist's direction, weighed by the lit/shadow contrast {contrast:g}"
        physical = None
    elif rec.source is not None and region >= 0:  # an HDR file's restored plateau: weighed as a found one is,
        # at its belief (the trees' mean, for a clear-sky sun the geometric mean of it and the fit's), only placed here
        clear = fit is not None and fit.clear
        physical = clear_sky_energy(fit, params) if clear else None
        learned = regions.added_energy(np.maximum(rec.mu, 0.0), [region])  # a plateau holds at most its source
        weight = weigh(physical, learned, 0.0, params=replace(params, belief=True))
        own = [k for k in rec.keys if region in (k.region, *k.parts)]
        color = (camera_colour(fit.sun_rgb, elevation, params) if clear else
                 max(own, key=lambda k: k.energy).color if own else np.ones(3))
        method = ("the artist's direction, weighed as the file's clipped plateau" +
                  (f" and its clear-sky fit (turbidity {fit.turbidity:g})" if clear else ""))
    else:
        if fit is None or not fit.clear:
            why = "it is below the horizon" if d[2] <= 0 else "no clear sky fits the photo with the sun there"
            raise SkyCannotWeigh(f"the sun pointed at ({elevation:.1f} deg up) cannot be weighed by its sky ({why}): "
                                 f"give --sun-contrast R, the photo's lit / shadowed ground (e.g. 3)", why)
        physical = clear_sky_energy(fit, params)
        weight = weigh(physical, given=physical, params=params)  # the fit alone weighs it
        color = camera_colour(fit.sun_rgb, elevation, params)
        method = f"the artist's direction, weighed by its clear-sky fit (turbidity {fit.turbidity:g})"
    sun = KeyLight(d, weight.energy, np.asarray(color, dtype=np.float64), math.radians(SUN_DIAMETER_DEG),
                   weight.energy_68, region, method, physical, fit, 0.0, learned=weight.energy, decided=weight.energy)
    keys = others + ([sun] if weight.energy > 0 else [])  # the estimate's keys all carry energy
    return rec.with_keys(keys, {"searched": False, "why": "the artist gave the sun's direction"})
