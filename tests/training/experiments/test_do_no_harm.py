"""training.experiments.do_no_harm: each decision rule holds only inside its block, a scene is scored under each
variant, and the summary counts harmed scenes first."""

import numpy as np
import pytest

from panolight_core import metrics
from panolight_core.camera.resample import area_downsample
from panolight_core.data import load_studio_hdri
from panolight_core.estimators import sources
from panolight_core.estimators.sources import decision, recovery
from training.experiments import do_no_harm


def test_the_rules_hold_only_inside_and_the_shipped_one_comes_back():
    shipped = (recovery.choose_shrink, recovery.shrunk, decision.harmless, decision.HARM_RANGE_Z)
    with do_no_harm.decision_rule("expected"):
        assert decision.harmless(np.full((3, 2), 9.0)).all()  # every candidate, however bad
    with do_no_harm.decision_rule("bounded:2"):
        assert decision.HARM_RANGE_Z == (-2.0, 0.0, 2.0)
    with do_no_harm.decision_rule("quantile:0.16"):
        assert recovery.shrunk(np.array([2.0]), np.array([1.0]), 0.0)[0] == pytest.approx(1.0057, abs=1e-3)
    with pytest.raises(ValueError, match="unknown decision"), do_no_harm.decision_rule("median"):
        pass
    assert (recovery.choose_shrink, recovery.shrunk, decision.harmless, decision.HARM_RANGE_Z) == shipped


def test_a_scene_is_scored_under_each_variant_and_the_summary_counts_harm_first():
    hdr = area_downsample(load_studio_hdri("forest"), 128)
    row = dict(do_no_harm.score(hdr, 0.0, sources.load_source_model(), ("shipped", "expected+sky-sun")), scene="forest")
    assert set(row["variants"]) == {"shipped", "expected+sky-sun"} and row["naive"][0] > 0
    low = dict(row, variants={v: [row["naive"][0] * 0.5, 0.0] for v in row["variants"]})
    high = dict(row, scene="other", variants={v: [row["naive"][0] * 3 + 1.0, 0.0] for v in row["variants"]})
    s = do_no_harm.summary([low, high], ["shipped"])["shipped"]
    assert list(s)[0] == "harmed" and s["harmed"] == 1 and s["harmed_scenes"] == ["other"]
    assert metrics.harmed(high["variants"]["shipped"][0], high["naive"][0])
    assert row["scale_defined"] and s["defined"]["harmed"] == 1 and s["defined"]["scenes"] == 2
    flipped = dict(high, scale_defined=False)  # a truth whose lmax-2 median is negative: reported apart
    d = do_no_harm.summary([low, flipped], ["shipped"])["shipped"]
    assert d["harmed"] == 1 and d["defined"] == {"scenes": 1, "harmed": 0, "dominant": int(low["dominant"]),
                                                 "dominant_median": 0.5 if low["dominant"] else None,
                                                 "dominant_mean": 0.5 if low["dominant"] else None}


def test_a_clipped_hdr_is_scored_against_the_file_as_it_is():
    """--clipped: the HDR clipped 2^stops over its ev-0 white, restored as panolight estimate does; harm is against
    the file's own projection, and a file that clips nothing is estimated as it is (the lights + SH fit of its
    exact pixels: within 1 % m-RMSE, never harmed)."""
    hdr = area_downsample(load_studio_hdri("city"), 128)
    row = do_no_harm.score_clipped(hdr, 4.0, ("shipped", "expected+as-before"))
    assert row["ev"] == 4.0 and set(row["variants"]) == {"shipped", "expected+as-before"}
    assert all(v[0] >= 0 for v in row["variants"].values()) and row["naive"][0] > 0
    unclipped = do_no_harm.score_clipped(hdr, 60.0, ("shipped",))
    got = unclipped["variants"]["shipped"][0]
    assert got < 0.01 and not metrics.harmed(got, unclipped["naive"][0])
