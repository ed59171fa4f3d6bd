
import numpy as np
import pytest

from panolight_core import metrics, sh
from panolight_core.apps import evaluation
from panolight_core.camera import hdr_to_ldr
from panolight_core.data import load_studio_hdri
from panolight_core.estimators import estimate
from panolight_core.lighting.adaptive import fit_model
from panolight_core.synthetic import environment


def _sunny(seed_range=range(300, 340)):
    for seed in seed_range:
        img, p = environment(seed, 128)
        if p["kind"] == "outdoor" and p["sun_visible"]:
            return img, p
    raise AssertionError("no sunny environment in range")


def test_lights_plus_auto_order_beat_fixed_lmax2_on_a_sunny_sky():
    img, p = _sunny()
    truth = sh.irradiance_map(sh.project(img, 24), 64, 128)
    model = fit_model(img)
    fixed = fit_model(img, lights=False, lmax=2, deringing="none")
    assert len(model.lights) >= 1 and model.lights[0]["type"] == "sun"
    assert metrics.angle_deg(model.lights[0]["peak_direction"], p["sun_direction"]) < 2
    assert metrics.irr_rmse_maps(truth, model.irradiance_map(64, 128)) < 0.5 * metrics.irr_rmse_maps(
        truth, fixed.irradiance_map(64, 128))
    assert model.parameter_count == model.coeffs.size + 8 * len(model.lights)
    info = model.info
    assert info["order"]["mode"] == "auto" and len(info["order"]["irradiance_error_per_order"]) == 9
    assert info["order"]["irradiance_error_per_order"][info["order"]["lmax"]] <= 0.01


def test_constant_environment_needs_nothing():
    model = fit_model(np.full((32, 64, 3), 0.7))
    assert model.lights == [] and model.info["order"]["lmax"] == 0 and model.info["ringing"]["window"] is None
    assert "why_none" in model.info["lights"]


def test_deringing_only_when_irradiance_rings():
    img = np.full((64, 128, 3), 0.01)
    img[5, 30] = 1e4  # a sun SH alone cannot hold without negative irradiance
    sh_only = fit_model(img, lights=False, lmax=2)
    assert sh_only.info["ringing"]["min_irradiance_rel"] < -0.01
    assert sh_only.info["ringing"]["window"]["target"] == "irradiance"
    windowed = sh.irradiance_map(sh_only.coeffs, 64, 128)
    assert windowed.min() >= -1e-6 * windowed.mean() - 1e-12
    with_light = fit_model(img, lmax=2)
    assert with_light.info["ringing"]["window"] is None and len(with_light.lights) == 1
    fixed = fit_model(img, lights=False, lmax=3, deringing="none")
    assert fixed.info["order"] == {"mode": "fixed", "lmax": 3} and fixed.coeffs.shape == (16, 3)


def test_all_saturated_ldr_is_sane():
    est = estimate(np.full((64, 128, 3), 255, np.uint8), 8, "analytic")
    model = fit_model(est.radiance, light_threshold=0.99)
    assert model.lights == [] and np.all(np.isfinite(model.coeffs)) and model.info["order"]["lmax"] == 0
    assert model.info["lights"]["why_none"]


@pytest.mark.parametrize("scene", ["city", "courtyard", "forest", "sunrise", "sunset"])
def test_public_sun_scenes_within_2_degrees_and_better_than_lmax2(scene):
    rows = evaluation.run_adaptive(scenes=(scene,))
    r = rows[0]
    assert r["sun_angle_deg"] < 2.0
    assert r["irr_rmse_adaptive"] < r["irr_rmse_fixed_lmax2"]


@pytest.mark.parametrize("scene", ["interior", "night", "studio"])
def test_public_other_scenes_no_worse_and_choice_reported(scene):
    r = evaluation.run_adaptive(scenes=(scene,))[0]
    assert r["irr_rmse_adaptive"] <= r["irr_rmse_fixed_lmax2"]
    assert r["lmax"] in range(9) and r["n_lights"] == len(r["light_types"])


def test_ldr_inputs_get_lights_from_recovered_sources():
    hdr = load_studio_hdri("sunrise")
    est = estimate(hdr_to_ldr(hdr, 0), 8, "analytic")
    model = fit_model(est.radiance, light_threshold=0.99)
    assert np.all(np.isfinite(model.coeffs))
    for light in model.lights:
        assert light["intensity"] > 0 and abs(np.linalg.norm(light["direction"]) - 1) < 1e-9


def test_overcast_sky_gets_no_light_and_says_why():
    for seed in range(400, 500):
        img, p = environment(seed, 128)
        if p["kind"] == "outdoor" and p["overcast"]:
            break
    model = fit_model(img)
    assert model.lights == [] and model.info["lights"]["why_none"]
    assert model.info["order"]["lmax"] <= 4
