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
