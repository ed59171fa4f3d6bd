import numpy as np
import pytest

from panolight_core import sh
from panolight_core.errors import PanoLightError
from panolight_core.estimators import available, estimate, resolve


def test_registry_and_resolution(monkeypatch, tmp_path):
    from panolight_core.estimators.nn import estimator as nn_estimator

    assert available()[:3] == ("ambient", "naive", "analytic")
    assert resolve("auto") in available()
    monkeypatch.setattr(nn_estimator, "DEFAULT_WEIGHTS", tmp_path / "gone.safetensors")
    assert "neural" not in available()
    with pytest.raises(PanoLightError, match="weights are missing"):
        resolve("neural")
    with pytest.raises(PanoLightError, match="unknown estimator 'magic'"):
        estimate(np.zeros((4, 8, 3), np.uint8), 2, "magic")
    with pytest.raises(PanoLightError, match=r"\(H, W, 3\)"):
        estimate(np.zeros((4, 8), np.uint8), 2)


def test_hdr_goes_straight_to_the_projection(rng):
    hdr = (rng.random((32, 64, 3)) * 5).astype(np.float32)
    for name in ("analytic", "naive"):
        est = estimate(hdr, 3, name)
        np.testing.assert_allclose(est.coeffs, sh.project(hdr, 3), rtol=1e-6)
        assert est.info["name"] == name and est.info["estimate_s"] >= 0
    amb = estimate(hdr, 3, "ambient").coeffs
    assert np.all(amb[1:] == 0) and amb[0, 0] == pytest.approx(sh.project(hdr, 3)[0, 0], rel=1e-6)
