"""camera.weights: what a bracket frame's code counts for in the merge."""
import numpy as np
import pytest

from panolight_core.camera.response import SRGB
from panolight_core.camera.weights import CLIPPED_CODE, hat, noise_weights, sure_codes


def test_the_hat_weighs_mid_tones_most_and_clipped_codes_not_at_all():
    w = hat(np.array([0, 1, 127, 128, 200, 249, 250, 255], np.uint8))
    assert w[0] > 0 and w[2] == w.max() and w[-1] == w[-2] == 0 and w[5] > 0  # a JPEG's clipped sun: 250-255


def test_the_noise_weight_trusts_a_code_as_its_curve_reads_it():
    """A code's weight is the hat over its log-radiance noise: in sRGB's toe a code of 10 reads a wide range of light
    and weighs far less than mid-grey; the top stays the hat's (nothing at CLIPPED_CODE). A film curve's fog (a steep
    toe at codes 17-21, as Debevec's memorial set) is no well-exposed code for the ghost test, sRGB's codes from 20
    up are."""
    w = noise_weights(SRGB.table)
    assert w.max() == pytest.approx(1.0) and w[CLIPPED_CODE:].max() == 0.0
    assert w[10] < 0.01 * w[160] and w[60] < w[120] < w[180]
    assert np.flatnonzero(sure_codes(SRGB.table))[[0, -1]].tolist() == [20, 235]
    film = SRGB.table.astype(np.float64).copy()
    film[:22] = film[22] * 1.4 ** (np.arange(22) - 22.0)  # each code of the fog 1.4x the last
    assert not sure_codes(film)[20] and sure_codes(film)[40]
