"""Synthetic panoramas and fixed ratios for the per-source energy tests."""
import math

import numpy as np

from panolight_core import sh
from panolight_core.camera import hdr_to_ldr


def sun_ldr(h=128, direction=(0.3, 0.4, 0.866), radius_deg=3.0, sky=0.05):
    """A uint8 panorama: a dim sky and one white clipped disk (the sun's clipped core)."""
    img = np.full((h, 2 * h, 3), sky, dtype=np.float64)
    d = np.asarray(direction) / np.linalg.norm(direction)
    ang = np.degrees(np.arccos(np.clip(sh.pixel_directions(h, 2 * h) @ d, -1, 1)))
    img[ang < radius_deg] = 5.0
    return hdr_to_ldr(img, scale=1.0), d


def fixed_ratio(ratio):
    """A per-region prediction function for ``sources.assemble``: every region at energy ratio ``ratio``, no spread."""
    def fn(reg):
        lr = np.full(reg.count, math.log(ratio))
        return lr, np.zeros(reg.count), lr
    return fn


def recover_fixed(ldr, ratio, wide_concentration=None):
    """``sources.assemble`` of ``ldr``'s regions with every region at ``ratio`` (``fixed_ratio``), the regions'
    wide-profile exponent ``wide_concentration`` (None: the shipped one)."""
    from panolight_core.estimators import sources

    maps = sources.work_maps(ldr)
    kw = {} if wide_concentration is None else {"wide_concentration": wide_concentration}
    regions = sources.region_features(*maps, **kw)
    return sources.assemble(maps, regions, fixed_ratio(ratio)(regions))
