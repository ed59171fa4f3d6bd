"""The key light: the compact source (a sun, a lamp) inside a clipped region, and what it weighs.

An auto-exposing camera clips a wide patch of bright sky or wall around a sun or lamp, and the
per-source model's even fill of that patch is no shadow-casting light. ``find_key_lights`` takes each
region that holds at least key_share of the scene's predicted energy (a clear sky's sun from sun_share) and
makes it one explicit light:

- where: the region's clipped-area centroid. Measured on the real HDRs at ev 0 (docs/keylight.md), it
  beat a glare-law fit of the unclipped ring, a clear-sky fit with the sun's position free, and a
  circle fitted to the region's sky-side boundary (median 3.4 degrees against 3.2-11).
- how much: for a sun in a clear sky, the Hosek-Wilkie fit of the visible sky (``sky``) weighs the solar
  disk in camera units, times sky_correction, the median of true / physical over the real HDRs'
  un-clipped suns (``training/keylight/cv.py``, by scene), capped at the per-source model's mean for the
  region, but on a compact patch and a sun at least floor_min_elevation_deg up never below the fit's 68 %
  low end (``physics_trusted``: the cap must not make a well-located sun vanish), its patch never holding
  more than the high end (``cap_log_ratios``); otherwise (a lamp, a window, a veiled sun, a cloudy sky) the
  energy the decision rule reports for the region (``key_energy``, "hybrid" in the study: over the real HDRs it halves the
  mean m-RMSE of "capped", which gave lamps the model's unshrunk mean; ``training/keylight/rules.py``).
- which: a region wider than plateau_extent_deg makes a key light only when a clear-sky sun is in it (the
  fit passes the cloudiness gate: its residual, the sky it rests on and its colour, ``sky.MIN_BLUENESS``); a
  wide patch of overcast sky or a white wall is lit evenly, and a point light there would cast a shadow
  the scene does not have. One sun in the sky: of the regions whose fit passes, the best-fitting one holds
  it, and a region touching it (the sun's patch cut in two) is part of the same light.
- a sun the photo does not show: where no region holds a clear-sky sun, the clear-sky position that best fits
  the visible sky (``sun_search.search_sun``) becomes a sun when the sky is clear, singles the position out,
  varies in colour as a sky does, and no occluder or clipped region stands there (``hidden_sun``).
- shape and colour: a sun is a 0.53 degree disk in the fitted sun's colour as a camera shows it
  (``camera_colour``: the model's D65 colour over camera_white from 20 degrees up, so a noon sun is about white
  and a sunset warm); a lamp
  takes the size of its clipped core and the colour of its glare (the unclipped ring's excess over the
  background just beyond it), unless that is blue sky.
Work maps: (h, 2h, 3) linear, clip units (1 = white), Blender world frame (CONVENTIONS.md). Every constant
named here is a field of ``KeyLightParams`` (``PARAMS``: what ships).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .. import sh
from ..camera.color import LUMINANCE_WEIGHTS
from . import sky as clear_sky
from . import sun_search
from .highlights import region_centres, region_sums

SUN_DIAMETER_DEG = 0.53  # the sun's angular diameter seen from the earth


@dataclass(frozen=True)
class KeyLightParams:
    """The key light's constants, in one place: what decides which regions hold a key light, where it stands,
    what it weighs and how it looks. Each was measured over the real HDRs (docs/keylight.md; the studies in
    docs/studies/ and training/keylight/). The shipped values are ``PARAMS``; a study varies one with
    ``dataclasses.replace(PARAMS, name=value)``.

    key_share: a region whose predicted energy is at least this share of the scene's holds a key light.
    sun_share: ... or this share, if a clear sky's sun is in it: the sky's own evidence admits the sun, the share
        only keeps glints out. A low sun's share wavers with the pixel grid (dawn.jpg turned by 333 pixels: 0.086
        against 0.103; sunset_water.jpg's sun 3.5 degrees up, which the trees weigh at 3-6 %), and the sun should
        not come and go with it. No scene of the 68 real HDRs at ev -2/0/+2 changes between 0.05 and 0.02; with no
        floor, ten false weak "suns" appear (night skies, rooms).
    max_keys: the most key lights one panorama gets.
    sky_correction: true / physical sun energy: the real suns' median (training/keylight/cv.py: 2.20 over 28,
        folds 2.05-2.37).
    camera_white: the camera's white point in the model's linear sRGB (D65), luminance 1: a camera balances
        sunlit daylight to about neutral, so the model's sun colour over this is what it shows (the median over
        the 27 clear fits of 12 real suns 20 degrees up or more; by fold 1.13-1.17 / 0.97-0.98 / 0.75-0.81;
        training/keylight/sun_colour.py) ...
    white_ramp_deg: ... for a sun at least [1] degrees up (none of it below [0], a share linear in between): the
        real suns 20 degrees up or more came closer to their truth 11 times of 12, those lower (warm, and left
        warm by their photographers) as often farther as closer.
    sky_spread: the clear-sky energy's 68 % range, a factor (the cross-validated spread).
    lamp_min_diameter_deg: the smallest angular diameter of a lamp (a light that is not a clear-sky sun).
    shoulder: linear (clip level 1; sRGB 225): above it a channel sits on the camera's highlight shoulder, and a
        glare colour is not read there.
    plateau_extent_deg: a region this wide (angular radius) with no clear-sky sun in it is a plateau (an overcast
        sky, a window wall), not a compact source: its even fill stays and it makes no light.
    hidden_clearance_deg: a sun found from the sky alone (``sun_search.search_sun``) is a hidden one only this far
        beyond every clipped region (its angular radius plus this): nearer, the region is the sun the photo shows.
    direction_68_per_extent: a light's direction error: within this share of its region's angular radius (at
        least one work cell) for 68 % of the dominant sources of the real HDRs at ev -2/0/+2.
    floor_max_extent_deg, floor_min_elevation_deg: a clear-sky sun whose region is no wider (angular radius) and
        that stands at least this high keeps at least its fit's 68 % low end, its patch at most the high end
        (``physics_trusted``): there the centroid is on the sun and the fit was checked; a wider patch's centroid
        is degrees off, and a low sun's haze makes the model's sun too strong.
    belief: a key light carries what its evidence believes, not the decided fill's caution: the per-source model's
        mean energy for its regions, a clear-sky sun the geometric mean of that and its fit's (two estimates
        averaged in log), and never less than the decided fill's (so its region holds one account: the light).
        What an HDR file's clipped plateau gets (``with_key_lights``): the plateau is a few pixels around the
        source, its place sure, its surroundings un-clipped and linear (docs/studies/captures.md).
    """

    key_share: float = 0.1
    sun_share: float = 0.02
    max_keys: int = 3
    sky_correction: float = 2.25
    camera_white: tuple = (1.1542, 0.9772, 0.7713)
    white_ramp_deg: tuple = (10.0, 20.0)
    sky_spread: float = 2.0
    lamp_min_diameter_deg: float = 1.0
    shoulder: float = 0.75
    plateau_extent_deg: float = 30.0
    hidden_clearance_deg: float = 20.0
    direction_68_per_extent: float = 0.25
    floor_max_extent_deg: float = 30.0
    floor_min_elevation_deg: float = 15.0
    belief: bool = False


PARAMS = KeyLightParams()  # what ships


@dataclass
class KeyLight:
    """A key light: unit direction (3,), luminance energy (clip units x sr), colour (luminance 1), angular
    diameter (radians), the 68 % range of the source's true energy (the belief; ``energy`` is what
    ``key_energy`` decides, which may lie below it), the region it came from and how it was weighed, the
    direction's 68 % error radius (radians: ``direction_68_per_extent`` of the region's radius, at least a cell),
    the cap on its regions' energy, and the candidates ``key_energy`` decided from."""

    direction: np.ndarray
    energy: float
    color: np.ndarray
    angle: float
    energy_68: tuple
    region: int  # -1: a hidden sun, which no clipped region holds (its energy is added, none taken from a fill)
    method: str
    physical: float | None = None  # the clear-sky fit's energy x sky_correction
    sky: clear_sky.SkyFit | None = None  # the clear-sky fit tried at its direction (clear or not); None below the horizon
    direction_68: float = 0.0
    parts: tuple = ()  # other regions of the same source (a sun's patch split in two): its energy comes from them too
    cap: float | None = None  # the most its regions may hold beyond their clip level, light and fill together: a
    # trusted sun's fit x sky_spread (the high end of its 68 % range; ``cap_log_ratios``); None: no cap
    weak: bool = False  # a clear-sky sun admitted under key_share only because its fit passes (from sun_share)
    learned: float = 0.0  # the per-source model's mean energy for its regions (``key_energy``'s candidates) ...
    decided: float = 0.0  # ... the decided fill's ...
    trusted: bool = False  # ... and whether its clear-sky fit bounds it (``physics_trusted``)

    def as_light(self) -> dict:
        """A lighting-file light dict (energy as intensity)."""
        return {"type": "sun" if math.degrees(self.angle) <= 5.0 else "area",
                "direction": [float(v) for v in self.direction], "peak_direction": [float(v) for v in self.direction],
                "color": [float(v) for v in self.color], "intensity": float(self.energy), "angle": float(self.angle),
                "energy_68": [float(v) for v in self.energy_68],
                "direction_68_deg": round(math.degrees(self.direction_68), 3), "source": self.method}


def _ring_color(rad, frac_any, labels, region, direction, radius, shoulder: float) -> np.ndarray:
    """Colour (luminance 1) of a region's glare: the mean of the unclipped cells within 3 work cells outside
    its angular ``radius`` (radians) around ``direction``, less the mean of the next 3 cells out (the
    background the glare sits on: a grey wall under a sodium lamp would wash its colour out), both without
    cells on the camera's shoulder (a channel above ``shoulder``, where channels compress toward white). The
    plain inner ring's colour where that difference is not a positive colour (no glare falloff). White where no
    ring is seen, where the background is bluer than red (a blue sky: the difference of two rings of sky is the
    sky's own gradient toward the sun, warm whatever the source; pmndrs_sky at ev 0 got (1.23, 1.00, 0.36) for a
    sun of (1.00, 1.01, 0.92)), or where the colour found is bluer than red (blue sky around a sun, not the
    source's own glare): the camera's white then. A synthetic sodium lamp keeps its chromaticity to 0.03 (tests)."""
    h, w = labels.shape
    cell = math.pi / h
    cos_t = sh.pixel_directions(h, w) @ direction
    free = (labels != region) & (frac_any == 0)
    inner = free & (cos_t > math.cos(radius + 3 * cell))
    outer = free & ~inner & (cos_t > math.cos(radius + 6 * cell))
    om = sh.pixel_solid_angles(h, w)

    def mean(cells):
        return (rad[cells] * om[cells][:, None]).sum(0) / om[cells].sum() if cells.sum() >= 2 else None

    rgb = mean(inner)
    if rgb is None:
        return np.ones(3)
    below = rad.max(axis=-1) < shoulder
    a, b = mean(inner & below), mean(outer & below)
    if b is not None and b[2] > b[0]:
        return np.ones(3)
    if a is not None and b is not None and (a - b).min() > 0:
        rgb = a - b
    y = float(rgb @ LUMINANCE_WEIGHTS)
    return rgb / y if y > 0 and rgb[2] <= rgb[0] else np.ones(3)


def camera_colour(rgb, elevation_deg: float, params: KeyLightParams = PARAMS) -> np.ndarray:
    """(3,) a clear-sky model's sun colour (linear sRGB referred to D65, any scale) for a sun ``elevation_deg`` up as a
    camera of white point ``params.camera_white`` shows it: divided by white^t, luminance 1, t the share of
    ``params.white_ramp_deg`` the elevation has reached (0 below it, 1 above). The model's noon sun, (1.15, 0.98,
    0.77), comes out about white, as real photos show it; a sun 10 degrees up or lower keeps the model's colour."""
    lo, hi = params.white_ramp_deg
    t = min(max((float(elevation_deg) - lo) / (hi - lo), 0.0), 1.0)
    c = np.asarray(rgb, dtype=np.float64) / np.asarray(params.camera_white, dtype=np.float64) ** t
    return c / float(c @ LUMINANCE_WEIGHTS)


def key_energy(physical: float | None, learned: float, decided: float, trusted: bool,
               params: KeyLightParams = PARAMS) -> float:
    """A key light's energy (luminance x sr, camera units) from its candidates: the clear-sky fit's (x
    sky_correction; None where there is none), the per-source model's mean and the decided fill's. A clear-sky
    sun takes its fit's energy capped at the larger of the mean and the decided fill, but never below the low end
    of the fit's 68 % range (fit / sky_spread) where the fit is ``trusted`` (``physics_trusted``); any other
    light takes the decided fill's. With ``params.belief`` any light takes its belief: the model's mean (``learned``),
    for a clear-sky sun the geometric mean of it and the fit's, at least the decided fill's. (The rules compared
    with it, "hybrid" in the study, are training's: training/keylight/rules.py; docs/studies/keylight_energy.md.)"""
    if params.belief:
        return max(learned if physical is None else math.sqrt(learned * physical), decided)
    if physical is None:
        return decided
    capped = min(physical, max(decided, learned))
    return max(capped, physical / params.sky_spread) if trusted else capped


def physics_trusted(extent_deg: float, elevation_deg: float, params: KeyLightParams = PARAMS) -> bool:
    """Whether a clear-sky sun's fit is trusted enough that its 68 % range bounds it: ``key_energy`` keeps the
    light at least at the low end, and its regions hold at most the high end (``KeyLight.cap``). Its region at most
    ``params.floor_max_extent_deg`` wide (angular radius; the centroid, where the fit puts the sun, is then on it)
    and the sun at least ``params.floor_min_elevation_deg`` up (lower, haze makes the model's sun too strong).
    ``find_key_lights`` also asks that the trees weigh it as a key light (key_share), not the sky alone."""
    return extent_deg <= params.floor_max_extent_deg and elevation_deg >= params.floor_min_elevation_deg


def find_key_lights(maps, regions, prediction, params: KeyLightParams = PARAMS, fits: dict | None = None
                    ) -> list[KeyLight]:
    """Key lights of the clipped ``regions`` (``sources.Regions``) of the work ``maps`` (rad, frac_any, frac_all:
    ``highlights.work_maps``), given the per-source model's ``prediction`` per region, (mu, sigma, reported):
    natural logs of the energy ratio, reported the decided fill's (None: mu). The regions holding at least
    key_share of the scene's predicted energy, largest first, at most max_keys, each located and weighed (module
    doc; ``region_candidates``), then a sun the photo does not show (``with_hidden_sun``). fits: a dict that
    keeps each region's clear-sky fit (by region index; the sun search under -1), filled here and read again
    when given filled (``sun_search_report`` reads it)."""
    keys = [k for k in region_candidates(maps, regions, prediction, params, fits) if k.energy > 0]
    return with_hidden_sun(keys, maps, regions, params, fits)


def with_hidden_sun(keys: list, maps, regions, params: KeyLightParams = PARAMS, fits: dict | None = None) -> list:
    """``keys`` with a sun the photo does not show, where no region holds a clear-sky sun the trees weigh as a key
    light: ``hidden_sun`` may add one (retouched out, veiled, or not clipped), located and weighed from the
    visible sky alone (``sun_search``). A sun the sky search places replaces a weakly admitted region sun
    (``KeyLight.weak``: a glint on the sea whose clear-sky fit passes would otherwise keep a retouched photo from
    its sun): one sun in the sky."""
    strong = [k for k in keys if not k.weak]
    if _holds_clear_sky_sun(keys) or len(strong) >= params.max_keys:
        return keys
    rad, frac_any, frac_all = maps
    if fits is not None and -1 in fits:
        search = fits[-1]
    else:
        search = sun_search.search_sun(rad, frac_any == 0, frac_all > 0.5)
        if fits is not None:
            fits[-1] = search
    hidden = hidden_sun(search, regions, params)
    return keys if hidden is None else strong + [hidden]


def _holds_clear_sky_sun(keys) -> bool:
    """Whether a clipped region's key light is a clear-sky sun the trees weigh as a key light (then no hidden sun
    is searched for; a weakly admitted one may give way to the sky search's)."""
    return any(k.method.startswith("clear-sky") and not k.weak for k in keys)


def hidden_refusals(search: sun_search.SunSearch | sun_search.NoSun, regions, params: KeyLightParams = PARAMS
                    ) -> list[str]:
    """Why no hidden sun is made from this search, one phrase per reason (empty: it is): the search's own tests
    (``SunSearch.refusals``, or why it stopped: ``NoSun``), a sun behind an occluder (whose shade the camera would
    be in), or a clipped region within its radius plus ``params.hidden_clearance_deg`` of it (the sun the photo
    shows, weighed as a region)."""
    out = search.refusals()
    if not isinstance(search, sun_search.SunSearch):
        return out
    if not search.seen:
        out.append("behind an occluder (the camera would be in its shade)")
    if regions.count:
        apart = np.degrees(np.arccos(np.clip(regions.centre @ search.direction, -1.0, 1.0)))
        if (apart <= regions.extent_deg() + params.hidden_clearance_deg).any():
            out.append(f"a clipped region within {params.hidden_clearance_deg:g} deg of it holds the sun the photo "
                       f"shows")
    return out


def sun_search_report(fits: dict, keys: list, regions, params: KeyLightParams = PARAMS) -> dict:
    """lighting.json's account of the sun search (``estimator.sun_search``) after ``find_key_lights`` found
    ``keys`` and filled ``fits`` on these ``regions``: whether it ran, where the sky puts a sun, and whether a
    hidden sun was made or why not."""
    if _holds_clear_sky_sun(keys):
        return {"searched": False, "why": "a clipped region holds a clear-sky sun"}
    if -1 not in fits:
        return {"searched": False, "why": f"{params.max_keys} key lights already"}
    search = fits[-1]
    out = {"searched": True, "hidden_sun": any(k.region < 0 for k in keys),
           "refused": hidden_refusals(search, regions, params)}
    if isinstance(search, sun_search.SunSearch):
        out.update(direction=[round(float(v), 6) for v in search.direction], elevation_deg=round(search.elevation_deg, 2),
                   direction_68_deg=round(search.direction_68_deg, 2))
    return out


def hidden_sun(search: sun_search.SunSearch | sun_search.NoSun, regions, params: KeyLightParams = PARAMS
               ) -> KeyLight | None:
    """The key light of a sun the photo does not show, from ``sun_search.search_sun``, where ``hidden_refusals``
    has nothing against it. Its energy is the fit's solar disk x sky_correction, added to the map (no region's
    fill holds it), a 0.53 degree disk in the model sun's colour; its direction's 68 % radius
    the search's (``SunSearch.direction_68_deg``: how far positions that fit nearly as well reach). None otherwise."""
    if hidden_refusals(search, regions, params):
        return None
    fit = search.fit
    physical = params.sky_correction * fit.sun_energy
    if not physical > 0:
        return None
    return KeyLight(np.asarray(search.direction, dtype=np.float64), float(physical),
                    camera_colour(fit.sun_rgb, search.elevation_deg, params),
                    math.radians(SUN_DIAMETER_DEG), (physical / params.sky_spread, physical * params.sky_spread), -1,
                    f"hidden sun: clear-sky fit of the visible sky (turbidity {fit.turbidity:g})", physical, fit,
                    math.radians(search.direction_68_deg), learned=float(physical), decided=float(physical))


def region_candidates(maps, regions, prediction, params: KeyLightParams = PARAMS, fits: dict | None = None
                      ) -> list[KeyLight]:
    """The key lights of the clipped regions (``find_key_lights`` without the hidden sun), each weighed by
    ``key_energy`` and carrying its candidates (``learned``, ``decided``, ``trusted``), including any whose energy
    came out 0 (``find_key_lights`` drops those; a study weighing them otherwise keeps them)."""
    rad, frac_any, frac_all = maps
    mu, sigma, reported = prediction
    if regions.count == 0:
        return []
    h, w = regions.labels.shape
    omega = sh.pixel_solid_angles(h, w)
    lum = rad @ LUMINANCE_WEIGHTS
    predicted = regions.held * np.exp(mu)
    scene = float((lum * omega).sum()) + float((predicted - regions.held).sum())
    extent = regions.extent_deg()
    radius = np.sqrt(regions.clipped_sr / math.pi)  # each region's angular radius, radians

    def fit_at(direction):  # the clear-sky fit with the sun there; None below the horizon
        return clear_sky.fit_clear_sky(rad, frac_any == 0, frac_all > 0.5, direction) if direction[2] > 0 else None

    chosen, weak = [], set()
    for i in map(int, np.argsort(-predicted)):
        if predicted[i] < params.sun_share * scene:
            break
        below = predicted[i] < params.key_share * scene  # then only a sun in a clear sky, where no stronger region holds one
        if below and (regions.centre[i][2] <= 0 or any(f is not None and f.clear for _, f in chosen)):
            continue
        if fits is not None and i in fits:
            fit = fits[i]
        else:
            fit = fit_at(regions.centre[i])
            if fits is not None:
                fits[i] = fit
        if below:
            if not (fit is not None and fit.clear):
                continue
            weak.add(i)
        chosen.append((i, fit))
    # one sun in the sky: of the regions whose clear-sky fit passes, the best-fitting one holds it; a region
    # next to it (the same sun's patch split in two) makes no light of its own, one further off is weighed
    # as any other region
    clear = [(fit.rms, i) for i, fit in chosen if fit is not None and fit.clear]
    sun = min(clear)[1] if clear else None
    part_of_sun = set()
    if sun is not None:
        for i, _ in chosen:
            apart = math.acos(float(np.clip(regions.centre[i] @ regions.centre[sun], -1.0, 1.0)))
            if i != sun and apart <= radius[i] + radius[sun] + 2.0 * math.pi / h:
                part_of_sun.add(i)
    keys = []
    for i, fit in chosen:
        if sum(k.energy > 0 for k in keys) == params.max_keys:  # the lights find_key_lights keeps
            break
        if i in part_of_sun or (i in weak and i != sun):
            continue
        direction = regions.centre[i]
        parts = [i, *sorted(part_of_sun)] if i == sun else [i]  # the regions this light stands for
        if len(parts) > 1:  # the sun sits at the centroid of its whole patch, fitted there again
            v = (regions.clipped_sr[parts, None] * regions.centre[parts]).sum(axis=0)
            centroid = v / np.linalg.norm(v)
            refit = fit_at(centroid)
            if refit is not None and refit.clear:
                direction, fit = centroid, refit
        learned = regions.added_energy(mu, parts)
        lo = regions.added_energy(np.maximum(mu - sigma, 0.0), parts)
        hi = regions.added_energy(mu + sigma, parts)
        decided = regions.added_energy(reported, parts) if reported is not None else learned
        physical = None
        if i == sun:
            physical = params.sky_correction * fit.sun_energy
            elevation = sh.elevation_deg(direction)
            color = camera_colour(fit.sun_rgb, elevation, params)
            lo, hi = physical / params.sky_spread, physical * params.sky_spread
            method, angle = f"clear-sky fit (turbidity {fit.turbidity:g})", math.radians(SUN_DIAMETER_DEG)
        else:
            if extent[i] > params.plateau_extent_deg:
                continue
            color = _ring_color(rad, frac_any, regions.labels, i, direction, radius[i], params.shoulder)
            method = "per-source model"
            # a lamp (or a veiled sun) as wide as a third of its clipped core
            angle = max(math.radians(params.lamp_min_diameter_deg), 2.0 * radius[i] / 3.0)
        # a sun the trees weigh as a key light: one only the sky admits (under key_share) keeps their weight, as a
        # cloud edge whose fit passes is no sun to give half its fit (dawn.jpg saved again: 67x the trees')
        trusted = physical is not None and i not in weak and physics_trusted(float(extent[i]), elevation, params)
        energy = key_energy(physical, learned, decided, trusted, params)
        if params.belief and physical is not None:  # the belief's range: the trees' and the fit's, averaged in log
            lo = math.sqrt(regions.added_energy(np.maximum(mu - sigma, 0.0), parts) * lo)
            hi = math.sqrt(regions.added_energy(mu + sigma, parts) * hi)
        keys.append(KeyLight(np.asarray(direction, dtype=np.float64), float(energy), np.asarray(color, dtype=np.float64),
                             float(angle), (float(lo), float(hi)), i, method, physical, fit,
                             max(params.direction_68_per_extent * math.radians(float(extent[i])), math.pi / h),
                             tuple(parts[1:]), physical * params.sky_spread if trusted else None, i in weak,
                             float(learned), float(decided), bool(trusted)))
    return keys


def with_key_lights(rec, params: KeyLightParams = PARAMS):
    """A per-source recovery (``sources.Recovery``) with its key lights (``find_key_lights``) as explicit lights,
    and the account of the sun search (``sun_search_report``): what the ``keylight`` estimator ships. An HDR file's
    clipped plateau (``rec.source``) carries its belief (``KeyLightParams.belief``)."""
    regions = rec.regions
    if rec.source is not None:
        params = replace(params, belief=True)
        regions = at_cores(regions, rec.source.core_fraction(regions.labels.shape[0]))
    fits = {}
    keys = find_key_lights(rec.maps, regions, (rec.mu, rec.sigma, rec.log_ratio), params, fits)
    return rec.with_keys(keys, sun_search_report(fits, keys, regions, params))


def at_cores(regions, core: np.ndarray):
    """``regions`` (``sources.Regions``) whose centres are moved to the centroid of their cells' ``core`` (h, w):
    the share of an HDR file's pixels with every channel at the ceiling (``restore.Source.core_fraction``), where
    a region holds any; the others keep theirs. A warm sun's plateau of two channels reaches out over the redder side
    of its aureole, and its all-channel core is nearer the sun: out of fold, three brackets of a sunset placed it
    3.5 degrees off at the plateau's centroid (docs/studies/captures.md)."""
    if regions.count == 0:
        return regions
    held = region_sums(regions.labels, regions.count, core)[0] > 0
    if not held.any():
        return regions
    centre = np.where(held[:, None], region_centres(regions.labels, core, regions.count), regions.centre)
    return replace(regions, centre=centre)

