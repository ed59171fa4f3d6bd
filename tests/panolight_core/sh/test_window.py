import math

import numpy as np
import pytest
import torch

from panolight_core import sh


def test_window_definitions():
    np.testing.assert_allclose(sh.window_weights(2, "sinc4", 6.0),
                               [1, (math.sin(math.pi / 6) / (math.pi / 6)) ** 4, (math.sin(math.pi / 3) / (math.pi / 3)) ** 4])
    np.testing.assert_allclose(sh.window_weights(3, "hanning", 4.0), [1, (1 + math.cos(math.pi / 4)) / 2, 0.5,
                                                                      (1 + math.cos(3 * math.pi / 4)) / 2])
    np.testing.assert_allclose(sh.window_weights(2, "lanczos", 3.0), [1, math.sin(math.pi / 3) / (math.pi / 3),
                                                                      math.sin(2 * math.pi / 3) / (2 * math.pi / 3)])
    for kind in ("sinc4", "lanczos", "hanning"):
        np.testing.assert_array_equal(sh.window_weights(5, kind, math.inf), 1.0)
        np.testing.assert_allclose(sh.window_weights(5, kind, 1.0), [1, 0, 0, 0, 0, 0], atol=1e-15)
        w = sh.window_weights(8, kind, 5.0)
        assert np.all(np.diff(w) <= 1e-15) and np.all(w >= 0)  # monotone, never amplifies or flips
    with pytest.raises(ValueError, match="kind"):
        sh.window_weights(2, "gauss")


def _ringing_sun(lmax):
    img = np.full((64, 128, 3), 1e-3)
    img[20, 40] = 1e5
    return sh.project(img, lmax)


@pytest.mark.parametrize("target", ["radiance", "irradiance"])
def test_auto_window_is_weakest_non_negative(target):
    c = _ringing_sun(8)
    assert sh.min_over_grid(c, target).min() < 0  # it rings
    width = sh.auto_window_width(c, target=target)
    mean = c[0, 0] / math.sqrt(4 * math.pi) * (math.pi if target == "irradiance" else 1)
    out = sh.window(c, "sinc4", width)
    assert sh.min_over_grid(out, target).min() >= -1e-6 * mean * 1.001
    weaker = sh.window(c, "sinc4", width * 1.02)
    assert sh.min_over_grid(weaker, target).min() < -1e-6 * mean  # a slightly weaker window rings again
    np.testing.assert_allclose(sh.window(c, "auto", target=target), out)


def test_auto_window_leaves_non_ringing_light_alone():
    c = sh.project(np.ones((16, 32, 3)) + sh.pixel_directions(16, 32)[..., 2:3] * 0.3, 4)
    assert sh.auto_window_width(c) == math.inf
    np.testing.assert_array_equal(sh.window(c, "auto"), c)


def test_auto_window_refuses_negative_mean():
    c = np.zeros((9, 3))
    c[0] = -1
    with pytest.raises(ValueError, match="negative mean"):
        sh.auto_window_width(c)


def test_window_torch_gradient_and_batch():
    flat = np.zeros((9, 3))
    flat[0] = 1.0
    c = torch.tensor(np.stack([_ringing_sun(2), flat]), requires_grad=True)
    out = sh.window(c, "auto")
    assert out.shape == c.shape and isinstance(out, torch.Tensor)
    assert torch.autograd.gradcheck(lambda x: sh.window(x, "hanning", 3.0), (c,))
    np.testing.assert_allclose(out[1].detach().numpy(), flat)  # the flat one is untouched
    assert not torch.allclose(out[0], c[0])
