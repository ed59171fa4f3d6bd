import numpy as np
import pytest

from panolight_core import sh
from panolight_core.camera.resample import area_downsample, sample_equirect
from tests.conftest import random_directions


def test_sampling_at_pixel_centres_returns_the_pixels(rng):
    img = rng.random((8, 16, 3))
    dirs = sh.pixel_directions(8, 16)
    np.testing.assert_allclose(sample_equirect(img, dirs), img, atol=1e-12)


def test_sampling_a_smooth_map_matches_the_function_it_holds(rng):
    coeffs = rng.normal(size=(9, 3))
    img = sh.reconstruct(coeffs, 256, 512)
    dirs = random_directions(rng, 2000)
    exact = sh.basis(dirs, 2) @ coeffs
    got = sample_equirect(img, dirs)
    assert np.abs(got - exact).max() < 5e-3 * np.abs(exact).max()  # bilinear; worst half a row from a pole


def test_columns_wrap_across_the_seam_and_rows_clamp_at_the_poles():
    img = np.zeros((4, 8, 1))
    img[:, 0] = 1.0  # the left column (looking towards -X, just left of the seam)
    img[:, -1] = 3.0  # the right column
    seam = sample_equirect(img, np.array([[-1.0, 0.0, 0.0]]))  # -X: the edge between them
    assert np.isclose(seam[0, 0], 2.0)
    assert np.isfinite(sample_equirect(img, np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]]))).all()


def test_area_downsample_keeps_the_mean(rng):
    img = rng.random((64, 128, 3))
    small = area_downsample(img, 16)
    assert small.shape == (16, 32, 3) and np.allclose(small.mean(axis=(0, 1)), img.mean(axis=(0, 1)))


def test_the_lut_mean_is_area_downsample_of_the_lut_image_to_the_bit(rng):
    from panolight_core.camera.color import SRGB8_TO_LINEAR
    from panolight_core.camera.resample import area_mean_lut

    for shape, height in (((256, 512, 3), 64), ((96, 192, 3), 32), ((100, 200, 3), 32), ((64, 128, 3), 64)):
        img = rng.integers(0, 256, shape, dtype=np.uint8)
        want = area_downsample(SRGB8_TO_LINEAR[img], height)
        assert np.array_equal(area_mean_lut(img, height, SRGB8_TO_LINEAR), want), shape


def test_sizes_that_are_not_whole_multiples_are_downsampled_by_slabs_with_the_same_numbers():
    """Issue 23: a 16000 x 8000 photo (31.25 input rows per work-map row) went through a whole-image
    float64 copy (5.4 GB); slabs of rows give the same numbers with a small fraction of that memory."""
    import tracemalloc

    from panolight_core.camera.color import SRGB8_TO_LINEAR
    from panolight_core.camera.resample import area_downsample_rows, area_mean_lut

    rng = np.random.default_rng(4)
    img = rng.integers(0, 256, (3000, 6000, 3), dtype=np.uint8)
    # the whole-image reference, written out: block means over rounded boundaries (46.9 rows per output row)
    ys, xs = np.linspace(0, 3000, 65).astype(int), np.linspace(0, 6000, 129).astype(int)
    rows = np.add.reduceat(SRGB8_TO_LINEAR[img].astype(np.float64), ys[:-1], axis=0) / np.diff(ys)[:, None, None]
    whole = np.add.reduceat(rows, xs[:-1], axis=1) / np.diff(xs)[None, :, None]
    del rows
    tracemalloc.start()
    got = area_mean_lut(img, 64, SRGB8_TO_LINEAR)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    np.testing.assert_array_equal(got, whole)
    assert peak < img.size * 8 / 4  # a whole-image float64 copy alone is img.size * 8 bytes (432 MB)
    small = img[:500, :1000]
    ys, xs = np.linspace(0, 500, 65).astype(int), np.linspace(0, 1000, 129).astype(int)
    ref = np.add.reduceat(np.add.reduceat(small * 2.0, ys[:-1], axis=0) / np.diff(ys)[:, None, None], xs[:-1],
                          axis=1) / np.diff(xs)[None, :, None]
    np.testing.assert_array_equal(area_downsample_rows(small, 64, lambda b: b * 2.0), ref)
    np.testing.assert_array_equal(area_downsample(small * 2.0, 64), ref)


def test_clipped_fractions_count_the_clipped_mask_on_both_paths(rng):
    from panolight_core.camera import clipped_mask
    from panolight_core.camera.resample import clipped_fractions

    ldr = rng.choice(np.array([0, 200, 253, 254, 255], dtype=np.uint8), size=(64, 128, 3))
    masks = np.stack([clipped_mask(ldr), clipped_mask(ldr, all_channels=True)], -1).astype(np.float64)
    whole = clipped_fractions(ldr, 16)  # whole-number factors: counted by row blocks
    np.testing.assert_allclose(whole, masks.reshape(16, 4, 32, 4, 2).mean(axis=(1, 3)), atol=1e-12)
    odd = clipped_fractions(ldr[:60, :120], 16)  # other sizes: the masks area-averaged
    np.testing.assert_allclose(odd, area_downsample(masks[:60, :120], 16), atol=1e-6)
    assert 0 < whole[..., 1].max() and (whole[..., 1] <= whole[..., 0]).all() and (whole[..., 1] < whole[..., 0]).any()


def test_above_the_reference_resolution_a_lone_clipped_pixel_makes_no_clipped_fraction(rng):
    from panolight_core.camera.resample import CLIP_REFERENCE_HEIGHT, clipped_fractions, reference_clipped

    f = 4  # an 8K-like panorama: 4 x 4 pixels per reference pixel
    H = f * CLIP_REFERENCE_HEIGHT
    ldr = np.full((H, 2 * H, 3), 188, np.uint8)  # a grey wall
    ys, xs = rng.integers(0, H, 40) // f * f, rng.integers(0, 2 * H, 40) // f * f
    ldr[ys, xs] = 255  # lone clipped pixels: 1/16 of a reference pixel each
    ldr[ys, xs + 1] = 255  # two side by side: still under a quarter
    ldr[600:632, 1800:1832] = 255  # a lamp: 8 x 8 whole reference pixels
    frac = clipped_fractions(ldr, 128)
    assert frac[..., 0].sum() * 16 == pytest.approx(64.0)  # the lamp's reference pixels alone (16 per work cell)
    assert frac[608 // 16, 1808 // 16, 1] == 1.0  # a work cell inside it
    # a camera of the reference resolution sees the lamp alone: the same fractions
    small = np.full((CLIP_REFERENCE_HEIGHT, 2 * CLIP_REFERENCE_HEIGHT, 3), 188, np.uint8)
    small[150:158, 450:458] = 255
    np.testing.assert_array_equal(clipped_fractions(small, 128), frac)
    assert reference_clipped(small) is None  # no taller than the reference: its own pixels count
    assert reference_clipped(ldr[::2, ::2]) is None  # twice as tall: one pixel is a quarter, each counts as it is
    # a quarter of a reference pixel clipped counts, as a camera at that resolution would clip it (4x the clip)
    ldr[0:2, 0:2] = 255
    assert reference_clipped(ldr)[0, 0].all()
