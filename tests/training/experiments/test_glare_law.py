"""training.experiments.glare_law: the ring of a synthetic point source's glare gives back its law, and a one-sided
excess (a lit wall) is not isotropic."""
import math

import numpy as np
import pytest

from panolight_core import sh
from training.experiments import glare_law

H = glare_law.HEIGHT


def _source(c_times_e=2e-4, background=0.05, core_deg=2.0, wall=False):
    """Maps at HEIGHT rows of a point source 30 degrees up: background + c E theta^-2, white within core_deg; with
    ``wall`` a patch to one side of the ring 0.3 brighter (an excess that does not surround the source)."""
    dirs = sh.pixel_directions(H, 2 * H)
    el = math.radians(30.0)
    centre = np.array([math.cos(el), 0.0, math.sin(el)])
    theta = np.arccos(np.clip(dirs @ centre, -1.0, 1.0))
    lum = background + c_times_e / np.maximum(theta, 1e-4) ** 2
    if wall:
        lum = lum + 0.3 * ((dirs[..., 1] > 0.05) & (theta < math.radians(8.0)))
    white = theta < math.radians(core_deg)
    lum[white] = 1.0
    return lum, ~white, white, dirs, centre


def test_a_point_source_gives_back_its_glare_law():
    c_times_e, core = 2e-4, 2.0
    lum, clear, white, dirs, centre = _source(c_times_e, core_deg=core)
    found = glare_law.ring(lum, clear, white, dirs, centre, core)
    assert found is not None
    assert found["radius_deg"] == pytest.approx(core, abs=0.4)
    assert found["background"] == pytest.approx(0.05 + c_times_e / math.radians(core + 14.0) ** 2, rel=0.1)
    # excess x theta^2 is c E wherever the ring is read (less the background's own slope of the glare)
    assert np.allclose(found["log_c"], math.log(c_times_e), atol=0.25)
    assert found["slope"] == pytest.approx(-2.0, abs=0.35)
    assert glare_law.isotropy(found["sectors"]) < 0.1


def test_an_excess_to_one_side_is_not_isotropic():
    lum, clear, white, dirs, centre = _source(wall=True)
    found = glare_law.ring(lum, clear, white, dirs, centre, 2.0)
    assert found is not None
    assert glare_law.isotropy(found["sectors"]) > glare_law.ISOTROPY


def test_isotropy_needs_five_sectors_and_marks_a_sector_at_the_background():
    assert math.isnan(glare_law.isotropy([1.0, 1.0, float("nan"), float("nan"), float("nan"), float("nan")]))
    assert glare_law.isotropy([1.0, 1.0, 1.0, 1.0, 0.0]) == math.inf


def test_the_summary_fits_the_constant_over_the_sources():
    rows = [{"share": 0.5, "true": 6.0, "mu": 3.0, "held": 1.0, "log_c": [-1.0, -1.0], "slope": -2.0,
             "larger_near": False, "extent_deg": 2.0, "sectors": [1.0] * 8, "key": "per-source model"},
            {"share": 0.01, "true": 0.5, "mu": 1.0, "held": 1.0, "log_c": [-2.0, -2.0], "slope": -2.0,
             "larger_near": False, "extent_deg": 2.0, "sectors": [1.0] * 8, "key": None}]
    s = glare_law.summarise(rows)
    assert s["log_c"] == pytest.approx(-7.0)  # law -1 against a true 6
    assert s["glare_median_abs_error"] == pytest.approx(0.0)
    assert s["trees_median_abs_error"] == pytest.approx(3.0)
    assert s["small_median_error"] == pytest.approx(5.0 - 0.5)  # -2 - (-7) = 5 against a true 0.5
    assert s["missed_by_trees"] == 1 and s["missed_passing_isotropic_gate"] == 1
    assert s["per_source_key_lights"]["sources"] == 1
