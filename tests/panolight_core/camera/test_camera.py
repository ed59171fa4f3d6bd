import io

import numpy as np
import pytest
from PIL import Image

from panolight_core.camera import auto_exposure, clipped_mask, hdr_to_ldr, ldr_to_linear
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
