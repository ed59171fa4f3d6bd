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


def test_a_registered_per_source_model_file_is_the_one_used(tmp_path, monkeypatch):
    """register_source_model: the shipped file under another label estimates exactly as ``keylight``; a file
    whose trees predict more energy gives more; a bad file or a built-in label is refused, naming it."""
    from safetensors.numpy import save_file

    from panolight_core import estimators
    from panolight_core.estimators import register_source_model, sources

    monkeypatch.setattr(estimators.registry, "_REGISTRY", dict(estimators.registry._REGISTRY))  # the test's labels go with it
    from panolight_core.camera import hdr_to_ldr
    from panolight_core.io.safetensors_np import load_safetensors
    from panolight_core.synthetic import environment

    seed = next(s for s in range(200, 260) if environment(s, 128)[1]["kind"] == "outdoor"
                and not environment(s, 128)[1]["overcast"])
    ldr = hdr_to_ldr(environment(seed, 128)[0], 0.0)
    same = register_source_model("test-shipped-trees", sources.MODEL_PATH)
    a, b = estimate(ldr, 2, "keylight"), estimate(ldr, 2, same)
    np.testing.assert_array_equal(a.coeffs, b.coeffs)
    assert a.info["model"] == b.info["model"] == sources.MODEL_PATH.name
    tensors, meta = load_safetensors(sources.MODEL_PATH)
    tensors["mean.base"] = tensors["mean.base"] + 1.0  # every region's mean log ratio one higher
    brighter = tmp_path / "brighter.safetensors"
    save_file(tensors, str(brighter), metadata=meta)
    c = estimate(ldr, 2, register_source_model("test-brighter-trees", brighter, key_lights=False))
    assert c.info["model"] == "brighter.safetensors" and c.coeffs[0, 0] > a.coeffs[0, 0]
    (tmp_path / "bad.safetensors").write_bytes(b"not a model")
    with pytest.raises(PanoLightError, match="bad.safetensors"):
        register_source_model("test-bad-trees", tmp_path / "bad.safetensors")
    with pytest.raises(PanoLightError, match="cannot name"):
        register_source_model("keylight", sources.MODEL_PATH)
