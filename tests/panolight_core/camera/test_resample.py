import numpy as np

from panolight_core import sh
from panolight_core.camera.resample import area_downsample, sample_equirect
from tests.conftest import random_directions


def test_sampling_at_pixel_centres_returns_the_pixels(rng):
    img = rng.random((8, 16, 3))
    dirs = sh.pixel_directions(8, 16)
    np.testing.assert_allclose(sample_equirect(img, dirs), img, atol=1e-12)


def test_sampling_a_smooth_map_matches_the_function_it_holds(rng):
    coeffs = rng.normal(size=(9, 3))
    img = sh.reconstruct(coeffs, 256, 512)
    dirs = random_directions(rng, 2000)
    exact = sh.basis(dirs, 2) @ coeffs
    got = sample_equirect(img, dirs)
    assert np.abs(got - exact).max() < 5e-3 * np.abs(exact).max()  # bilinear; worst half a row from a pole


def test_columns_wrap_across_the_seam_and_rows_clamp_at_the_poles():
    img = np.zeros((4, 8, 1))
    img[:, 0] = 1.0  # the left column (looking towards -X, just left of the seam)
    img[:, -1] = 3.0  # the right column
    seam = sample_equirect(img, np.array([[-1.0, 0.0, 0.0]]))  # -X: the edge between them
    assert np.isclose(seam[0, 0], 2.0)
    assert np.isfinite(sample_equirect(img, np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]]))).all()


def test_area_downsample_keeps_the_mean(rng):
    img = rng.random((64, 128, 3))
    small = area_downsample(img, 16)
    assert small.shape == (16, 32, 3) and np.allclose(small.mean(axis=(0, 1)), img.mean(axis=(0, 1)))


def test_the_lut_mean_is_area_downsample_of_the_lut_image_to_the_bit(rng):
    from panolight_core.camera.color import SRGB8_TO_LINEAR
    from panolight_core.camera.resample import area_mean_lut

    for shape, height in (((256, 512, 3), 64), ((96, 192, 3), 32), ((100, 200, 3), 32), ((64, 128, 3), 64)):
        img = rng.integers(0, 256, shape, dtype=np.uint8)
        want = area_downsample(SRGB8_TO_LINEAR[img], height)
        assert np.array_equal(area_mean_lut(img, height, SRGB8_TO_LINEAR), want), shape
