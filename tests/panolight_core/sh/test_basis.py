import math

import numpy as np
import pytest
import torch

from panolight_core import sh
from tests.conftest import random_directions
from tests.panolight_core.sh.reference import basis_scipy


def test_low_orders_match_conventions_table(rng):
    d = random_directions(rng, 50)
    x, y, z = d.T
    table = np.stack([np.full_like(x, 0.282095), 0.488603 * y, 0.488603 * z, 0.488603 * x, 1.092548 * x * y,
                      1.092548 * y * z, 0.315392 * (3 * z * z - 1), 1.092548 * x * z, 0.546274 * (x * x - y * y)], -1)
    np.testing.assert_allclose(sh.basis(d, 2), table, atol=2e-6)


@pytest.mark.parametrize("lmax", [0, 1, 5, 12, 25])
def test_matches_independent_scipy_reference(rng, lmax):
    d = random_directions(rng, 200)
    np.testing.assert_allclose(sh.basis(d, lmax), basis_scipy(d, lmax), atol=1e-10 * max(1, lmax))


def test_exact_poles_finite_and_correct():
    lmax = 40
    for sign in (1.0, -1.0):
        y = sh.basis(np.array([0.0, 0.0, sign]), lmax)
        l, m = sh.degrees_orders(lmax)
        expected = np.where(m == 0, sign ** l * np.sqrt((2 * l + 1) / (4 * np.pi)), 0.0)
        np.testing.assert_allclose(y, expected, atol=1e-12)


def test_no_nan_up_to_lmax_100(rng):
    d = np.concatenate([random_directions(rng, 500), [[0, 0, 1.0], [0, 0, -1.0], [1.0, 0, 0]],
                        [[np.sin(1e-8), 0, np.cos(1e-8)]]])
    y = sh.basis(d, 100)
    assert np.all(np.isfinite(y))
    # orthonormality survives at high order: quadrature over a grid exact for band 100 products
    c = sh.project(sh.reconstruct(np.eye(101 ** 2)[:, [0, 5000, 10200]], 208, 416), 100, weights="quadrature")
    np.testing.assert_allclose(c, np.eye(101 ** 2)[:, [0, 5000, 10200]], atol=1e-9)


def test_torch_in_torch_out_and_differentiable(rng):
    d = torch.tensor(random_directions(rng, 10), requires_grad=True)
    y = sh.basis(d, 4)
    assert isinstance(y, torch.Tensor) and y.dtype == torch.float64 and y.shape == (10, 25)
    np.testing.assert_allclose(y.detach().numpy(), sh.basis(d.detach().numpy(), 4), atol=1e-14)
    y.sum().backward()
    assert torch.all(torch.isfinite(d.grad))


def test_float32_kept(rng):
    assert sh.basis(random_directions(rng, 3).astype(np.float32), 3).dtype == np.float32


def test_rejects_non_unit_and_bad_shapes():
    with pytest.raises(ValueError, match="unit vectors"):
        sh.basis(np.array([[2.0, 0, 0]]), 2)
    with pytest.raises(ValueError, match=r"\(\.\.\., 3\)"):
        sh.basis(np.zeros((4, 2)), 2)
    with pytest.raises(ValueError, match="lmax"):
        sh.basis(np.array([0, 0, 1.0]), -1)
    with pytest.raises(ValueError, match="lmax"):
        sh.basis(np.array([0, 0, 1.0]), 2.5)


def test_pixel_directions_follow_conventions():
    d = sh.pixel_directions(4, 8)
    # image centre column boundary -> +X, quarter width -> +Y, three quarters -> -Y, top row -> +Z
    d_fine = sh.pixel_directions(1001, 2002)
    np.testing.assert_allclose(d_fine[500, 1001], [1, 0, 0], atol=1e-2)
    np.testing.assert_allclose(d_fine[500, 500], [0, 1, 0], atol=1e-2)
    np.testing.assert_allclose(d_fine[500, 1501], [0, -1, 0], atol=1e-2)
    assert d[0, 0, 2] > 0.9 and d[-1, 0, 2] < -0.9
    np.testing.assert_allclose(np.linalg.norm(d, axis=-1), 1.0, atol=1e-15)


def test_solid_angles_sum_to_4pi():
    for h in (1, 2, 7, 512):
        assert math.isclose(sh.pixel_solid_angles(h, 2 * h).sum(), 4 * math.pi, rel_tol=1e-13)
