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


@pytest.mark.parametrize("net", [64, 128])  # 128: the per-source model's own height, its work maps shared
def test_the_sources_guess_is_the_per_source_work_map_the_network_corrects(net):
    from panolight_core import sh
    from panolight_core.camera.resample import area_downsample
    from panolight_core.estimators import sources

    h = 128
    d = np.array([0.4, 0.2, 0.89])
    d /= np.linalg.norm(d)
    t = np.degrees(np.arccos(np.clip(sh.pixel_directions(h, 2 * h) @ d, -1, 1)))
    hdr = 0.1 + 3.0 * np.maximum(t, 0.5)[..., None] ** -2.0 * np.ones(3)  # a sun with glare, clipped inside
    from panolight_core.camera import hdr_to_ldr

    ldr = hdr_to_ldr(hdr, scale=1.0)
    ldr = np.repeat(np.repeat(ldr, 2, axis=0), 2, axis=1)  # 256 rows: both network heights average pixels
    x = network_input(ldr, net, guess="sources")
    lin = srgb_to_linear(x[:3].astype(np.float64))
    a = x[3].astype(np.float64)
    guessed = lin + a * (np.exp(x[4:].astype(np.float64)) - BASE_EXCESS)  # what an untrained network outputs
    rec = sources.recover(ldr)
    assert rec.regions.count >= 1
    want = area_downsample(rec.work, net) if net < rec.work.shape[0] else rec.work
    clipped = a > 0
    np.testing.assert_allclose(np.moveaxis(guessed, 0, -1)[clipped], want[clipped], rtol=1e-4)
    np.testing.assert_allclose(np.moveaxis(guessed, 0, -1)[~clipped], want[~clipped], rtol=1e-4, atol=1e-4)
    assert not np.allclose(x[4:], network_input(ldr, net)[4:])  # not the analytic guess
    with pytest.raises(ValueError, match="guess must be"):
        network_input(ldr, 64, guess="oracle")
