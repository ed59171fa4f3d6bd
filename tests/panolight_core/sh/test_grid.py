import numpy as np
import pytest

from panolight_core import sh


@pytest.mark.parametrize("shape", [(4, 8), (64, 128), (1024, 2048)])
def test_directions_at_equals_the_pixel_directions_grid(shape):
    h, w = shape
    rng = np.random.default_rng(0)
    rows, cols = rng.integers(0, h, 5000), rng.integers(0, w, 5000)  # more indices than rows + cols: tables
    want = sh.grid.pixel_directions(h, w)[rows, cols]
    np.testing.assert_array_equal(sh.grid.directions_at(rows, cols, h, w), want)
    np.testing.assert_array_equal(sh.grid.directions_at(rows[:3], cols[:3], h, w), want[:3])  # direct path
    # fractional positions (between pixel centres) use the formula
    d = sh.grid.directions_at(np.array([h / 2 - 0.5]), np.array([w / 2 - 0.5]), h, w)
    np.testing.assert_allclose(d, [[1.0, 0.0, 0.0]], atol=1e-12)  # the image centre looks along +X
    np.testing.assert_allclose(np.linalg.norm(sh.grid.directions_at(rows, cols, h, w), axis=-1), 1.0, atol=1e-15)


def test_pixel_coordinates_invert_directions_at():
    from panolight_core.sh import grid

    h, w = 37, 74
    y, x = grid.pixel_coordinates(grid.pixel_directions(h, w), h, w)
    np.testing.assert_allclose(y, np.broadcast_to(np.arange(h)[:, None], (h, w)), atol=1e-9)
    np.testing.assert_allclose(x, np.broadcast_to(np.arange(w)[None, :], (h, w)), atol=1e-9)
    rows, cols = np.array([0.25, 10.7, 36.0]), np.array([0.0, 33.3, 73.4])
    y, x = grid.pixel_coordinates(grid.directions_at(rows, cols, h, w), h, w)
    np.testing.assert_allclose(y, rows, atol=1e-9)
    np.testing.assert_allclose(x, cols, atol=1e-9)
    assert grid.pixel_at(grid.directions_at(5, 70, h, w), h, w) == (5, 70)


def test_elevation_deg_against_the_pixel_rows():
    # every pixel centre's elevation is 90 - its row's polar angle (CONVENTIONS.md), whatever the length
    h, w = 16, 32
    d = sh.pixel_directions(h, w)
    theta = np.degrees(np.pi * (np.arange(h) + 0.5) / h)
    for y in (0, 5, 8, 15):
        for x in (0, 7, 31):
            assert sh.elevation_deg(d[y, x]) == pytest.approx(90.0 - theta[y], abs=1e-9)
            assert sh.elevation_deg(3.5 * d[y, x]) == pytest.approx(90.0 - theta[y], abs=1e-9)
    assert sh.elevation_deg((0.0, 0.0, 2.0)) == 90.0 and sh.elevation_deg((0.0, 0.0, -1e-300)) == -90.0
    assert sh.elevation_deg((1.0, 0.0, 0.0)) == 0.0 and sh.elevation_deg((0.0, 0.0, 0.0)) == 0.0
