"""The clipped regions and their features: found where they are, measured by name, shaped as asked."""
import math

import numpy as np
import pytest

from panolight_core import metrics, sh
from panolight_core.estimators import sources

from .helpers import recover_fixed, sun_ldr


def test_a_clipped_disk_is_one_region_with_its_centre():
    ldr, d = sun_ldr()
    rec = recover_fixed(ldr, 1.0)
    assert rec.regions.count == 1
    assert metrics.angle_deg(rec.regions.centre[0], d) < 1.0
    assert rec.regions.clipped_sr[0] == pytest.approx(2 * math.pi * (1 - math.cos(math.radians(3))), rel=0.15)
    assert np.all(np.isfinite(rec.regions.features))


def test_features_are_read_by_name_and_mean_what_they_say():
    ldr, d = sun_ldr(radius_deg=4.0)
    reg = sources.region_features(*sources.work_maps(ldr))
    assert reg.names == sources.FEATURES and reg.features.shape == (1, len(sources.FEATURES))
    assert reg.feature("elevation")[0] == pytest.approx(reg.centre[0, 2])
    assert reg.feature("log_clipped_sr")[0] == pytest.approx(math.log10(reg.clipped_sr[0]))
    assert reg.extent_deg()[0] == pytest.approx(4.0, abs=1.5)  # the disk's radius, to a work-map cell
    assert reg.feature("share_of_clipped")[0] == pytest.approx(1.0) and reg.feature("rank")[0] == 0
    with pytest.raises(ValueError):
        reg.feature("no such feature")


def test_wide_regions_follow_the_concentration_they_are_given():
    ldr, d = sun_ldr(radius_deg=25.0)  # wider than SHAPE_MAX_EXTENT_DEG: shaped by wide_concentration
    maps = sources.work_maps(ldr)
    even = sources.region_features(*maps)
    peaked = sources.region_features(*maps, wide_concentration=3.0)
    assert even.shape_exponents()[0] == sources.WIDE_CONCENTRATION == 0.0 and peaked.shape_exponents()[0] == 3.0
    cells = even.labels == 0
    for reg in (even, peaked):
        assert reg.share[cells].sum() == pytest.approx(1.0) and np.all(reg.share[~cells] == 0)
    dirs = sh.pixel_directions(*even.labels.shape)[cells]
    near = dirs @ d > np.cos(np.radians(8.0))  # the inner cells take a larger share when the profile peaks
    assert peaked.share[cells][near].sum() > 2.0 * even.share[cells][near].sum()
    # the parameter reaches the recovered map through ``recover``
    a = recover_fixed(ldr, 10.0)
    b = recover_fixed(ldr, 10.0, wide_concentration=3.0)
    assert np.abs(a.work - b.work).max() > 0
