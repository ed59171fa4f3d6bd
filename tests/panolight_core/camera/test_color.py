import numpy as np
import pytest

from panolight_core.camera.color import (
    LUMINANCE_WEIGHTS,
    SRGB8_TO_LINEAR,
    gray8,
    linear_to_srgb,
    luminance,
    srgb_to_linear,
)


def test_srgb_round_trip_and_the_iec_breakpoints():
    v = np.linspace(0.0, 1.0, 1001)
    assert np.allclose(linear_to_srgb(srgb_to_linear(v)), v, atol=1e-6)
    assert np.isclose(srgb_to_linear(np.float64(0.04045)), 0.04045 / 12.92)
    assert np.isclose(linear_to_srgb(np.float64(0.0031308)), 0.0031308 * 12.92)
    assert np.isclose(srgb_to_linear(np.float64(1.0)), 1.0) and srgb_to_linear(np.float64(0.0)) == 0.0


def test_curve_is_continuous_and_increasing():
    v = np.linspace(0.0, 1.0, 100001)
    lin = srgb_to_linear(v)
    assert (np.diff(lin) > 0).all()
    assert np.abs(np.diff(lin)).max() < 1e-4


def test_encoding_clips_and_dtype_follows_the_input():
    assert np.allclose(linear_to_srgb(np.array([-1.0, 2.0])), [0.0, 1.0], atol=1e-12)
    assert srgb_to_linear(np.zeros(3, np.float32)).dtype == np.float32
    assert srgb_to_linear(np.zeros(3, np.float64)).dtype == np.float64


def test_uint8_table_is_the_curve():
    assert np.allclose(SRGB8_TO_LINEAR, srgb_to_linear(np.arange(256) / 255.0), atol=1e-7)
    assert not SRGB8_TO_LINEAR.flags.writeable


def test_gray8_is_wards_grey_on_any_view_and_at_white():
    rng = np.random.default_rng(3)
    frame = rng.integers(0, 256, (40, 60, 3), dtype=np.uint8)
    frame[0, :, :] = 255  # the largest sum, 256 x 255: no uint16 overflow
    for view in (frame, frame[::2, ::3], frame[5:9]):
        want = np.floor((view.astype(np.int64) @ np.array([54, 183, 19])) / 256.0).astype(np.uint8)
        got = gray8(view)
        assert got.dtype == np.uint8 and got.shape == view.shape[:2] and np.array_equal(got, want)
    assert (gray8(frame)[0] == 255).all()


def test_luminance_is_rec709():
    assert np.isclose(LUMINANCE_WEIGHTS.sum(), 1.0)
    assert np.isclose(luminance(np.array([1.0, 1.0, 1.0])), 1.0)
    assert np.allclose(luminance(np.eye(3)), [0.2126, 0.7152, 0.0722])


def test_torch_and_numpy_share_the_curve():
    torch = pytest.importorskip("torch")
    v = np.linspace(0.0, 1.0, 257)
    t = srgb_to_linear(torch.tensor(v, dtype=torch.float64, requires_grad=True))
    assert np.allclose(t.detach().numpy(), srgb_to_linear(v), atol=1e-12)
    t.sum().backward()  # differentiable for the autoencoder
