import numpy as np
import pytest

from panolight_core import sh
from panolight_core.lighting.order import select_order, truncation_errors


def test_constant_light_needs_order_zero():
    c = np.zeros((81, 3))
    c[0] = 1.0
    assert select_order(c)[0] == 0


def test_errors_fall_and_tolerance_decides(rng):
    img = np.full((64, 128, 3), 0.1)
    img[20, 40] = 500.0
    c = sh.project(img, 8)
    errs = truncation_errors(c)
    assert errs[-1] == 0 and all(b <= a + 1e-12 for a, b in zip(errs, errs[1:]))
    assert errs[3] == pytest.approx(errs[2])  # odd bands above 1 carry no irradiance
    lo, _ = select_order(c, 0.05)
    hi, _ = select_order(c, 0.001)
    assert 1 <= lo < hi <= 8
    assert select_order(c, 0.0)[0] == 8
    with pytest.raises(ValueError):
        select_order(c, -1)
