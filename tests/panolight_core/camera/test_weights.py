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


def test_weighted_median_against_a_plain_reference():
    """Each column's smallest value with half its weight at or below it, against a loop over sorted values; equal
    weights give the lower median."""
    from panolight_core.camera.weights import weighted_median

    rng = np.random.default_rng(2)
    values, weights = rng.uniform(0, 10, (7, 50)), rng.uniform(0, 1, (7, 50))
    weights[:, 0] = 0.0
    weights[3, 0] = 1.0  # one frame holds all the weight
    got = weighted_median(values, weights)
    for k in range(values.shape[1]):
        order = np.argsort(values[:, k])
        cum = np.cumsum(weights[order, k])
        assert got[k] == values[order, k][np.searchsorted(cum, 0.5 * cum[-1])]
    assert got[0] == values[3, 0]
    assert weighted_median(np.array([[1.0], [2.0], [3.0], [4.0]]), np.ones((4, 1)))[0] == 2.0


def test_outlying_frames_drop_one_frame_s_odd_reading_never_the_reference_s():
    """Four frames read one pixel well exposed: three agree, one reads 8x; that one is dropped. Where the odd one is
    the reference, nothing is (what moved is the reference's). A pixel whose readings agree is not looked at."""
    from panolight_core.camera.weights import outlying_frames, sure_readings

    table = SRGB.table
    rel = np.array([0.25, 1.0, 4.0, 16.0])
    radiance = [(table / np.float32(k)).astype(np.float32) for k in rel]
    level = 0.01  # in the reference's units: codes 60 (0.25x)... well exposed in all four
    codes = [np.searchsorted(table, level * k) for k in rel]
    top = [np.array([[c, c]], np.uint8) for c in codes]
    top[0][0, 0] = np.searchsorted(table, 8 * level * rel[0])  # frame 0 reads 8x at the first pixel
    weight = noise_weights(table)
    tables = [sure_readings(r, sure_codes(table), np.tile(weight, 256)) for r in radiance]  # no ghost test here

    def outliers():
        index = [(top[1].astype(np.uint16) << 8) | t for t in top]
        return outlying_frames([t[i] for t, i in zip(tables, index)], [weight[t] for t in top], ref=1)

    dropped = outliers()
    assert dropped[0] is not None and dropped[0].tolist() == [[True, False]]
    assert all(d is None for d in dropped[1:])
    top[1][0, 0] = np.searchsorted(table, 8 * level)  # now the reference is the odd one
    top[0][0, 0] = codes[0]
    dropped = outliers()
    assert dropped is None or all(d is None or not d[0, 0] for d in dropped)


def test_sure_readings_trust_a_weighed_well_exposed_code_only_and_an_untrusted_reading_is_never_dropped():
    """The outlier test's table holds a frame's radiance at a sure code its weight table weighs, NaN at a code out of
    GHOST_CODES or one the ghost test zeroed; a wild reading held as NaN does not count, so nothing is dropped."""
    from panolight_core.camera.weights import outlying_frames, sure_readings

    table = SRGB.table
    level = (table / np.float32(4.0)).astype(np.float32)
    weight = np.tile(noise_weights(table), 256)
    weight[128 * 256 + 100] = 0.0  # the ghost test zeroed (reference code 128, own code 100)
    got = sure_readings(level, sure_codes(table), weight).reshape(256, 256)
    assert got[128, 100] != got[128, 100]  # NaN
    assert got[128, 101] == level[101] and got[7, 101] == level[101]
    assert np.isnan(got[:, 5]).all() and np.isnan(got[:, CLIPPED_CODE]).all()
    a = np.array([[0.01, 0.01]], np.float32)
    wild = np.array([[np.nan, 0.08]], np.float32)  # the first pixel's wild reading untrusted, the second's trusted
    dropped = outlying_frames([a, a.copy(), wild], [np.ones((1, 2), np.float32)] * 3, ref=1)
    assert dropped[2] is not None and dropped[2].tolist() == [[False, True]]
    assert dropped[0] is None and dropped[1] is None
