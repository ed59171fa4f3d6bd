"""Finding the key lights: each clipped region that holds a compact source (a sun, a lamp) becomes one explicit
light (``find_key_lights``), and a sun the photo does not show is put back from its clear sky (``with_hidden_sun``).
What each weighs is ``weigh``'s; docs/keylight.md says why each rule is as it is.

- which: a region holding key_share of the scene's predicted energy (a clear sky's sun from sun_share); a region
  wider than plateau_extent_deg only with a clear-sky sun in it (an overcast patch or a white wall is lit evenly).
  One sun in the sky: of the regions whose clear-sky fit passes, the best-fitting one holds it.
- where: the region's clipped-area centroid (an HDR file's plateau: its all-channel core, ``at_cores``).
- a sun the photo does not show: where no region holds a clear-sky sun, the position that best fits the visible sky
  (``sun_search.search_sun``), if the sky is clear, singles it out, and nothing stands there (``hidden_sun``).
Work maps: (h, 2h, 3) linear, clip units (1 = white), Blender world frame (CONVENTIONS.md).
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ... import sh
from ...camera.color import LUMINANCE_WEIGHTS
from .. import sky as clear_sky
from .. import sun_search
from ..highlights import region_centres, region_sums
from .light import KeyLight
from .params import PARAMS, SUN_DIAMETER_DEG, KeyLightParams
from .weighing import camera_colour, clear_sky_energy, physics_trusted, ring_colour, weigh


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
    be in), a clipped region within its radius plus ``params.hidden_clearance_deg`` of it (the sun the photo
    shows, weighed as a region), and, where it passes all of those, SKY_ALONE unless ``params.sky_alone_sun``: the
    sky's gradient alone is no evidence of a sun. Out of fold a hazy sky passed every test and got a clear-sky sun
    2034x naive's m-RMSE (docs/studies/do_no_harm.md), so a sun the photo does not show is put back by default only
    from what the photo records (its capture metadata) or the artist's pointer; the note says where the sky puts it."""
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
    if not out and not params.sky_alone_sun:
        out.append(SKY_ALONE)
    return out


SKY_ALONE = "only the sky's gradient shows it"  # the one refusal that leaves the sky's sun a suggestion to place


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
    physical = clear_sky_energy(fit, params)
    if not physical > 0:
        return None
    weight = weigh(physical, given=physical, params=params)  # the fit alone weighs it: no region, no trees
    return KeyLight(np.asarray(search.direction, dtype=np.float64), weight.energy,
                    camera_colour(fit.sun_rgb, search.elevation_deg, params), math.radians(SUN_DIAMETER_DEG),
                    weight.energy_68, -1, f"hidden sun: clear-sky fit of the visible sky (turbidity {fit.turbidity:g})",
                    physical, fit, math.radians(search.direction_68_deg), learned=float(physical),
                    decided=float(physical))


def region_candidates(maps, regions, prediction, params: KeyLightParams = PARAMS, fits: dict | None = None
                      ) -> list[KeyLight]:
    """The key lights of the clipped regions (``find_key_lights`` without the hidden sun), each weighed by
    ``weigh`` and carrying its candidates (``learned``, ``decided``, ``trusted``), including any whose energy
    came out 0 (``find_key_lights`` drops those; a study weighing them otherwise keeps them)."""
    if regions.count == 0:
        return []
    chosen, weak = _chosen_regions(maps, regions, prediction[0], params, fits)
    sun, part_of_sun = _the_sun(chosen, regions)
    keys = []
    for i, fit in chosen:
        if sum(k.energy > 0 for k in keys) == params.max_keys:  # the lights find_key_lights keeps
            break
        if i in part_of_sun or (i in weak and i != sun):
            continue
        parts = [i, *sorted(part_of_sun)] if i == sun else [i]  # the regions this light stands for
        key = _region_light(maps, regions, prediction, parts, fit, i == sun, i in weak, params)
        if key is not None:
            keys.append(key)
    return keys


def _fit_at(maps, direction):
    """The clear-sky fit of the work ``maps`` with the sun at ``direction``; None below the horizon."""
    rad, frac_any, frac_all = maps
    return clear_sky.fit_clear_sky(rad, frac_any == 0, frac_all > 0.5, direction) if direction[2] > 0 else None


def _chosen_regions(maps, regions, mu, params: KeyLightParams, fits: dict | None) -> tuple[list, set]:
    """([(region, its clear-sky fit or None)], the weakly admitted regions), largest predicted energy first: each
    region holding key_share of the scene's predicted energy, and one under it (from sun_share) only where its sky
    is clear and no stronger region holds a clear sky (``KeyLight.weak``). ``fits`` caches the fits by region."""
    rad = maps[0]
    h, w = regions.labels.shape
    predicted = regions.held * np.exp(mu)
    scene = float(((rad @ LUMINANCE_WEIGHTS) * sh.pixel_solid_angles(h, w)).sum()) + \
        float((predicted - regions.held).sum())
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
            fit = _fit_at(maps, regions.centre[i])
            if fits is not None:
                fits[i] = fit
        if below:
            if not (fit is not None and fit.clear):
                continue
            weak.add(i)
        chosen.append((i, fit))
    return chosen, weak


def _the_sun(chosen: list, regions) -> tuple[int | None, set]:
    """(the region holding the sun, the regions that are part of it): one sun in the sky. Of the regions whose
    clear-sky fit passes, the best-fitting one holds it; a region next to it (the same sun's patch split in two)
    makes no light of its own, one further off is weighed as any other region."""
    clear = [(fit.rms, i) for i, fit in chosen if fit is not None and fit.clear]
    if not clear:
        return None, set()
    sun = min(clear)[1]
    h = regions.labels.shape[0]
    radius = np.sqrt(regions.clipped_sr / math.pi)  # each region's angular radius, radians
    part_of_sun = set()
    for i, _ in chosen:
        apart = math.acos(float(np.clip(regions.centre[i] @ regions.centre[sun], -1.0, 1.0)))
        if i != sun and apart <= radius[i] + radius[sun] + 2.0 * math.pi / h:
            part_of_sun.add(i)
    return sun, part_of_sun


def _region_light(maps, regions, prediction, parts: list, fit, is_sun: bool, weak: bool, params: KeyLightParams
                  ) -> KeyLight | None:
    """The key light of the regions ``parts`` (the first its own; ``fit``: its clear-sky fit, or None): the sun, or
    a lamp (None for a plateau wider than plateau_extent_deg), located, weighed (``weigh``) and coloured."""
    rad, frac_any, _ = maps
    mu, sigma, reported = prediction
    i = parts[0]
    h = regions.labels.shape[0]
    extent = float(regions.extent_deg()[i])
    direction = regions.centre[i]
    if len(parts) > 1:  # the sun sits at the centroid of its whole patch, fitted there again
        v = (regions.clipped_sr[parts, None] * regions.centre[parts]).sum(axis=0)
        centroid = v / np.linalg.norm(v)
        refit = _fit_at(maps, centroid)
        if refit is not None and refit.clear:
            direction, fit = centroid, refit
    learned = regions.added_energy(mu, parts)
    trees_68 = (regions.added_energy(np.maximum(mu - sigma, 0.0), parts), regions.added_energy(mu + sigma, parts))
    decided = regions.added_energy(reported, parts) if reported is not None else learned
    if is_sun:
        physical = clear_sky_energy(fit, params)
        elevation = sh.elevation_deg(direction)
        color = camera_colour(fit.sun_rgb, elevation, params)
        method, angle = f"clear-sky fit (turbidity {fit.turbidity:g})", math.radians(SUN_DIAMETER_DEG)
        # a sun the trees weigh as a key light: one only the sky admits (under key_share) keeps their weight, as a
        # cloud edge whose fit passes is no sun to give half its fit (dawn.jpg saved again: 67x the trees')
        trusted = not weak and physics_trusted(extent, elevation, params)
    else:
        if extent > params.plateau_extent_deg:
            return None
        radius = math.sqrt(regions.clipped_sr[i] / math.pi)
        physical, trusted, method = None, False, "per-source model"
        color = ring_colour(rad, frac_any, regions.labels, i, direction, radius, params.shoulder)
        # a lamp (or a veiled sun) as wide as a third of its clipped core
        angle = max(math.radians(params.lamp_min_diameter_deg), 2.0 * radius / 3.0)
    weight = weigh(physical, learned, decided, trusted=trusted, trees_68=trees_68, params=params)
    return KeyLight(np.asarray(direction, dtype=np.float64), weight.energy, np.asarray(color, dtype=np.float64),
                    float(angle), weight.energy_68, i, method, physical, fit,
                    max(params.direction_68_per_extent * math.radians(extent), math.pi / h), tuple(parts[1:]),
                    weight.cap, weak, float(learned), float(decided), bool(trusted))


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
