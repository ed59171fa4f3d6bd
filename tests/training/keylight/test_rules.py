"""training.keylight.rules: each rule's energies, and one scored scene whose numbers can be checked."""
import math

import numpy as np
import pytest

from panolight_core import sh
from panolight_core.estimators import sources
from training.keylight import rules as keylight_rules


def test_rules_choose_among_the_candidates():
    sun = {"physical": 8.0, "learned": 3.0, "decided": 1.0}
    lamp = {"physical": None, "learned": 3.0, "decided": 1.0}
    got = {rule: keylight_rules._energies(rule, [sun, lamp]) for rule in keylight_rules.RULES}
    assert got["sources"] == [0.0, 0.0]
    assert got["decided"] == [1.0, 1.0]
    assert got["capped"] == [3.0, 3.0]  # the sun's fit capped at the model's mean; the lamp at its mean
    assert got["physical"] == [8.0, 3.0]
    assert got["hybrid"] == [3.0, 1.0]  # capped for the sun, decided for the lamp


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
    for rule, got in row["rules"].items():
        assert len(got) == 3 and all(np.isfinite(got)) and got[0] >= 0 and got[2] > 0
    # a clipped compact source: the baseline's cone holds only the clip level and the decided fill, the
    # key lights put more there
    assert row["rules"]["capped"][2] > row["rules"]["sources"][2]
    s = keylight_rules.summary([dict(row, scene="x")], lambda r: r["rules"]["hybrid"])
    assert s["scenes"] == 1 and s["dominant"] == 1 and s["within"] >= 1.0
    assert s["m_rmse_median"] == pytest.approx(row["rules"]["hybrid"][0] / row["naive"][0])


def test_fold_model_patterns_name_every_fold_or_fail_clearly(tmp_path):
    from training.keylight.cv import fold_model_paths

    for k in (1, 2, 3):
        (tmp_path / f"m_{k}.safetensors").write_bytes(b"")
    assert fold_model_paths(str(tmp_path / "m_{k}.safetensors"), 3) == {k: tmp_path / f"m_{k}.safetensors" for k in (1, 2, 3)}
    with pytest.raises(SystemExit, match="m_4.safetensors"):
        fold_model_paths(str(tmp_path / "m_{k}.safetensors"), 4)
    with pytest.raises(SystemExit, match="needs"):
        fold_model_paths(str(tmp_path / "m.safetensors"))


def test_curve_option_names_a_camera_curve_or_fails_clearly():
    import argparse

    from training.keylight.cv import SRGB, parse_curve

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
