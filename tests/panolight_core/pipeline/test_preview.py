import numpy as np

from panolight_core import sh
from panolight_core.lighting.adaptive import LightingModel
from panolight_core.pipeline.preview import diffuse_sphere, estimate_preview, exposure_for, strip, tonemap


def test_exposure_puts_the_median_at_18_percent_and_degenerate_images_get_1():
    img = np.full((4, 8, 3), 0.5)
    assert np.isclose(exposure_for(img), 0.36)
    assert exposure_for(np.zeros((4, 8, 3))) == 1.0
    assert exposure_for(np.full((4, 8, 3), np.nan)) == 1.0


def test_tonemap_is_srgb_of_the_clipped_scaled_image():
    img = np.array([[[0.0, 0.5, 4.0]]])
    out = tonemap(img, 0.5)
    assert out.dtype == np.uint8 and out.tolist() == [[[0, 137, 255]]]  # srgb(0.25) = 0.537


def test_diffuse_sphere_of_a_constant_environment_is_uniform():
    c = np.zeros((9, 3))
    c[0] = 2.0 * np.sqrt(4 * np.pi)  # radiance 2 everywhere -> irradiance 2 pi -> shade 0.8 * 2
    img = diffuse_sphere(c, 32)
    inside = img[16, 16]
    assert np.allclose(inside, 1.6, rtol=1e-6)
    assert np.allclose(img[0, 0], 0.8)  # outside: half the sphere's median


def test_a_light_brightens_the_side_of_the_sphere_facing_it():
    lights = [{"type": "sun", "direction": [0.0, -1.0, 0.0], "color": [1, 1, 1], "intensity": 50.0,
               "angle": 0.01}]  # -Y: image right (the camera looks along +X)
    img = diffuse_sphere(LightingModel(lights, np.zeros((1, 3))), 32)
    assert img[16, 28].mean() > 10 * img[16, 3].mean()


def test_preview_strip_layout():
    image = np.random.default_rng(0).random((32, 64, 3))
    coeffs = sh.project(image, 2)
    out = estimate_preview(image, sh.reconstruct(coeffs, 32, 64), coeffs, 2, height=32)
    assert out.dtype == np.uint8 and out.shape == (32, 64 + 4 + 64 + 4 + 32, 3)
    assert (out[:, 64:68] == 255).all()  # white gaps between the tiles
    assert strip([("a", image)], 16).shape == (16, 32, 3)


def test_the_sphere_from_the_irradiance_map_matches_the_model():
    lights = [{"type": "sun", "direction": [0.6, -0.48, 0.64], "color": [1, 0.9, 0.8], "intensity": 5.0,
               "angle": 0.02}]
    c = np.zeros((9, 3))
    c[0], c[3] = 1.0, 0.4
    model = LightingModel(lights, c)
    exact = diffuse_sphere(model, 64)
    looked_up = diffuse_sphere(model, 64, irradiance_map=model.irradiance_map(256, 512))
    assert np.abs(looked_up - exact).max() < 0.01 * exact.max()
