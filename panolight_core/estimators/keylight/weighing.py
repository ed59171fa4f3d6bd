"""Weighing a key light: the one home of what every kind of sun and lamp weighs (``weigh``: its energy, its 68 %
range and its cap), of the clear-sky fit's energy in camera units (``clear_sky_energy``), and of how a light looks
(``camera_colour``, ``ring_colour``).

Energies are luminance x sr in camera units (clip level 1); colours have luminance 1 (Rec.709 weights); work maps
are (h, 2h, 3) linear, Blender world frame (CONVENTIONS.md).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ... import sh
from ...camera.color import LUMINANCE_WEIGHTS
from .params import PARAMS, KeyLightParams


def clear_sky_energy(fit, params: KeyLightParams = PARAMS) -> float:
    """A clear-sky fit's solar disk in camera units (luminance x sr): the model's (``sky.SkyFit.sun_energy``) times
    ``params.sky_correction``, the real suns' median true / model."""
    return params.sky_correction * fit.sun_energy


@dataclass(frozen=True)
class Weight:
    """What ``weigh`` gives a key light: its energy, the 68 % range of its source's true energy (the belief,
    which ``energy`` may lie below), and the most its regions may hold beyond their clip level (None: no cap)."""

    energy: float
    energy_68: tuple
    cap: float | None = None


def weigh(physical: float | None, learned: float = 0.0, decided: float = 0.0, *, trusted: bool = False,
          trees_68: tuple | None = None, given: float | None = None, params: KeyLightParams = PARAMS) -> Weight:
    """The one function through which every sun and lamp gets its energy, 68 % range and cap.

    physical: the clear-sky fit's energy (``clear_sky_energy``; None: no clear sky weighs it); learned, decided: the
    per-source model's mean and the decided fill's energy for its regions; trusted: whether the fit bounds it
    (``physics_trusted``); trees_68: the per-source model's 68 % range for its regions (a clipped region's light);
    given: an energy already set by its evidence (a sun weighed by the fit alone, or by the photo's lit / shadow
    contrast). The energy is ``given``, else ``key_energy``'s, but for a trusted sun at most the decided fill's where
    the two kinds of evidence disagree (``when_disagreeing``): the trees' 68 % range wholly under the fit's (a hazy
    patch whose clear-sky fit passes: out of fold, evening_meadow's sun at ev -2 went from 8.7x naive's m-RMSE to
    0.26x, and no other scene moved; docs/studies/do_no_harm.md). The range: about a region's light, the fit's
    (physical / sky_spread .. physical x sky_spread) where a fit weighs it, averaged in log with the trees' under
    ``params.belief``, else the trees'; about any other light, its energy's, sky_spread either way. The cap: a
    trusted fit's high end."""
    energy = key_energy(physical, learned, decided, trusted, params) if given is None else given
    spread = params.sky_spread
    if given is None and physical is not None and trees_68 is not None:
        energy = when_disagreeing(energy, physical, decided, trees_68, trusted, params)
    if trees_68 is None:
        lo, hi = energy / spread, energy * spread
    elif physical is None:
        lo, hi = trees_68
    else:
        lo, hi = physical / spread, physical * spread
        if params.belief:  # the belief's range: the trees' and the fit's, averaged in log
            lo, hi = math.sqrt(trees_68[0] * lo), math.sqrt(trees_68[1] * hi)
    return Weight(float(energy), (float(lo), float(hi)), physical * spread if trusted else None)


def when_disagreeing(energy: float, physical: float, decided: float, trees_68: tuple, trusted: bool,
                     params: KeyLightParams = PARAMS) -> float:
    """A trusted clear-sky sun's energy (``physics_trusted``: its fit's floor) where its two kinds of evidence
    disagree: the trees' 68 % range wholly under the fit's (its high end under physical / sky_spread) takes at most
    the decided fill's energy (the cautious one); ``energy`` otherwise. An untrusted sun is already capped at the
    trees' mean (``key_energy``); out of fold the rule for every clear-sky sun moved the same one scene, and on the
    real photos it weakened three low suns already kept below their evidence (docs/studies/do_no_harm.md)."""
    return min(energy, decided) if trusted and trees_68[1] < physical / params.sky_spread else energy


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


def camera_colour(rgb, elevation_deg: float, params: KeyLightParams = PARAMS) -> np.ndarray:
    """(3,) a clear-sky model's sun colour (linear sRGB referred to D65, any scale) for a sun ``elevation_deg`` up as a
    camera of white point ``params.camera_white`` shows it: divided by white^t, luminance 1, t the share of
    ``params.white_ramp_deg`` the elevation has reached (0 below it, 1 above). The model's noon sun, (1.15, 0.98,
    0.77), comes out about white, as real photos show it; a sun 10 degrees up or lower keeps the model's colour."""
    lo, hi = params.white_ramp_deg
    t = min(max((float(elevation_deg) - lo) / (hi - lo), 0.0), 1.0)
    c = np.asarray(rgb, dtype=np.float64) / np.asarray(params.camera_white, dtype=np.float64) ** t
    return c / float(c @ LUMINANCE_WEIGHTS)


def ring_colour(rad, frac_any, labels, region, direction, radius, shoulder: float) -> np.ndarray:
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
