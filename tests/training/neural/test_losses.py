import numpy as np
import torch

from panolight_core import sh
from training.neural.losses import WEIGHTS, photometric_loss, reconstruction_loss, sh_loss, ssim, total_loss


def _batch(rng, b=2, h=8):
    image = torch.tensor(rng.random((b, h, 2 * h, 3)))
    normals = torch.tensor(np.broadcast_to(sh.pixel_directions(h, 2 * h), (b, h, 2 * h, 3)).copy())
    target = torch.tensor(rng.normal(size=(b, 9, 3)) * 0.2 + np.eye(9, 3)[None] * 3)
    return image, normals, target


def test_losses_vanish_for_a_perfect_prediction_and_grow_otherwise(rng):
    image, normals, target = _batch(rng)
    total, parts = total_loss(image, normals, target.clone(), target)
    assert float(total) < 1e-9 and all(abs(v) < 1e-9 for v in parts.values())
    worse = target + 0.5
    total_w, parts_w = total_loss(image, normals, worse, target)
    assert all(parts_w[k] > 1e-4 for k in parts_w) and float(total_w) > 0
    assert WEIGHTS == {"sh": 0.01, "rc": 0.3, "rl": 0.7}
    _, off = total_loss(image, normals, worse, target, weights={"rl": 0.0})
    assert off["rl"] == 0


def test_reconstruction_loss_is_the_solid_angle_weighted_l2(rng):
    _, _, target = _batch(rng)
    pred = target.clone()
    pred[:, 0] += 1.0  # a constant offset of Y_00 in every channel: squared radiance difference 1 / (4 pi)
    np.testing.assert_allclose(float(reconstruction_loss(pred, target)), 1 / (4 * np.pi), rtol=1e-6)
    assert float(sh_loss(pred, target)) == float(((pred - target) ** 2).mean())


def test_scaled_losses_are_relative_and_robust(rng):
    from panolight_core import metrics

    _, _, target = _batch(rng)
    pred = target.clone()
    pred[:, 0] += 1.0
    scale = torch.tensor([1.0, 10.0], dtype=target.dtype)
    # per sample log(1 + e / s^2): the same absolute miss counts 100x less squared in a 10x brighter scene
    expected = (np.log1p(1 / 9) + np.log1p(1 / 9 / 100)) / 2
    np.testing.assert_allclose(float(sh_loss(pred, target, scale)), expected, rtol=1e-6)
    far = target.clone()
    far[:, 0] += 1e4  # a wild miss grows the loss only logarithmically
    assert float(sh_loss(far, target, scale)) < 20 and float(sh_loss(target, target, scale)) == 0
    # the relative reconstruction loss is the evaluation's m-RMSE (on a coarser grid), scale-free
    pred = target * torch.tensor([1.0, 1.3, 0.7])[None, None] + 0.1 * torch.tensor(rng.normal(size=target.shape))
    want = np.mean([metrics.m_rmse(t.numpy(), p.numpy()) for t, p in zip(target, pred)])
    got = float(reconstruction_loss(pred, target, height=64, relative=True))
    np.testing.assert_allclose(got, want, rtol=0.05)
    np.testing.assert_allclose(float(reconstruction_loss(pred * 7.0, target, height=64, relative=True)), got, rtol=1e-6)


def test_extremes_are_finite_with_finite_gradients(rng):
    image, normals, target = _batch(rng)
    for img in (torch.zeros_like(image), image * 1e6):
        for pred0 in (torch.zeros_like(target), target * 1e4, -target):
            pred = pred0.clone().requires_grad_(True)
            total, _ = total_loss(img, normals, pred, target)
            total.backward()
            assert torch.isfinite(total) and torch.all(torch.isfinite(pred.grad))


def test_ssim_identity_and_range(rng):
    a = torch.tensor(rng.random((1, 3, 16, 32)))
    assert abs(float(ssim(a, a)) - 1) < 1e-9
    b = torch.tensor(rng.random((1, 3, 16, 32)))
    assert -1 <= float(ssim(a, b)) < 0.5
    assert 0 <= float(photometric_loss(*_batch(rng)[:2], *_batch(rng)[2:3] * 2)) < 10
