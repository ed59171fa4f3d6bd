"""The clipped regions and their features: found where they are, measured by name, shaped as asked."""
import math

import numpy as np
import pytest

from panolight_core import metrics, sh
from panolight_core.estimators import sources

from .helpers import fixed_ratio, sun_ldr


def test_a_clipped_disk_is_one_region_with_its_centre():
    ldr, d = sun_ldr()
    rec = sources.recover(ldr, log_ratio_fn=fixed_ratio(1.0))
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
    a = sources.recover(ldr, log_ratio_fn=fixed_ratio(10.0))
    b = sources.recover(ldr, log_ratio_fn=fixed_ratio(10.0), wide_concentration=3.0)
    assert np.abs(a.work - b.work).max() > 0


def test_the_largest_regions_above_the_horizon_carry_what_a_clear_sky_says_of_them():
    """A clear sky's clipped sun: its region's sky features are the clear-sky fit with the sun at its centre (the
    solar disk over what the region holds, the residual, the blueness), the fit the key light then uses; a region
    below the horizon, or past the SKY_FIT_REGIONS largest, gets NO_SKY_FIT."""
    from panolight_core.estimators import keylight, sky
    from panolight_core.estimators.sources.features import NO_SKY_FIT, SKY_FEATURES, SKY_FIT_REGIONS

    from ..test_sky import _clear_sky_ldr

    ldr, sun, k, true_sun, _ = _clear_sky_ldr(h=128)
    ldr = ldr.copy()
    h = ldr.shape[0]
    ldr[int(0.8 * h):int(0.8 * h) + 4, 10:14] = 255  # a glint on the ground, below the horizon
    for j in range(SKY_FIT_REGIONS):  # small white speckles high in the sky, far from the sun: ranks after the sun's
        ldr[6, 60 + 40 * j] = 255
    rad, frac_any, frac_all = sources.work_maps(ldr)
    reg = sources.region_features(rad, frac_any, frac_all)
    assert reg.count == SKY_FIT_REGIONS + 2
    i = int(np.argmax([metrics.angle_deg(c, sun) < 15.0 for c in reg.centre]))
    assert i == 0  # the sun's patch is the largest
    fit = sky.fit_clear_sky(rad, frac_any == 0, frac_all > 0.5, reg.centre[0])
    assert reg.sky_fits[0].sun_energy == pytest.approx(fit.sun_energy, rel=1e-12)
    got = dict(zip(SKY_FEATURES, (reg.feature(n)[0] for n in SKY_FEATURES)))
    assert got["log_sky_sun_over_held"] == pytest.approx(math.log10(fit.sun_energy / reg.held[0]), rel=1e-9)
    assert got["sky_fit_rms"] == pytest.approx(fit.rms) and got["sky_fit_blueness"] == pytest.approx(fit.blueness)
    assert got["log_sky_sun_over_held"] > 0.5  # the sun outweighs its 20-degree clipped patch several times
    below = [j for j in range(reg.count) if reg.centre[j][2] < 0]
    beyond = [j for j in range(SKY_FIT_REGIONS, reg.count)]
    assert below and beyond
    for j in set(below) | set(beyond):
        assert j not in reg.sky_fits
        assert {n: reg.feature(n)[j] for n in SKY_FEATURES} == NO_SKY_FIT
    mu = np.log(np.maximum(fit.sun_energy / reg.held, 2.0))
    keys = keylight.find_key_lights(rad, frac_any, frac_all, reg, mu, np.full(reg.count, 0.3))
    assert keys and keys[0].sky is reg.sky_fits[0]  # the key light weighs the sun with that same fit
