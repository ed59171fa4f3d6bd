"""The learned estimator's input: area-averaged colour and clipped fraction."""
import numpy as np
import pytest

from panolight_core.color import srgb_to_linear
from panolight_core.nn.inputs import network_input


def test_colour_is_the_linear_area_mean_and_the_fourth_channel_the_clipped_fraction(rng):
    ldr = rng.integers(0, 240, size=(32, 64, 3), dtype=np.uint8)
    ldr[0:4, 0:2] = 255  # 8 clipped pixels in the first 4 x 4 cell
    x = network_input(ldr, 8)
    assert x.shape == (4, 8, 16) and x.dtype == np.float32
    assert x[3, 0, 0] == pytest.approx(8 / 16) and x[3, 1:].max() == 0 and x[3, 0, 1:].max() == 0
    lin = srgb_to_linear(ldr.astype(np.float64) / 255.0)
    np.testing.assert_allclose(srgb_to_linear(x[:3, 2, 3].astype(np.float64)),
                               lin[8:12, 12:16].reshape(-1, 3).mean(0), rtol=1e-4, atol=1e-6)


def test_wrong_pixels_are_refused():
    with pytest.raises(ValueError, match="uint8"):
        network_input(np.zeros((8, 16, 3), np.float32), 4)
