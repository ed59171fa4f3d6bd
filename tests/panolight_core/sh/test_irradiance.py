import math

import numpy as np
import pytest
import torch

from panolight_core import sh
from tests.conftest import random_directions


def test_lambert_kernel_values():
    a = sh.lambert_kernel(8)
    np.testing.assert_allclose(a[:3], [math.pi, 2 * math.pi / 3, math.pi / 4], rtol=1e-15)
    assert a[3] == a[5] == a[7] == 0
    np.testing.assert_allclose(a[4], -math.pi / 24, rtol=1e-14)  # 2 pi (-1) / (6 * 3) * 4! / (16 * 4)
    np.testing.assert_allclose(a[6], math.pi / 64, rtol=1e-14)
    assert np.all(np.isfinite(sh.lambert_kernel(200)))


def test_matrix_form_agrees_with_kernel(rng):
    c = rng.normal(size=(9, 3))
    n = random_directions(rng, 500)
    np.testing.assert_allclose(sh.irradiance_rh(c, n), sh.irradiance(c, n), atol=1e-12)
    from panolight_core.sh.irradiance import RH_C1, RH_C2, RH_C3, RH_C4, RH_C5, _rh_constants
    np.testing.assert_allclose(_rh_constants(), [RH_C1, RH_C2, RH_C3, RH_C4, RH_C5], atol=1.5e-6)  # R&H round to 6 digits
    m = sh.irradiance_matrix(c)
    np.testing.assert_allclose(m, np.swapaxes(m, -1, -2))


@pytest.mark.parametrize("lmax", [2, 4, 6])
def test_irradiance_equals_brute_force_cosine_integral(rng, lmax):
    """E(n) = integral of L(w) max(0, n.w) dw for band-limited L, by dense quadrature."""
    c = rng.normal(size=((lmax + 1) ** 2, 3))
    c[0] += 10.0
    h = 720
    radiance = sh.reconstruct(c, h, 2 * h)
    d = sh.pixel_directions(h, 2 * h)
    omega = sh.pixel_solid_angles(h, 2 * h)
    n = random_directions(rng, 6)
    brute = np.einsum("hwc,nhw->nc", radiance, np.maximum(0.0, d @ n.T).transpose(2, 0, 1) * omega)
    np.testing.assert_allclose(sh.irradiance(c, n), brute, rtol=2e-4)


def test_batched_irradiance_and_torch_gradients(rng):
    c = rng.normal(size=(2, 9, 3))
    n = random_directions(rng, 10).reshape(2, 5, 3)
    e = sh.irradiance(c, n)
    assert e.shape == (2, 5, 3)
    np.testing.assert_allclose(e[1], sh.irradiance(c[1], n[1]), atol=1e-14)
    ct = torch.tensor(c[0], requires_grad=True)
    nt = torch.tensor(n[0], requires_grad=True)
    assert torch.autograd.gradcheck(lambda a, b: sh.irradiance(a, b), (ct, nt))
    assert torch.autograd.gradcheck(lambda a, b: sh.irradiance_rh(a, b), (ct, nt))


def test_matrix_form_needs_lmax_2():
    with pytest.raises(ValueError, match="lmax = 2"):
        sh.irradiance_matrix(np.zeros((16, 3)))
