"""training.keylight.rules: each rule's energies, and one scored scene whose numbers can be checked."""
import math

import numpy as np
import pytest

from panolight_core import sh
from panolight_core.estimators import keylight, sources
from training.keylight import rules as keylight_rules


def test_rules_choose_among_the_candidates():
    # a sun on a wide patch (its centroid is degrees off the sun: no floor), a lamp, and a compact high sun
    def key(physical, learned, extent_deg, elevation_deg=40.0):
        return {"physical": physical, "learned": learned, "decided": 1.0,
                "trusted": physical is not None and keylight.physics_trusted(extent_deg, elevation_deg)}

    sun, lamp, high = key(8.0, 3.0, 40.0), key(None, 3.0, 5.0), key(8.0, 2.0, 10.0)
    got = {rule: keylight_rules._energies(rule, [sun, lamp, high]) for rule in keylight_rules.RULES}
    assert got["sources"] == [0.0, 0.0, 0.0]
    assert got["decided"] == [1.0, 1.0, 1.0]
    assert got["capped"] == [3.0, 3.0, 2.0]  # the sun's fit capped at the model's mean; the lamp at its mean
    assert got["physical"] == [8.0, 3.0, 8.0]
    # capped for the sun, decided for the lamp; the compact high sun not below its fit's 68 % low end
    assert got["hybrid"] == [3.0, 1.0, 8.0 / keylight.PARAMS.sky_spread]
    low = key(8.0, 2.0, 10.0, keylight.PARAMS.floor_min_elevation_deg - 1.0)  # a low sun's haze: no floor
    assert keylight_rules._energies("hybrid", [low]) == [2.0]
    strong = dict(high, learned=7.0)  # the floor only lifts: above it the capped energy stays
    assert keylight_rules._energies("hybrid", [strong]) == [7.0]


def test_physics_is_trusted_on_a_compact_high_sun_only():
    trusted = keylight.physics_trusted
    assert trusted(keylight.PARAMS.floor_max_extent_deg, keylight.PARAMS.floor_min_elevation_deg)
    assert not trusted(keylight.PARAMS.floor_max_extent_deg + 0.1, 45.0)
    assert not trusted(5.0, keylight.PARAMS.floor_min_elevation_deg - 0.1)
    assert not trusted(5.0, 45.0, keylight_rules.floor_params(keylight_rules.NO_FLOOR))
    assert trusted(100.0, 0.0, keylight_rules.floor_params((180.0, 0.0)))


def test_floor_option_parses_or_fails_clearly():
    import argparse

    assert keylight_rules.parse_floor("30:15") == (30.0, 15.0)
    assert keylight_rules.parse_floor("none") == keylight_rules.NO_FLOOR
    assert keylight_rules.floor_label((30.0, 15.0)) == "30/15" and keylight_rules.floor_label(keylight_rules.NO_FLOOR) == "none"
    for bad in ("30", "a:b", "1:2:3"):
        with pytest.raises(argparse.ArgumentTypeError, match="EXTENT:ELEVATION"):
            keylight_rules.parse_floor(bad)


def test_the_floor_chosen_by_cv_scores_each_scene_with_the_other_folds_choice():
    # 10 scenes; the floor "a" is better on every scene but one, so every fold that trains on it picks "a"
    rows = []
    for i in range(10):
        better = i != 3
        rows.append({"scene": f"s{i}", "ev": 0.0, "floor": {"none": [1.0, 1.0], "a": [0.5 if better else 4.0, 1.0]}})
    got = keylight_rules.floor_cv(rows, ["none", "a"])
    assert len(got["floors"]) == 5 and set(got["floors"]) <= {"none", "a"}
    assert all(got["scores"][(r["scene"], 0.0)] in (r["floor"]["none"], r["floor"]["a"]) for r in rows)
    # s3's loss (log 4) never outweighs the other training scenes' gains (at least 7 x log 2)
    assert got["floors"] == ["a"] * 5
    # a tie goes to no floor
    tie = [{"scene": f"s{i}", "ev": 0.0, "floor": {"none": [1.0, 1.0], "a": [1.0, 1.0]}} for i in range(10)]
    assert keylight_rules.floor_cv(tie, ["a", "none"])["floors"] == ["none"] * 5


def test_a_scored_sunny_scene():
    h = 128
    d = sh.pixel_directions(h, 2 * h)
    sun = np.array([0.4, 0.3, 0.866])
    hdr = np.full((h, 2 * h, 3), 0.3)
    hdr[d[..., 2] < 0] = 0.1
    core = d @ sun > math.cos(math.radians(3.0))
    hdr[core] = 2000.0  # a dominant compact source
    row = keylight_rules.score_scene(hdr, 0.0, sources.load_source_model())
    assert row["dominant"] and row["keys"] and set(row["rules"]) == set(keylight_rules.RULES)
    for got in row["rules"].values():
        assert len(got) == 3 and all(np.isfinite(got)) and got[0] >= 0 and got[2] > 0
    # a clipped compact source: the baseline's cone holds only the clip level and the decided fill, the
    # key lights put more there
    assert row["rules"]["capped"][2] > row["rules"]["sources"][2]
    s = keylight_rules.summary([dict(row, scene="x")], lambda r: r["rules"]["hybrid"])
    assert s["scenes"] == 1 and s["dominant"] == 1 and s["within"] >= 1.0
    assert s["m_rmse_median"] == pytest.approx(row["rules"]["hybrid"][0] / row["naive"][0])


def test_fold_model_patterns_name_every_fold_or_fail_clearly(tmp_path):
    from training.common.study import fold_model_paths

    for k in (1, 2, 3):
        (tmp_path / f"m_{k}.safetensors").write_bytes(b"")
    assert fold_model_paths(str(tmp_path / "m_{k}.safetensors"), 3) == {k: tmp_path / f"m_{k}.safetensors" for k in (1, 2, 3)}
    with pytest.raises(SystemExit, match="m_4.safetensors"):
        fold_model_paths(str(tmp_path / "m_{k}.safetensors"), 4)
    with pytest.raises(SystemExit, match="needs"):
        fold_model_paths(str(tmp_path / "m.safetensors"))


def test_curve_option_names_a_camera_curve_or_fails_clearly():
    import argparse

    from training.common.study import SRGB, parse_curve

    assert parse_curve("srgb") == SRGB
    assert parse_curve("contrast:1.6") == ("contrast", 1.6)
    assert parse_curve("gamma") == ("gamma", None)  # the curve's default parameter
    for bad, why in [("log", "unknown tone curve 'log'"), ("gamma:x", "must be a number"),
                     ("srgb:2", "takes no parameter"), ("shoulder:-1", "must be positive")]:
        with pytest.raises(argparse.ArgumentTypeError, match=why):
            parse_curve(bad)


def test_a_scene_through_another_curve_is_scored_in_the_pictures_units():
    """Through a tone curve the picture's linear units are not k x the HDR's, so the cone's truth is scaled by
    the medians (EVALUATION.md's r). A contrast curve of slope 1 is the sRGB camera: the same lights, and the
    same cone ratio to within the 8-bit median's rounding."""
    h = 128
    d = sh.pixel_directions(h, 2 * h)
    sun = np.array([0.4, 0.3, 0.866])
    hdr = np.full((h, 2 * h, 3), 0.3)
    hdr[d[..., 2] < -0.3] = 0.1  # the sky and a band of ground alike: the median lies on one plateau
    hdr[d @ sun > math.cos(math.radians(3.0))] = 2000.0
    model = sources.load_source_model()
    plain = keylight_rules.score_scene(hdr, 0.0, model)
    flat = keylight_rules.score_scene(hdr, 0.0, model, curve=("contrast", 1.0))
    assert [k["method"] for k in flat["keys"]] == [k["method"] for k in plain["keys"]]
    assert flat["rules"]["hybrid"][2] == pytest.approx(plain["rules"]["hybrid"][2], rel=0.02)
    steep = keylight_rules.score_scene(hdr, 0.0, model, curve=("contrast", 1.6))
    assert all(np.isfinite(v).all() for v in steep["rules"].values())


def test_the_shipped_rule_is_the_cores_key_energy():
    for physical in (None, 8.0, 0.5):
        for trusted in (False, True):
            if physical is None and trusted:
                continue
            assert keylight_rules.rule_energy("hybrid", physical, 3.0, 1.0, trusted) == \
                keylight.key_energy(physical, 3.0, 1.0, trusted)


def test_energy_rules_give_a_lamp_the_decided_energy_and_name_bad_rules():
    from panolight_core.camera import hdr_to_ldr
    from tests.panolight_core.estimators.test_keylight import _lamps

    ldr = hdr_to_ldr(_lamps([(0.3, -0.2, -0.2)]), 0.0)  # below the horizon: no clear-sky fit, a lamp
    maps = sources.work_maps(ldr)
    reg = sources.region_features(*maps)
    mu, sigma, _ = sources.load_source_model().predict(reg.features)
    reported = np.maximum(mu - 1.0 * sigma ** 2, 0.0)  # a shrunk decision, below the model's mean
    held = reg.held

    def energies(rule):
        return {k.region: k.energy for k in keylight_rules.find_under(rule, maps, reg, (mu, sigma, reported))}

    hybrid, decided, capped = energies("hybrid"), energies("decided"), energies("capped")
    shipped = keylight.find_key_lights(maps, reg, (mu, sigma, reported))
    assert hybrid == {k.region: k.energy for k in shipped} and all(k.method == "per-source model" for k in shipped)
    for i, e in hybrid.items():  # a lamp (no clear-sky fit): the decision's energy, not the model's mean
        assert e == pytest.approx((math.exp(reported[i]) - 1.0) * held[i]) == pytest.approx(decided[i])
        assert capped[i] == pytest.approx((math.exp(mu[i]) - 1.0) * held[i]) and capped[i] > e
    with pytest.raises(ValueError, match="unknown key-light energy rule 'loud'.*hybrid"):
        keylight_rules.find_under("loud", maps, reg, (mu, sigma, reported))


def test_the_sky_rule_gives_a_clear_sky_sun_its_whole_fitted_energy():
    """The study's "sky" rule (not shipped): the fit's energy uncapped; "hybrid" caps it."""
    from panolight_core import metrics
    from tests.panolight_core.estimators.test_keylight import _clear_sky_with_pole

    ldr, s = _clear_sky_with_pole(pole_deg=0.0)
    maps = sources.work_maps(ldr)
    reg = sources.region_features(*maps)
    prediction = sources.load_source_model().predict(reg.features)
    (a,) = keylight.find_key_lights(maps, reg, prediction)
    (b,) = keylight_rules.find_under("sky", maps, reg, prediction)
    assert a.method.startswith("clear-sky fit") and metrics.angle_deg(b.direction, s) < 1.5
    assert b.energy == pytest.approx(b.physical) and b.energy > a.energy  # the cap bites here
