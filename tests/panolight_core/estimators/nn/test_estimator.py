"""The learned estimator at inference: shipped weights, numpy only, clear errors, torch parity."""
import json

import numpy as np
import pytest

from panolight_core import sh
from panolight_core.errors import PanoLightError
from panolight_core.estimators import estimate
from panolight_core.estimators.nn import estimator as E


def test_the_shipped_model_loads_without_torch_and_has_its_card():
    model = E.load_model()
    assert model.config["input_height"] >= 32 and model.config["lmax"] >= 2
    assert E.DEFAULT_WEIGHTS.stat().st_size < 20 * 2 ** 20
    card = E.DEFAULT_WEIGHTS.with_suffix(".md").read_text()
    assert "studio HDRIs" in card and "m-RMSE" in card


def test_neural_estimates_are_finite_any_order_and_hdr_is_projected_exactly(rng):
    ldr = rng.integers(0, 200, size=(128, 256, 3), dtype=np.uint8)
    ldr[20:26, 40:48] = 255
    for lmax in (0, 2, 4):
        est = estimate(ldr, lmax, "neural")
        assert est.coeffs.shape == ((lmax + 1) ** 2, 3) and np.isfinite(est.coeffs).all()
    assert np.isfinite(estimate(ldr[::8, ::8], 2, "neural").coeffs).all()  # 32 x 16: below the network's size
    low, high = estimate(ldr, 2, "neural").coeffs, estimate(ldr, 4, "neural").coeffs
    np.testing.assert_allclose(high[:9], low)  # the encoder's bands, the HDR map's projection above
    hdr = (rng.random((32, 64, 3)) * 3).astype(np.float32)
    np.testing.assert_allclose(estimate(hdr, 2, "neural").coeffs, sh.project(hdr, 2), rtol=1e-6)


def test_bad_weight_files_are_named(tmp_path):
    with pytest.raises(PanoLightError, match="no model weights"):
        E.load_model(tmp_path / "missing.safetensors")
    junk = tmp_path / "junk.safetensors"
    junk.write_bytes(b"\x10\x00\x00\x00\x00\x00\x00\x00{not json}......")
    with pytest.raises(PanoLightError, match="junk.safetensors"):
        E.load_model(junk)
    from panolight_core.io import safetensors_np  # a valid file that is not our network

    header = json.dumps({"w": {"dtype": "F32", "shape": [1], "data_offsets": [0, 4]},
                         "__metadata__": {"config": json.dumps({"input_height": 8})}}).encode()
    other = tmp_path / "other.safetensors"
    other.write_bytes(len(header).to_bytes(8, "little") + header + b"\x00" * 4)
    assert safetensors_np.load_safetensors(other)[0]["w"].shape == (1,)
    with pytest.raises(PanoLightError, match="lacks"):
        E.load_model(other)


def test_extreme_panoramas_give_finite_lighting():
    """All black (log of zero), all clipped (every cell saturated), and one lone clipped pixel."""
    black = np.zeros((64, 128, 3), np.uint8)
    white = np.full((64, 128, 3), 255, np.uint8)
    dot = black.copy()
    dot[10, 20] = 255
    for ldr in (black, white, dot):
        c = estimate(ldr, 2, "neural").coeffs
        assert np.isfinite(c).all()
    assert abs(estimate(black, 2, "neural").coeffs).max() < 1.0  # nothing seen, nothing invented


def _malformed_weights(tmp_path):
    """Issue 23's malformed weight files, made from the shipped model: name -> (path, what the line says)."""
    import struct

    from safetensors.numpy import save_file

    from panolight_core.io.safetensors_np import load_safetensors

    weights, meta = load_safetensors(E.DEFAULT_WEIGHTS)
    made = {}

    def save(name, w, m=meta):
        save_file({k: np.ascontiguousarray(v) for k, v in w.items()}, str(tmp_path / name), metadata=m)
        return tmp_path / name

    bomb = tmp_path / "nested.safetensors"
    header = b"[" * 100000 + b"]" * 100000
    bomb.write_bytes(struct.pack("<Q", len(header)) + header)
    made["nested"] = (bomb, "unreadable header")
    made["missing"] = (save("missing.safetensors", {k: v for k, v in weights.items() if k != "encoder.fc2.weight"}),
                       "lack the tensor 'encoder.fc2.weight'")
    nan = dict(weights)
    nan["ae.dec.0.conv.weight"] = nan["ae.dec.0.conv.weight"].copy()
    nan["ae.dec.0.conv.weight"].flat[3] = np.nan
    made["nan"] = (save("nan.safetensors", nan), "'ae.dec.0.conv.weight' holds NaN or Inf")
    swapped = dict(weights)
    swapped["ae.enc.1.conv.weight"] = np.swapaxes(swapped["ae.enc.1.conv.weight"], 0, 1)
    made["swapped"] = (save("swapped.safetensors", swapped), "do not fit the model config")
    config = json.loads(meta["config"])
    made["huge"] = (save("huge.safetensors", weights, {**meta, "config": json.dumps({**config, "input_height": 100000})}),
                    "impossible input_height 100000")
    return made


def test_malformed_weights_get_one_line_naming_the_file(tmp_path, capsys):
    """Issue 23: RecursionError, KeyError, an error about the radiance map, a conv2d ValueError and an
    out-of-memory hint that named neither the file nor the cause."""
    from panolight_core.apps.cli import main

    for key, (path, said) in _malformed_weights(tmp_path).items():
        E.load_model.cache_clear()
        with pytest.raises(PanoLightError, match=f"^{path}: .*"):
            E.load_model(path)
        assert main(["eval", "--weights", f"{key}={path}", "-q"]) == 1
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and str(path) in err and said in err and "Traceback" not in err, (key, err)
