"""Recovering a panorama's clipped energy: exact bookkeeping, the ratio's floor, stability at the extremes."""
import math

import numpy as np
import pytest

from panolight_core import sh
from panolight_core.camera.color import LUMINANCE_WEIGHTS
from panolight_core.estimators import estimate, sources

from .helpers import recover_fixed, sun_ldr


def test_energy_bookkeeping_exact():
    ldr, _ = sun_ldr()
    rec = recover_fixed(ldr, 25.0)
    h, w = rec.frac.shape
    omega = sh.pixel_solid_angles(h, w)
    inside = rec.regions.labels == 0
    lum_work = rec.work @ LUMINANCE_WEIGHTS
    assert float((lum_work * omega)[inside].sum()) == pytest.approx(25.0 * rec.regions.held[0], rel=1e-12)
    np.testing.assert_array_equal(rec.work[~inside], rec.base[~inside])  # nothing moves outside the region
    info = rec.region_info()[0]
    assert info["energy"] == pytest.approx(25.0 * info["held_energy"]) and info["ratio"] == pytest.approx(25.0)


def test_ratio_never_below_one_and_partial_channel_clipping_is_no_region():
    img = np.zeros((64, 128, 3), np.uint8)
    img[10:20, 10:20] = (40, 80, 255)  # a blue sky clipped in blue only: no energy is known to be missing
    rec = recover_fixed(img, 0.5)
    assert rec.regions.count == 0
    ldr, _ = sun_ldr(64)
    model = sources.load_source_model()
    mu, sigma, reported = model.predict(sources.recover(ldr, model).regions.features)
    assert np.all(reported >= 0) and np.all(sigma > 0) and np.all(reported <= np.maximum(mu, 0) + 1e-12)


@pytest.mark.parametrize("shape,value", [((64, 128), 0), ((64, 128), 255), ((2, 4), 255), ((4, 8), 0),
                                         ((1, 2), 128)])
def test_stable_on_black_fully_clipped_and_tiny(shape, value):
    px = np.full(shape + (3,), value, np.uint8)
    est = estimate(px, 2, "sources")
    assert np.all(np.isfinite(est.coeffs)) and np.all(np.isfinite(est.radiance))
    if value == 255:  # everything clipped: one region, never less than the clip level
        assert est.coeffs[0, 0] >= math.sqrt(4 * math.pi) * 0.99


def test_huge_input_costs_its_work_map():
    ldr, d = sun_ldr(128)
    big = np.repeat(np.repeat(ldr, 16, axis=0), 16, axis=1)  # 4096 x 2048
    a, b = estimate(ldr, 2, "sources"), estimate(big, 2, "sources")
    np.testing.assert_allclose(a.coeffs, b.coeffs, rtol=1e-6, atol=1e-9)
