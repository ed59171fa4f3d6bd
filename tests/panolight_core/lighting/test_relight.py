import numpy as np
import pytest
import torch

from panolight_core import sh
from panolight_core.lighting.relight import LDR_SCALE, blend, relight, simulate_ldr, training_lighting


def test_relight_is_irradiance_times_image_batched_and_differentiable(rng):
    n = sh.pixel_directions(6, 12)
    img = rng.random((6, 12, 3))
    c = rng.normal(size=(9, 3))
    np.testing.assert_allclose(relight(img, n, c), sh.irradiance(c, n) * img, atol=1e-14)
    out = relight(np.stack([img, img]), np.stack([n, n]), np.stack([c, 3 * c]))
    np.testing.assert_allclose(out[1], 3 * relight(img, n, c), atol=1e-12)
    assert np.all(relight(img, np.zeros_like(n), c) == 0)  # no surface, no light
    args = [torch.tensor(a, requires_grad=True) for a in (img[:2, :3], n[:2, :3], c)]
    assert torch.autograd.gradcheck(relight, args)
    with pytest.raises(ValueError, match="same shape"):
        relight(img, n[:, :6], c)


def test_blending_and_projection_commute(rng):
    a, b = rng.random((32, 64, 3)) * 5, rng.random((32, 64, 3))
    for lam in (0.0, 0.3, 1.0):
        np.testing.assert_allclose(sh.project(lam * a + (1 - lam) * b, 2), blend(sh.project(a, 2), sh.project(b, 2), lam),
                                   atol=1e-12)


def test_training_lighting_scales_and_derings(rng):
    a, b = rng.normal(size=(9, 3)), rng.normal(size=(9, 3))
    target, used = training_lighting(a, b, 0.25)
    np.testing.assert_allclose(target, 0.25 * a + 0.75 * b)
    np.testing.assert_allclose(used, sh.window(target * LDR_SCALE, "sinc4", 6.0))
    ldr = simulate_ldr(np.full((4, 8, 3), 3.0))
    assert ldr.dtype == np.uint8 and ldr.shape == (4, 8, 3)
