"""Recovering a panorama's clipped energy: regions, the model's prediction, the decision and the fill, in one call
(``recover``; ``assemble`` takes a prediction of any origin).

The excess (r - 1) x held goes into each region's cells by ``Regions.share``, white in the camera's balance,
so the recovered work map holds exactly r x held in the region; ``fill.fill_full_resolution`` puts the
same energy into the full-resolution clipped pixels.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from ..highlights import WORK_HEIGHT, work_maps
from .decision import choose_shrink, shrunk
from .features import region_features
from .fill import cap_log_ratios, fill_with_keys
from .regions import Regions
from .trees import SourceModel, load_source_model


@dataclass
class Recovery:
    """What ``recover`` found: the recovered work map (h, 2h, 3), the plain linearised work map, the
    all-channels clipped fraction (h, 2h), the regions and, per region, mu, sigma and the reported log ratio."""

    work: np.ndarray
    base: np.ndarray
    frac: np.ndarray
    regions: Regions
    mu: np.ndarray
    sigma: np.ndarray
    log_ratio: np.ndarray
    decision: dict | None = None
    keys: list = field(default_factory=list)  # keylight.KeyLight: the compact sources, as explicit lights
    diffuse: np.ndarray | None = None  # ``work`` without the key lights (what the SH part is fitted to)
    sun_search: dict | None = None  # keylight.sun_search_report: the search for a sun the photo does not show
    frac_any: np.ndarray | None = None  # the any-channel clipped fraction (h, 2h): with base and frac, the work maps
    decided: np.ndarray | None = None  # the reported log ratios before any key light capped them (``with_keys``)
    source: object | None = None  # restore.Source: the HDR file whose clipped plateau this restores (maps in clip
    # units: its energies times source.level are in the file's); None for a photo

    def __post_init__(self):
        if self.diffuse is None:
            self.diffuse = self.work

    @property
    def maps(self) -> tuple:
        """The work maps (rad, frac_any, frac_all) this recovery was made from (``highlights.work_maps``)."""
        return self.base, self.frac_any, self.frac

    def with_keys(self, keys: list, sun_search: dict | None = None) -> "Recovery":
        """This recovery with ``keys`` (``keylight.KeyLight``) as explicit lights: each key light's region keeps
        in its fill only what its decided energy holds beyond the light's, and a trusted sun's regions at most the
        high end of its fit's 68 % range (``cap_log_ratios``: the reported log ratios say so); ``sun_search``: the
        account of the search for a sun the photo does not show (``keylight.sun_search_report``)."""
        decided = self.log_ratio if self.decided is None else self.decided  # the keys before these do not count
        reported = cap_log_ratios(self.regions, decided, keys)
        diffuse, work = fill_with_keys(self.base, self.regions, reported, keys)
        return replace(self, work=work, diffuse=diffuse, log_ratio=reported, keys=list(keys), sun_search=sun_search,
                       decided=decided)

    def with_key_strength(self, strength: float) -> "Recovery":
        """This recovery with every key light's energy times ``strength`` (>= 0; an artist's setting: lighting.json
        gives each light's 68 % range), the maps made again as ``recover`` makes them: a region's fill keeps
        what its decided energy holds beyond its (scaled) light, so the work map gains max(decided, light) as
        before. The 68 % ranges (the belief) stay. ``strength`` 1 returns this recovery itself."""
        if strength == 1.0 or not self.keys:
            return self
        keys = [replace(k, energy=k.energy * strength) for k in self.keys]
        # strength 0 keeps each light at zero energy, as 0.001 keeps it at a thousandth: its region's fill keeps the
        # decided energy either way, and no second light is taken there (``key_exclusions``)
        diffuse, work = fill_with_keys(self.base, self.regions, self.log_ratio, keys)
        return replace(self, work=work, diffuse=diffuse, keys=keys)

    def key_points(self) -> list:
        """(unit direction (3,), RGB energy (3,)) of each key light, for the full-resolution HDRI."""
        return [(k.direction, k.energy * k.color) for k in self.keys]

    def lights(self) -> list[dict]:
        """The key lights as lighting-file light dicts, brightest first."""
        return [k.as_light() for k in sorted(self.keys, key=lambda k: -k.energy)]

    def key_exclusions(self) -> list:
        """(direction (3,), angular radius in radians) of each key light's region: the lighting model takes
        no second light there (one light per physical source)."""
        cell = math.pi / self.work.shape[0]
        sr = self.regions.clipped_sr

        def off(k):  # an HDR file's key light stands at its plateau's core (keylight.at_cores), off its centroid
            if self.source is None or k.region < 0:
                return 0.0
            return math.acos(float(np.clip(np.dot(k.direction, self.regions.centre[k.region]), -1.0, 1.0)))

        return [(k.direction, (math.sqrt(float(sr[[k.region, *k.parts]].sum()) / math.pi) + off(k) if k.region >= 0
                               else k.direction_68) + 2 * cell) for k in self.keys]

    def region_info(self) -> list[dict]:
        """Per region, for lighting.json: direction, clipped solid angle (sr), held and recovered energy
        (luminance, clip units x sr), ratio with its 68 % interval, angular radius (extent, degrees),
        colour and glare exponent."""
        r = self.regions
        extent = r.extent_deg()
        out = []
        for i in range(r.count):
            out.append({"direction": [round(float(v), 6) for v in r.centre[i]],
                        "solid_angle": float(r.clipped_sr[i]), "held_energy": float(r.held[i]),
                        "energy": float(r.held[i] * math.exp(self.log_ratio[i])),
                        "ratio": float(math.exp(self.log_ratio[i])),
                        "ratio_68": [float(math.exp(max(self.mu[i] - self.sigma[i], 0.0))),
                                     float(math.exp(self.mu[i] + self.sigma[i]))],
                        "extent_deg": float(extent[i]),
                        "color": [round(float(v), 6) for v in r.color[i]], "exponent": float(r.exponent[i])})
        return out


def recover_hdr(source, model: SourceModel | None = None) -> Recovery:
    """``recover`` of an HDR file's clipped plateau (``restore.Source``): its work maps in clip units, the regions,
    the model's decision and the fill, as of a photo whose white is the file's ceiling."""
    return replace(recover(None, model, source.work_maps(WORK_HEIGHT)), source=source)


def recover(ldr: np.ndarray, model: SourceModel | None = None, maps=None) -> Recovery:
    """Recover the clipped energy of a uint8 sRGB panorama with the learned model (default: the shipped one):
    its regions, the model's prediction (mu, sigma) and the energies ``choose_shrink`` decides (the
    expected-error optimum under the metric), filled into the work map. maps: ``work_maps(ldr)`` when the
    caller already has them (the learned estimator's input at this height), so they are made once. The key
    lights are a further step (``keylight.with_key_lights``)."""
    maps = work_maps(ldr, WORK_HEIGHT) if maps is None else maps
    regions = region_features(*maps)
    return assemble(maps, regions, *decide(maps[0], regions, model or load_source_model()))


def decide(rad: np.ndarray, regions: Regions, model: SourceModel):
    """(prediction (mu, sigma, reported), decision) of ``model`` for the ``regions`` of work map ``rad``: the
    reported log ratios those of least expected error (``choose_shrink``); decision None without regions."""
    mu, sigma, reported = model.predict(regions.features)
    if not regions.count:
        return (mu, sigma, reported), None
    c, expected = choose_shrink(rad, regions, mu, sigma)
    return (mu, sigma, shrunk(mu, sigma, c)), {"shrink": "none" if math.isinf(c) else c, "expected_error": expected}


def assemble(maps, regions: Regions, prediction, decision: dict | None = None) -> Recovery:
    """The lower-level entry point: the Recovery of work ``maps`` (rad, frac_any, frac_all), their ``regions``
    and a per-region ``prediction`` (mu, sigma, reported: natural logs of the energy ratio) of any origin, the
    reported ratios filled into the work map. ``recover`` is it with the shipped model and decision; training's
    variants (other ratio functions, region profiles, decisions, oracles) call it with their own."""
    rad, frac_any, frac_all = maps
    mu, sigma, reported = prediction
    diffuse, work = fill_with_keys(rad, regions, reported)
    return Recovery(work, rad, frac_all, regions, mu, sigma, reported, decision, [], diffuse, None, frac_any)
