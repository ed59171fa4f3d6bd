import numpy as np
import pytest

from panolight_core import sh


def _sun_sh(lmax=4, direction=(0.3, 0.5, 0.81)):
    """SH of a small bright disk over a dim sky: its truncated series rings below zero."""
    d = np.asarray(direction) / np.linalg.norm(direction)
    dirs = sh.pixel_directions(128, 256)
    img = np.full((128, 256, 3), 0.05)
    img[dirs @ d > np.cos(np.radians(3))] = [40.0, 30.0, 20.0]
    return sh.project(img, lmax)


def _moments(f, h, w, keep=2):
    y = sh.basis(sh.pixel_directions(h, w).reshape(-1, 3), keep)
    return (sh.pixel_solid_angles(h, w).reshape(-1, 1) * y).T @ f.reshape(-1, f.shape[-1])


def test_emitter_has_no_negative_light_and_the_same_bands_0_to_2():
    c = _sun_sh()
    rad = sh.reconstruct(c, 64, 128)
    assert (rad < 0).any()  # the series rings
    f, info = sh.emitter_map(c, 64, 128)
    assert f.min() >= 0 and info["negative_fraction"] > 0.05 and info["moment_error"] < 1e-8
    np.testing.assert_allclose(_moments(f, 64, 128), _moments(rad, 64, 128), atol=1e-9 * abs(c[0]).max())
    # so every diffuse surface gets the same irradiance, and the energy (band 0) is unchanged ...
    e_ours = sh.irradiance_map(sh.project(f, 2), 32, 64)
    e_model = sh.irradiance_map(sh.project(rad, 2), 32, 64)
    np.testing.assert_allclose(e_ours, e_model, rtol=1e-4)  # sh.project: another quadrature than the moments
    # ... where clipping the negatives adds light
    clipped = _moments(np.maximum(rad, 0), 64, 128)[0]
    assert clipped.sum() > 1.03 * _moments(rad, 64, 128)[0].sum()  # 4 % more light here


def test_it_is_the_nearest_such_map_against_a_float64_dykstra_reference():
    c = _sun_sh(lmax=3)
    h, w = 16, 32
    rad = sh.reconstruct(c, h, w).reshape(-1, 3)
    dirs = sh.pixel_directions(h, w).reshape(-1, 3)
    wts = sh.pixel_solid_angles(h, w).reshape(-1)
    f, _ = sh.nonnegative(rad, dirs, wts)
    # Dykstra's alternating projections (independent of the Newton solve) onto {f >= 0} and the affine set
    y = sh.basis(dirs, 2)
    gram_inv = np.linalg.inv(y.T @ (wts[:, None] * y))
    target = y.T @ (wts[:, None] * rad)
    x, p, q = rad.copy(), np.zeros_like(rad), np.zeros_like(rad)
    for _ in range(20000):
        a = np.maximum(x + p, 0)
        p = x + p - a
        b = a + q
        x = b + y @ (gram_inv @ (target - y.T @ (wts[:, None] * b)))
        q = b - x
    scale = np.abs(rad).max()
    np.testing.assert_allclose(f, np.maximum(x, 0), atol=2e-4 * scale)


def test_non_negative_radiance_is_unchanged_and_a_dark_channel_is_zero():
    c = np.zeros((9, 3))
    c[0] = [1.0, 2.0, 3.0]
    c[2] = [0.5, 0.5, 0.5]  # 1 + 0.5 cos: non-negative
    rad = sh.reconstruct(c, 16, 32)
    f, info = sh.emitter_map(c, 16, 32)
    np.testing.assert_array_equal(f, rad)
    assert info["negative_fraction"] == 0 and info["iterations"] == 0
    c[0, 1] = -0.1  # a channel whose mean is negative has no non-negative map: no light
    f, info = sh.emitter_map(c, 16, 32)
    assert f.min() >= 0 and np.all(f[..., 1] == 0) and info["moment_error"] == 1.0


@pytest.mark.parametrize("height", [8, 64, 256])
def test_every_grid_size_converges(height):
    c = _sun_sh(lmax=6)
    f, info = sh.emitter_map(c, height, 2 * height)
    assert f.min() >= 0 and info["moment_error"] < 1e-8 and info["iterations"] <= 20
