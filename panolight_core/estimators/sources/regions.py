"""The clipped regions of an LDR panorama's work map: where they are, what they hold, how their excess spreads.

Work maps: radiance (h, 2h, 3) linear in clip units (1 = white), Blender world frame (CONVENTIONS.md).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ... import sh
from ..highlights import CORE_RADIUS, label_blobs, region_cells, region_sums

MAX_REGIONS = 48  # regions modelled, largest clipped area first; smaller speckles keep the clip level
SHAPE_MAX_EXTENT_DEG = 10.0  # regions up to this radius are shaped by their glare's power law
WIDE_CONCENTRATION = 0.0  # profile exponent of wider regions (0: an even fill)


@dataclass
class Regions:
    """Clipped regions of a work map: labels (h, w) int (-1 outside), and per region (n,) arrays:
    clipped solid angle (sr), held luminance energy (clip units x sr, over the region's cells), unit
    centre direction (n, 3), excess colour (n, 3, luminance 1), glare exponent p, features (n, F) in the
    order of ``names`` (read one with ``feature``); share (h, w): each cell's share of its
    region's excess energy: its clipped solid angle weighted by the region's profile (``shape_exponents``).

    The excess colour is white in the camera's balance, as the clipped pixels are: given each region's
    true energy, white scores m-RMSE 0.35 mean / 0.30 median on the 50 real HDRs at ev 0, the glare
    ring's colour 0.41 / 0.33 (a sun's ring is blue sky)."""

    labels: np.ndarray
    clipped_sr: np.ndarray
    held: np.ndarray
    centre: np.ndarray
    color: np.ndarray
    exponent: np.ndarray
    features: np.ndarray
    share: np.ndarray
    names: tuple = ()  # the features' names, in their columns' order (``features.FEATURES``)
    wide_concentration: float = WIDE_CONCENTRATION  # the profile exponent of wide regions (``shape_exponents``)

    @property
    def count(self) -> int:
        return int(self.held.size)

    def feature(self, name: str) -> np.ndarray:
        """(n,) the named feature (one of ``names``) of every region."""
        return self.features[:, self.names.index(name)]

    def added_energy(self, log_ratio: np.ndarray, which) -> float:
        """The luminance energy (clip units x sr) that log ratios ``log_ratio`` (n,) add to the regions ``which``
        (indices) beyond what their cells hold: the sum of (r - 1) x held."""
        which = list(which)
        return float(((np.exp(np.asarray(log_ratio, dtype=np.float64)[which]) - 1.0) * self.held[which]).sum())

    def extent_deg(self) -> np.ndarray:
        """(n,) each region's angular radius around its centre, degrees."""
        return 10.0 ** self.feature("log_extent_deg")

    def shape_exponents(self) -> np.ndarray:
        """(n,) exponent q of the profile max(t, t_core)^-q around its centre that each region's excess
        follows (in the work map and in ``fill_full_resolution``): its glare's p for a compact region
        (extent <= SHAPE_MAX_EXTENT_DEG, a sun or lamp), ``wide_concentration`` for a wide one."""
        return np.where(self.extent_deg() <= SHAPE_MAX_EXTENT_DEG, self.exponent, self.wide_concentration)


def label_regions(frac_all: np.ndarray, max_regions: int = MAX_REGIONS):
    """Connected sets of work-map cells (seam- and pole-aware) holding all-channel clipped pixels, the
    ``max_regions`` largest by clipped solid angle kept, numbered largest first.

    frac_all (h, w) -> (labels (h, w) int, -1 outside; clipped solid angle (n,) sr; total count found)."""
    h, w = frac_all.shape
    labels, count = label_blobs(frac_all > 0)
    if count == 0:
        return labels, np.zeros(0), 0
    m = labels >= 0
    clipped_sr = region_sums(labels, count, sh.pixel_solid_angles(h, w) * frac_all)[0]
    keep = np.argsort(-clipped_sr)[:max_regions]
    remap = np.full(count, -1)
    remap[keep] = np.arange(keep.size)
    return np.where(m, remap[np.maximum(labels, 0)], -1), clipped_sr[keep], count


def profile_shares(regions: Regions, frac_all: np.ndarray) -> np.ndarray:
    """(h, w) each cell's share of its region's excess: clipped solid angle x max(t, t_floor)^-q, t its
    angle to the region's centre, q the region's ``shape_exponents``, normalised to 1 per region."""
    h, w = regions.labels.shape
    share = np.zeros((h, w))
    if regions.count == 0:
        return share
    q = regions.shape_exponents()
    t_floor = max(CORE_RADIUS, math.radians(0.5 * 180.0 / h))
    dirs = sh.pixel_directions(h, w).reshape(-1, 3)
    weight = (sh.pixel_solid_angles(h, w) * frac_all).ravel()
    flat = share.ravel()
    for i, cells in enumerate(region_cells(regions.labels, regions.count)):
        ang = np.arccos(np.clip(dirs[cells] @ regions.centre[i], -1.0, 1.0))
        wt = weight[cells] * np.maximum(ang, t_floor) ** (-q[i])
        flat[cells] = wt / max(float(wt.sum()), 1e-300)
    return share
