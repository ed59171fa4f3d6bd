"""hdr.exr: the full-resolution HDR panorama agrees with the work map and the lighting model."""
import warnings

import numpy as np
import pytest

from panolight_core import sh
from panolight_core.camera import hdr_to_ldr
from panolight_core.camera.resample import area_downsample
from panolight_core.data import load_studio_hdri
from panolight_core.pipeline import fit_pixels
from panolight_core.pipeline.hdri import hdr_panorama


@pytest.fixture(scope="module")
def city_ldr():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return hdr_to_ldr(load_studio_hdri("city"), 0.0, 90)


def test_analytic_cell_means_equal_its_work_map(city_ldr):
    _, est = fit_pixels(city_ldr, estimator="analytic")
    hdr = hdr_panorama(city_ldr, est)
    assert hdr.shape == city_ldr.shape and hdr.dtype == np.float32 and np.all(np.isfinite(hdr))
    np.testing.assert_allclose(area_downsample(hdr, est.radiance.shape[0]), est.radiance, rtol=1e-5, atol=1e-6)


def test_region_energy_is_exact_and_shaped_like_a_sun(city_ldr):
    _, est = fit_pixels(city_ldr)
    rec = est.recovery
    hdr = hdr_panorama(city_ldr, est).astype(np.float64)
    lum = np.array([0.2126, 0.7152, 0.0722])
    full_sr = sh.pixel_solid_angles(*hdr.shape[:2])
    h, w = rec.frac.shape
    labels_full = np.repeat(np.repeat(rec.regions.labels, hdr.shape[0] // h, 0), hdr.shape[1] // w, 1)
    inside = labels_full == 0
    got = float(((hdr @ lum) * full_sr)[inside].sum())
    want = float(((rec.work @ lum) * sh.pixel_solid_angles(h, w))[rec.regions.labels == 0].sum())
    assert got == pytest.approx(want, rel=1e-4)


def test_a_compact_source_with_glare_is_filled_like_a_sun():
    h = 256
    d = np.array([0.5, -0.3, 0.81])
    d /= np.linalg.norm(d)
    t = np.degrees(np.arccos(np.clip(sh.pixel_directions(h, 2 * h) @ d, -1, 1)))
    hdr = 0.05 + 2.0 * np.maximum(t, 0.3)[..., None] ** -2.5 * np.ones(3)  # a sun's aureole, clipped inside ~1.3 deg
    ldr = hdr_to_ldr(hdr, scale=1.0)
    _, est = fit_pixels(ldr)
    assert est.recovery.regions.shape_exponents()[0] > 1.0
    out = hdr_panorama(ldr, est)
    lum = out @ np.array([0.2126, 0.7152, 0.0722], np.float32)
    iy, ix = np.unravel_index(np.argmax(lum), lum.shape)
    assert np.degrees(np.arccos(np.clip(sh.grid.directions_at(iy, ix, h, 2 * h) @ d, -1, 1))) < 1.5
    clipped = (ldr >= 254).all(-1)
    assert lum[clipped].max() > 2.0 * lum[clipped].mean()  # peaked at the centre, not an even fill


def test_sh_of_hdri_equals_the_lighting_model_within_truncation(city_ldr):
    fitted, est = fit_pixels(city_ldr)
    p = sh.project(hdr_panorama(city_ldr, est), 2)
    q = fitted.project(2)
    assert np.abs(p - q).max() <= 2e-3 * np.abs(q).max()  # the lights are disks, the HDRI's sources are not


def test_hdr_input_is_its_own_hdri():
    px = np.random.default_rng(0).random((8, 16, 3)).astype(np.float32)
    _, est = fit_pixels(px)
    np.testing.assert_array_equal(hdr_panorama(px, est), px)


def test_block_wise_hdri_is_the_whole_image_fill_even_when_blocks_split_work_cells(city_ldr, monkeypatch):
    from panolight_core.camera import clipped_mask, ldr_to_linear, resample
    from panolight_core.estimators.sources import fill_full_resolution
    from panolight_core.pipeline.hdri import assemble, hdr_blocks

    ldr = city_ldr[:300, :600]  # 300 rows over a 128-row work map: cells do not align with blocks
    _, est = fit_pixels(ldr)
    rec = est.recovery
    whole = fill_full_resolution(ldr_to_linear(ldr), clipped_mask(ldr, all_channels=True),
                                 np.maximum(rec.diffuse - rec.base, 0.0), rec.regions.centre,
                                 rec.regions.shape_exponents(), rec.regions.labels, rec.key_points())
    monkeypatch.setattr(resample, "BLOCK_PIXELS", 600 * 7)  # 7-row blocks
    blocks = list(hdr_blocks(ldr, est))
    assert len(blocks) > 40 and whole.max() > 1.0  # many blocks, and energy was filled in
    np.testing.assert_array_equal(assemble(ldr.shape, blocks), whole)


def test_the_peak_bounds_every_value_before_the_first_block(city_ldr):
    from panolight_core.pipeline.hdri import HdrRows, assemble

    for ldr, estimator in ((city_ldr, "sources"), (city_ldr, "analytic"),
                           (np.random.default_rng(0).random((8, 16, 3)).astype(np.float32), "sources")):
        _, est = fit_pixels(ldr, estimator=estimator)
        for scale in (1.0, 8.0):
            rows = HdrRows(ldr, est, scale)
            top = float(assemble(ldr.shape, rows).max())
            assert top <= rows.peak <= top + scale * 1.0 + 1e-6, (estimator, scale)  # a bound, and a close one


def test_half_floats_only_for_8_bit_inputs_whose_range_fits(city_ldr):
    from panolight_core.io.images import HALF_MAX
    from panolight_core.pipeline.hdri import HdrRows

    _, est = fit_pixels(city_ldr)
    peak = HdrRows(city_ldr, est).peak  # set by the sun light's splat (at scale 1 it can pass 65504)
    assert HdrRows(city_ldr, est, 0.5 * HALF_MAX / peak).fits_half()
    assert not HdrRows(city_ldr, est, 2.0 * HALF_MAX / peak).fits_half()  # its peak would overflow half floats
    assert not HdrRows(city_ldr, est, 2.0 ** -5).fits_half()  # its darkest steps would be subnormal
    hdr = city_ldr.astype(np.float32) / 255
    assert not HdrRows(hdr, fit_pixels(hdr)[1]).fits_half()  # a float input keeps float32


def test_a_lone_clipped_pixel_of_a_large_panorama_is_no_firefly(rng):
    """8K-like: 4 x 4 pixels per pixel of the training panoramas' grid (CLIP_REFERENCE_HEIGHT). Lone clipped
    pixels of a bright wall, under a quarter of such a pixel, get nothing in hdr.exr; the lamp keeps its fill."""
    from panolight_core.camera.resample import CLIP_REFERENCE_HEIGHT

    H = 4 * CLIP_REFERENCE_HEIGHT
    ldr = np.full((H, 2 * H, 3), 200, np.uint8)
    ys, xs = rng.integers(H // 4, 3 * H // 4, 200) // 4 * 4, rng.integers(0, 2 * H, 200) // 4 * 4
    ldr[ys, xs] = 255  # specks of a sunlit wall
    yy, xx = np.mgrid[:H, :2 * H]
    r = np.hypot(yy - 500, xx - 1500)  # a lamp at 44 deg up: clipped core, glare falling off around it
    ldr[r < 60] = 255
    ring = (r >= 60) & (r < 200)
    ldr[ring] = np.clip(255 * (r[ring] / 60.0) ** -0.6, 200, 254).astype(np.uint8)[:, None]
    _, est = fit_pixels(ldr)
    hdr = hdr_panorama(ldr, est)
    specks = r[ys, xs] > 300
    assert specks.sum() > 150
    np.testing.assert_array_equal(hdr[ys[specks], xs[specks]], 1.0)  # as shot: the clip level, no more
    assert float(hdr[r < 50].mean()) > 2.0  # the lamp's core holds its recovered energy


@pytest.mark.parametrize("direction", [(0.3, -0.2, 0.93), (-1.0, 0.0, 0.0), (0.0, 0.0, 1.0), (0.05, 0.0, -0.999)])
def test_peak_beside_a_light_is_the_brightest_pixel_outside_its_cone(direction):
    """PeakBeside passes the blocks through unchanged and finds the brightest luminance farther than the radius from
    the light (a light on the seam, at a pole and below the horizon too), against every pixel's direction in float64;
    NaN is passed over."""
    from panolight_core.camera.color import LUMINANCE_WEIGHTS
    from panolight_core.pipeline.hdri import PeakBeside

    h, w = 64, 128
    d = sh.pixel_directions(h, w)
    key = np.asarray(direction) / np.linalg.norm(direction)
    rng = np.random.default_rng(3)
    img = rng.uniform(0.0, 1.0, (h, w, 3)).astype(np.float32)
    near = d @ key > np.cos(np.radians(5.0))
    img[near] = 500.0  # the light, and a pixel just beside it a little less bright
    beside = np.argmax(np.where(near, -2.0, d @ key))
    img.reshape(-1, 3)[beside] = 40.0
    img[3, 7] = np.nan
    blocks = [(r0, img[r0:r0 + 10]) for r0 in range(0, h, 10)]
    tap = PeakBeside(iter(blocks), (h, w), key, np.radians(5.0))
    passed = list(tap)
    assert [r for r, _ in passed] == [r for r, _ in blocks] and all(a is b for (_, a), (_, b) in zip(passed, blocks))
    lum = np.where(np.isfinite(img @ LUMINANCE_WEIGHTS), img @ LUMINANCE_WEIGHTS, 0.0)
    assert tap.peak == pytest.approx(float(lum[~near].max()), rel=1e-6) and tap.peak == pytest.approx(40.0, rel=1e-6)
