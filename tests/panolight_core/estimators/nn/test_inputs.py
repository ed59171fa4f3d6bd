"""The learned estimator's input: area-averaged colour, clipped fraction, the physical model's guess."""
import numpy as np
import pytest

from panolight_core.camera.color import srgb_to_linear
from panolight_core.estimators.highlights import recover_highlights
from panolight_core.estimators.nn.inputs import BASE_EXCESS, network_input


def test_channels_hold_colour_clipped_fraction_and_the_recovered_excess(rng):
    ldr = rng.integers(0, 200, size=(64, 128, 3), dtype=np.uint8)
    ldr[8:12, 16:18] = 255  # 8 clipped pixels in one 4 x 4 cell
    x = network_input(ldr, 16)
    assert x.shape == (7, 16, 32) and x.dtype == np.float32
    assert x[3, 2, 4] == pytest.approx(8 / 16) and (x[3] > 0).sum() == 1
    lin = srgb_to_linear(ldr.astype(np.float64) / 255.0)
    np.testing.assert_allclose(srgb_to_linear(x[:3, 5, 7].astype(np.float64)),
                               lin[20:24, 28:32].reshape(-1, 3).mean(0), rtol=1e-4, atol=1e-6)
    # unclipped cells carry the neutral guess; the clipped cell rebuilds the physical model's map
    np.testing.assert_allclose(x[4:, 0, 0], np.log(BASE_EXCESS), rtol=1e-6)
    recovered, blobs = recover_highlights(ldr, 16)
    assert blobs
    rebuilt = srgb_to_linear(x[:3, 2, 4].astype(np.float64)) + x[3, 2, 4] * (np.exp(x[4:, 2, 4]) - BASE_EXCESS)
    np.testing.assert_allclose(rebuilt, recovered[2, 4], rtol=1e-3)


def test_wrong_pixels_are_refused():
    with pytest.raises(ValueError, match="uint8"):
        network_input(np.zeros((8, 16, 3), np.float32), 4)


def test_small_panoramas_are_upsampled_to_the_network_size(rng):
    ldr = rng.integers(0, 256, size=(8, 16, 3), dtype=np.uint8)
    x = network_input(ldr, 32)
    assert x.shape == (7, 32, 64)
    np.testing.assert_allclose(x[:4, ::4, ::4], network_input(ldr, 8)[:4], atol=1e-6)
