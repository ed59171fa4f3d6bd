"""training.experiments.key_variants: what a key light carries, in two variants."""
import numpy as np
import pytest

from panolight_core.estimators import keylight, sources
from training.experiments.key_variants import belief, one_account


def test_the_sun_takes_its_region_s_decided_energy_and_leaves_no_fill():
    """A clear sky whose trees say more than the sky fit (their prediction raised by e^2): shipped, the light
    carries its capped fit and the region keeps the rest as fill; in the experiment the light carries the decided
    energy (capped at the fit's high end for a trusted sun) and its region's fill is empty. Outside it nothing
    changes, and the shipped rule is back after the block."""
    from tests.panolight_core.estimators.test_keylight import _clear_sky_with_pole

    ldr, _ = _clear_sky_with_pole(0.0)
    rec = sources.recover(ldr)
    boosted = sources.assemble(rec.maps, rec.regions, (rec.mu + 2.0, rec.sigma, rec.log_ratio + 2.0), rec.decision)
    shipped = keylight.with_key_lights(boosted)
    with one_account():
        whole = keylight.with_key_lights(boosted)
    (a,), (b,) = shipped.keys, whole.keys
    region = np.isin(boosted.regions.labels, [a.region, *a.parts])
    # (two runs of the same estimate may differ in the last bit: numpy's SIMD sums, docs/development.md)
    assert a.trusted and a.energy < b.energy == min(b.decided, b.cap)
    assert np.abs(shipped.diffuse - shipped.base)[region].sum() > 0 and np.abs(whole.diffuse - whole.base)[region].sum() == 0
    np.testing.assert_allclose(shipped.diffuse[~region], whole.diffuse[~region], rtol=1e-12)
    assert keylight.with_key_lights(boosted).keys[0].energy == pytest.approx(a.energy, rel=1e-12)


def test_a_sure_sun_carries_its_fit_s_belief_and_others_stay():
    """belief:DEG: a trusted clear-sky sun within DEG of its place carries its fit's belief (the median of its 68 %
    range); a gate tighter than its 68 % radius leaves the shipped energy."""
    from tests.panolight_core.estimators.test_keylight import _clear_sky_with_pole

    ldr, _ = _clear_sky_with_pole(0.0)
    rec = sources.recover(ldr)
    (shipped,) = keylight.with_key_lights(rec).keys
    with belief(90.0):
        (sure,) = keylight.with_key_lights(rec).keys
    with belief(0.0):
        (kept,) = keylight.with_key_lights(rec).keys
    assert shipped.trusted and sure.energy == pytest.approx(shipped.physical, rel=1e-12)
    assert sure.energy == pytest.approx((sure.energy_68[0] * sure.energy_68[1]) ** 0.5, rel=1e-12)
    assert kept.energy == pytest.approx(shipped.energy, rel=1e-12) and abs(kept.energy / sure.energy - 1) > 1e-3
