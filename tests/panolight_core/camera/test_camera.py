import io

import numpy as np
import pytest
from PIL import Image

from panolight_core.camera import auto_exposure, clipped_mask, hdr_to_ldr, lanczos_resize, ldr_to_linear
from panolight_core.camera.color import linear_to_srgb, srgb_to_linear


def test_forward_model_follows_evaluation_md(rng):
    hdr = rng.random((8, 16, 3)) ** 3 * 50
    lum = hdr @ [0.2126, 0.7152, 0.0722]
    for ev in (-2, 0, 2):
        k = 0.18 * 2 ** ev / np.median(lum)
        assert auto_exposure(hdr, ev) == pytest.approx(k, rel=1e-12)
        v = np.clip(k * hdr, 0, 1)
        srgb = np.where(v <= 0.0031308, 12.92 * v, 1.055 * v ** (1 / 2.4) - 0.055)
        np.testing.assert_array_equal(hdr_to_ldr(hdr, ev), np.round(srgb * 255).astype(np.uint8))


def test_jpeg_option_and_undefined_exposure(rng):
    hdr = rng.random((16, 32, 3)) + 0.1
    ldr = hdr_to_ldr(hdr, 0, jpeg_quality=90)
    assert ldr.dtype == np.uint8 and ldr.shape == (16, 32, 3)
    buf = io.BytesIO()
    Image.fromarray(hdr_to_ldr(hdr, 0)).save(buf, format="JPEG", quality=90)
    np.testing.assert_array_equal(ldr, np.asarray(Image.open(io.BytesIO(buf.getvalue())).convert("RGB")))
    with pytest.raises(ValueError, match="median luminance"):
        auto_exposure(np.zeros((4, 8, 3)))


def test_inverse_is_the_srgb_curve_and_clipping_is_flagged():
    v = np.arange(256, dtype=np.uint8)[None, :, None].repeat(3, axis=2)
    np.testing.assert_allclose(ldr_to_linear(v)[0, :, 0], srgb_to_linear(np.arange(256) / 255.0), rtol=1e-6)
    np.testing.assert_allclose(linear_to_srgb(ldr_to_linear(v).astype(np.float64)) * 255, v, atol=1e-3)
    px = np.array([[[254, 0, 0], [253, 253, 253], [0, 0, 255]]], dtype=np.uint8)
    np.testing.assert_array_equal(clipped_mask(px), [[True, False, True]])


def test_tone_curves_the_cameras_draw():
    """The shared tone curves (training's camera and the studies' --curve): sRGB is EVALUATION.md's; a pure gamma;
    a shoulder that reaches white exactly at wp; a midtone S-curve that keeps mid grey and steepens about it."""
    from panolight_core.camera import TONE_CURVES, tone_curve

    x = np.array([0.0, 0.01, 0.18, 0.5, 1.0, 3.0])
    np.testing.assert_array_equal(tone_curve(x), linear_to_srgb(np.clip(x, 0, 1)))
    np.testing.assert_allclose(tone_curve(x, "gamma", 2.0), np.sqrt(np.clip(x, 0, 1)))
    np.testing.assert_allclose(tone_curve(np.array([4.0, 8.0]), "shoulder", 4.0), [1.0, 1.0])
    assert tone_curve(np.array([3.9]), "shoulder", 4.0)[0] < 1.0  # only beyond wp is it white
    g = 1.6
    lin = srgb_to_linear(tone_curve(np.array([0.09, 0.18, 0.36]), "contrast", g))
    np.testing.assert_allclose(lin[1], 0.18, rtol=1e-12)  # mid grey stays
    np.testing.assert_allclose(np.log(lin[2] / lin[0]) / np.log(4.0), g, rtol=1e-9)  # a slope g in log-log
    for name in TONE_CURVES:  # every curve maps into [0, 1], rising
        y = tone_curve(np.linspace(0, 10, 200), name)
        assert y.min() >= 0 and y.max() <= 1 and (np.diff(y) >= 0).all()
    with pytest.raises(ValueError, match="unknown tone curve 'log'.*srgb, gamma, shoulder, contrast"):
        tone_curve(x, "log")
    ldr = hdr_to_ldr(np.full((4, 8, 3), 0.5), 0.0, curve="contrast", curve_param=g)
    assert ldr.dtype == np.uint8 and int(ldr[0, 0, 0]) == round(255 * float(linear_to_srgb(np.array(0.18))))


def test_lanczos_resize_makes_a_photo_smaller_and_keeps_a_flat_one_flat():
    flat = np.full((25, 50, 3), (200, 120, 40), dtype=np.uint8)
    small = lanczos_resize(flat, 20, 9)
    assert small.shape == (9, 20, 3) and small.dtype == np.uint8
    assert (small == flat[0, 0]).all()
    edge = np.zeros((8, 16, 3), dtype=np.uint8)
    edge[:, 8:] = 255
    half = lanczos_resize(edge, 8, 4)
    assert half[:, 0].max() < 30 and half[:, -1].min() > 225  # the two sides keep their levels
