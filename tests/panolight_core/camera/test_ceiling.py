import math

import numpy as np
import pytest

from panolight_core import sh
from panolight_core.camera.ceiling import CEILING_TOL, MIN_HEADROOM, find_ceiling, pointed_ceiling
from panolight_core.packed import PackedImage, RowFile


def _sky_with_sun(h=128, sun_radiance=5e4):
    """A smooth sky (0.2-1.2) with a one-degree sun: an un-clipped HDR whose peak is one pixel's."""
    d = sh.pixel_directions(h, 2 * h)
    s = np.array([0.6, 0.3, 0.74])
    s /= np.linalg.norm(s)
    img = (0.2 + np.maximum(d[..., 2], 0.0))[..., None] * np.array([0.7, 0.85, 1.0])
    ang = np.degrees(np.arccos(np.clip(d @ s, -1.0, 1.0)))
    img = img + (sun_radiance * np.exp(-(ang / 1.0) ** 2))[..., None]
    return img.astype(np.float32), s


def test_a_peaked_sun_is_no_plateau_and_the_same_sun_clipped_is_one():
    img, _ = _sky_with_sun()
    assert find_ceiling(img) is None  # one brightest pixel: a real sun, left alone
    clipped = np.minimum(img, np.float32(100.0))
    c = find_ceiling(clipped)
    assert c is not None and c.rgb == pytest.approx((100.0, 100.0, 100.0))
    plateau = (clipped >= 100.0 * (1 - CEILING_TOL)).sum(axis=-1) >= 2  # at the ceiling to its last bits
    assert c.pixels == int(plateau.sum()) >= 3
    assert c.solid_angle == pytest.approx(float(sh.pixel_solid_angles(*plateau.shape)[plateau].sum()), rel=1e-9)
    assert c.level == 100.0 and c.headroom > MIN_HEADROOM
    assert c.describe()["plateau_pixels"] == c.pixels


def test_a_warm_sun_clipped_in_two_channels_is_a_plateau_one_channel_alone_is_not():
    img, _ = _sky_with_sun()
    img *= np.array([1.0, 0.8, 0.3], np.float32)  # blue stays under the ceiling
    two = np.minimum(img, np.float32(200.0))
    assert find_ceiling(two) is not None
    one = img.copy()
    one[..., 0] = np.minimum(one[..., 0], 300.0)  # only red ties: a coloured lamp's channel, not a clipped source
    one[..., 1] = img[..., 1]
    assert find_ceiling(one) is None


def test_an_artist_s_pointer_declares_the_plateau_a_resampled_file_lost():
    """A clipped sun whose ties are gone (each value times 1 +- 0.1 %, as resampling leaves it) is no plateau
    ``find_ceiling`` can find; the artist's pointer, a degree off it, declares one at half the patch's peak: the
    bump's top and nothing else, every channel's ceiling half the peak pixel's. A pointer at plain sky, or at the
    same sun un-clipped (a peak, not a bump), declares nothing, and says why."""
    img, s = _sky_with_sun()
    rng = np.random.default_rng(3)
    untied = (np.minimum(img, np.float32(100.0)) * (1 + 1e-3 * rng.uniform(-1, 1, img.shape))).astype(np.float32)
    assert find_ceiling(untied) is None
    side = np.cross(s, [0.0, 0.0, 1.0])
    click = math.cos(math.radians(1.0)) * s + math.sin(math.radians(1.0)) * side / np.linalg.norm(side)
    c, why = pointed_ceiling(untied, click)
    lum = untied @ np.array([0.2126, 0.7152, 0.0722], np.float32)
    peak = untied.reshape(-1, 3)[int(np.argmax(lum))]
    assert c is not None and c.rgb == pytest.approx(tuple(0.5 * peak), rel=1e-6) and c.declared == why
    top = (untied >= 0.5 * peak * (1 - CEILING_TOL)).sum(axis=-1) >= 2
    assert c.pixels == int(top.sum()) >= (untied >= 99.0).all(axis=-1).sum()  # the whole clipped disk, at least
    assert "half" not in why and "0.5 of its peak" in why and c.describe()["declared"] == why
    nothing, reason = pointed_ceiling(untied, -s)  # the sky opposite the sun
    assert nothing is None and reason.startswith("there is no bright patch within 10 deg")
    assert pointed_ceiling(PackedImage(untied, "half"), click)[0].pixels == c.pixels  # read by rows alike
    peaked, reason = pointed_ceiling(img, click)  # the same sun un-clipped: a peak the file holds whole
    assert peaked is None and "a source the file holds whole" in reason


def test_flat_and_black_images_have_no_ceiling():
    assert find_ceiling(np.full((32, 64, 3), 0.5, np.float32)) is None  # every pixel at the top, but no headroom
    assert find_ceiling(np.zeros((32, 64, 3), np.float32)) is None
    grey = np.zeros((32, 64, 3), np.float32)
    grey[..., 1] = 1.0  # one channel: no two channels can sit at a ceiling
    assert find_ceiling(grey) is None


def test_a_large_image_read_by_rows_finds_the_same_ceiling():
    img, _ = _sky_with_sun(h=600)
    clipped = np.minimum(img, np.float32(50.0))
    packed = PackedImage(RowFile(lambda r0, r1: clipped[r0:r1], *clipped.shape[:2]), "file")
    assert find_ceiling(packed) == find_ceiling(clipped)
    assert math.isfinite(find_ceiling(clipped).headroom)


@pytest.mark.parametrize("width", [1, 2, 7, 64, 1025])
def test_each_row_s_largest_value_per_channel_is_numpy_s(width):
    from panolight_core.camera.ceiling import row_channel_max

    block = np.random.default_rng(width).normal(size=(5, width, 3)).astype(np.float32)
    assert np.array_equal(row_channel_max(block), block.max(axis=1))
