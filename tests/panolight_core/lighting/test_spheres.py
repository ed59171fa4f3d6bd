"""lighting.spheres and metrics.sphere_scores: the three-sphere protocol, checked against analytic cases."""
import math

import numpy as np
import pytest

from panolight_core import metrics, sh
from panolight_core.lighting import spheres


def test_a_constant_environment_lights_every_sphere_evenly():
    env = np.ones((64, 128, 3))
    for name, pixels in spheres.render_spheres(env, size=32).items():
        np.testing.assert_allclose(pixels, 1.0, rtol=2e-3, err_msg=name)  # E / pi = 1; a normalised lobe; the map


def test_a_model_s_lights_keep_their_energy_on_the_environment_grid():
    light = {"direction": [0.3, -0.4, 0.866], "intensity": 2.0, "color": [1.0, 0.8, 0.6], "angle": math.radians(0.53)}
    wide = dict(light, angle=math.radians(12.0))
    omega = sh.pixel_solid_angles(128, 256)[..., None]
    for one in (light, wide):  # a sun smaller than a cell, and a lamp spread over many
        env = spheres.environment_from_model(np.zeros((9, 3)), [one])
        np.testing.assert_allclose((env * omega).sum(axis=(0, 1)), 2.0 * np.array([1.0, 0.8, 0.6]), rtol=1e-9)


def test_the_mirror_sphere_reflects_the_point_behind_the_viewer_at_its_centre():
    normals, mirror = spheres.sphere_geometry(33)
    centre = np.argmax(normals[:, 0])
    np.testing.assert_allclose(normals[centre], [1.0, 0.0, 0.0], atol=1e-3)
    np.testing.assert_allclose(mirror[centre], [1.0, 0.0, 0.0], atol=1e-3)  # straight back toward the camera
    assert np.allclose(np.linalg.norm(mirror, axis=-1), 1.0)


def test_scores_are_zero_for_the_truth_and_scale_invariant_where_they_say():
    rng = np.random.default_rng(0)
    truth = {n: rng.random((50, 3)) + 0.1 for n in spheres.SPHERES}
    same = metrics.sphere_scores(truth, truth)
    assert all(v == pytest.approx(0.0, abs=1e-5) for s in same.values() for v in s.values())  # arccos near 1
    doubled = metrics.sphere_scores(truth, {n: 2.0 * p for n, p in truth.items()})
    for s in doubled.values():
        assert s["si_rmse"] == pytest.approx(0.0, abs=1e-9) and s["angular_deg"] == pytest.approx(0.0, abs=1e-5)
        assert s["rmse"] == pytest.approx(1.0, rel=1e-9)  # (2g - g) over g's RMS
    grey = metrics.sphere_scores({"diffuse": np.array([[1.0, 0.0, 0.0]])}, {"diffuse": np.array([[1.0, 1.0, 0.0]])})
    assert grey["diffuse"]["angular_deg"] == pytest.approx(45.0)


def test_a_model_in_camera_units_is_scored_in_the_truth_s():
    """model_scores scales an estimate's SH and lights by ``unit`` into the truth's units: a constant environment's
    own SH at half the level, unit 2, scores as the truth; unit 1 is 50 % off (RMSE) and scale-invariantly right;
    score_medians takes each score's median over the list."""
    truth = spheres.render_spheres(np.full((64, 128, 3), 0.8))
    half = sh.project(np.full((16, 32, 3), 0.4), 2)
    right = spheres.model_scores(truth, half, [], 2.0)
    off = spheres.model_scores(truth, half, [], 1.0)
    for name in spheres.SPHERES:
        assert right[name]["rmse"] == pytest.approx(0.0, abs=5e-3)
        assert off[name]["rmse"] == pytest.approx(0.5, abs=5e-3) and off[name]["si_rmse"] == pytest.approx(0.0, abs=5e-3)
    med = spheres.score_medians([right, off, off])
    assert med["diffuse"]["rmse"] == pytest.approx(off["diffuse"]["rmse"]) and spheres.score_medians([]) == {}
