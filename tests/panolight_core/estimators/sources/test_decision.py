"""The decision: its errors are the metric's, and a certain prediction is reported as it is."""
import math

import numpy as np
import pytest

from panolight_core import sh
from panolight_core.estimators import sources

from .helpers import sun_ldr


def test_decision_errors_are_the_metric(rng):
    from panolight_core.metrics import _relative_weighted_rmse

    q = rng.normal(size=(3, 9, 3)) + np.array([3.0, 0, 0, 0, 0, 0, 0, 0, 0])[:, None]
    g = rng.normal(size=(2, 9, 3)) + np.array([3.0, 0, 0, 0, 0, 0, 0, 0, 0])[:, None]
    q[2] *= -1  # a map with a negative median: scale 1, as EVALUATION.md says
    h, w = 16, 32
    grid = sh.basis(sh.pixel_directions(h, w).reshape(-1, 3), 2)
    wts = sh.pixel_solid_angles(h, w).ravel() / (4 * math.pi)
    got = sources._weighted_errors(q, g, grid, wts)
    for c in range(3):
        for s in range(2):
            ref = _relative_weighted_rmse(sh.reconstruct(g[s], h, w), sh.reconstruct(q[c], h, w))
            assert got[c, s] == pytest.approx(ref, rel=1e-9)


def test_decision_without_uncertainty_reports_the_mean():
    ldr, _ = sun_ldr(64)
    rad, fa, fb = sources.work_maps(ldr)
    reg = sources.region_features(rad, fa, fb)
    mu = np.full(reg.count, math.log(40.0))
    c, expected = sources.choose_shrink(rad, reg, mu, np.full(reg.count, 1e-9))
    assert math.isfinite(c) and expected["0"] == pytest.approx(0.0, abs=1e-6)  # known truth: mu - c sigma^2 = mu
    assert expected["none"] > 0.1 and expected["1"] == pytest.approx(0.0, abs=1e-6)


def test_a_choice_that_would_harm_the_low_end_of_the_range_gives_way_to_a_harmless_one(monkeypatch):
    """A wide clipped patch in a bright sky, predicted unsure (log ratio 2.5 +- 1.5, as the trees predict clipped
    clouds): the least expected error alone reports the whole mean, which harms a truth at the range's low end
    (EVALUATION.md's harm against the plain map); the shipped decision takes a more cautious choice that harms no
    truth of the range."""
    from panolight_core.estimators.sources import decision
    from panolight_core.metrics import harmed

    ldr, _ = sun_ldr(64, radius_deg=20.0, sky=0.2)
    rad, fa, fb = sources.work_maps(ldr)
    reg = sources.region_features(rad, fa, fb)
    mu, sigma = np.full(reg.count, 2.5), np.full(reg.count, 1.5)
    guarded, _ = decision.choose_shrink(rad, reg, mu, sigma)
    monkeypatch.setattr(decision, "harmless", lambda m_rmse: np.ones(len(m_rmse), bool))
    alone, _ = decision.choose_shrink(rad, reg, mu, sigma)
    assert guarded > alone
    low = np.maximum(mu - sigma, 0.0)[None]

    def m_rmse(c):
        cand = np.stack([decision.shrunk(mu, sigma, c), np.zeros_like(mu)])  # the choice and the plain map
        return decision.decision_errors(rad, reg, cand, low)[0][0][:, 0]

    assert harmed(*m_rmse(alone))
    for z in (-1.0, 0.0, 1.0):
        truth = np.maximum(mu + z * sigma, 0.0)[None]
        cand = np.stack([decision.shrunk(mu, sigma, guarded), np.zeros_like(mu)])
        assert not harmed(*decision.decision_errors(rad, reg, cand, truth)[0][0][:, 0])
