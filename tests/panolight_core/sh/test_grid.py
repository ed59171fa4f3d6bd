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
