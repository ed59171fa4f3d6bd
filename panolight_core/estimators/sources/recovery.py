"""Recovering a panorama's clipped energy: regions, the model's prediction, the decision and the fill, in one call.

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
from .fill import fill_with_keys
from .regions import WIDE_CONCENTRATION, Regions
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

    def __post_init__(self):
        if self.diffuse is None:
            self.diffuse = self.work

    def with_key_strength(self, strength: float) -> "Recovery":
        """This recovery with every key light's energy times ``strength`` (>= 0; an artist's setting: lighting.json
        gives each light's 68 % range), the maps made again as ``recover`` makes them: a region's fill keeps
        what its decided energy holds beyond its (scaled) light, so the work map gains max(decided, light) as
        before. The 68 % ranges (the belief) stay. ``strength`` 1 returns this recovery itself."""
        if strength == 1.0 or not self.keys:
            return self
        keys = [replace(k, energy=k.energy * strength) for k in self.keys]
        keys = [k for k in keys if k.energy > 0]  # strength 0: no light, its region's fill keeps the decided energy
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
        return [(k.direction, (math.sqrt(float(sr[[k.region, *k.parts]].sum()) / math.pi) if k.region >= 0
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


def recover(ldr: np.ndarray, model: SourceModel | None = None, log_ratio_fn=None,
            height: int = WORK_HEIGHT, decide: bool = True, tolerance: float | None = None,
            min_median_ratio: float | None = None, maps=None, key_lights: bool = False,
            wide_concentration: float = WIDE_CONCENTRATION) -> Recovery:
    """Recover the clipped energy of a uint8 sRGB panorama with the learned model (default: the shipped
    one) or ``log_ratio_fn(regions) -> (mu, sigma, reported)`` (alternatives and oracles in evaluation).

    decide: report the energies ``choose_shrink`` picks (the expected-error optimum under the metric);
    False: the model's fixed rule, log r = mu - shrink sigma^2. maps: ``work_maps(ldr, height)`` when the
    caller already has them (the learned estimator's input at this height), so they are made once.
    key_lights: make the regions that hold a compact key source explicit lights (``keylight``); each such
    region's fill keeps only what its decided energy holds beyond its light's, and a trusted sun's regions at
    most the high end of its fit's 68 % range (``keylight.cap_log_ratios``: the reported log ratios say so).
    wide_concentration: the profile exponent of wide regions' excess (``Regions.shape_exponents``; the
    cross-validation's knob)."""
    rad, frac, frac_all = work_maps(ldr, height) if maps is None else maps
    regions = region_features(rad, frac, frac_all, wide_concentration=wide_concentration)
    decision = None
    if log_ratio_fn is not None:
        mu, sigma, reported = log_ratio_fn(regions)
    else:
        mu, sigma, reported = (model or load_source_model()).predict(regions.features)
        if decide and regions.count:
            c, expected = choose_shrink(rad, regions, mu, sigma, tolerance=tolerance,
                                        min_median_ratio=min_median_ratio)
            reported = shrunk(mu, sigma, c)
            decision = {"shrink": "none" if math.isinf(c) else c, "expected_error": expected}
    keys, report = [], None
    if key_lights and log_ratio_fn is None:  # also without regions: a sun the photo does not show
        from ..keylight import cap_log_ratios, find_key_lights, sun_search_report

        fits = {}
        keys = find_key_lights(rad, frac, frac_all, regions, mu, sigma, reported, fits=fits)
        report = sun_search_report(fits, keys, regions)
        reported = cap_log_ratios(regions, reported, keys)  # a trusted sun's patch holds at most its fit's 68 % high end
    diffuse, work = fill_with_keys(rad, regions, reported, keys)
    return Recovery(work, rad, frac_all, regions, mu, sigma, reported, decision, keys, diffuse, report)


def power_law_log_ratio(regions: Regions):
    """The physical model alone as a region ratio (the learned model's yardstick): the power law's gain
    over the clipped area, no spread."""
    gain = 10.0 ** regions.feature("log_power_law_gain")
    ratio = (regions.held + (gain - 1.0) * regions.clipped_sr) / np.maximum(regions.held, 1e-30)
    lr = np.log(np.maximum(ratio, 1.0))
    return lr, np.zeros_like(lr), lr
