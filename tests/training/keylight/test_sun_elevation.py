"""training.keylight.sun_elevation: which scenes it reads, and a model sky whose sun it must weigh exactly."""
import math

import numpy as np
import pytest

from panolight_core import sh
from panolight_core.estimators import keylight
from training.keylight import sun_elevation

from .test_sun_colour import model_sky_with_sun


def test_manifest_suns_are_the_unclipped_ones(tmp_path):
    (tmp_path / "MANIFEST.csv").write_text(
        "file,size,kind,sun,max_over_median,license,source\n"
        "a.hdr,1x1,outdoor,yes,1,x,y\n"
        "b.hdr,1x1,outdoor,yes (low),1,x,y\n"
        "c.exr,1x1,outdoor,yes (core overflowed half floats: energy a lower bound),1,x,y\n"
        "d.hdr,1x1,outdoor,clipped (max 37),1,x,y\n"
        "e.hdr,1x1,indoor,no (lamps),1,x,y\n", encoding="utf-8")
    assert sun_elevation.manifest_suns(tmp_path) == [tmp_path / "a.hdr", tmp_path / "b.hdr"]


def test_the_model_sky_s_own_sun_is_weighed_at_one_over_the_correction():
    """The tabulated clear sky with its solar disk painted in: the fit at the true sun weighs that disk, so the
    truth (the disk and the aureole within 5 degrees) over the corrected fit is close to 1 / SKY_CORRECTION."""
    elev = 35.0
    hdr, _, _ = model_sky_with_sun(elev)
    rows = sun_elevation.score_scene(hdr, [0.0])
    (row,) = rows
    assert row["fit"] and row["clear"] and row["elevation_deg"] == pytest.approx(elev, abs=0.5)
    assert row["true_over_physical"] * keylight.PARAMS.sky_correction == pytest.approx(1.0, rel=0.1)
    bands = sun_elevation.summary([dict(row, scene="x")])
    assert [b["fits"] for b in bands] == [0, 0, 1, 0]
    assert bands[2]["median_true_over_physical"] == pytest.approx(row["true_over_physical"])
    assert sun_elevation.table([dict(row, scene="x")])[2].startswith("| x | 35.")


def test_a_sun_below_the_horizon_has_no_row():
    h = 64
    d = sh.pixel_directions(h, 2 * h)
    hdr = np.full((h, 2 * h, 3), 0.2)
    hdr[(d @ np.array([0.0, 0.8, -0.6])) > math.cos(math.radians(2.0))] = 1e4
    assert sun_elevation.score_scene(hdr, [0.0]) == []
