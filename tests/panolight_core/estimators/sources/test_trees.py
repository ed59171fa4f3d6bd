"""The tree arrays against a plain walk, and the shipped model file (loads without torch, names bad files)."""
import json

import numpy as np
import pytest

from panolight_core.estimators import sources
from panolight_core.errors import PanoLightError


def _random_ensemble(rng, trees=5, depth=3, features=4):
    feat, thr, left, right, val, roots = [], [], [], [], [], []
    for _ in range(trees):
        base = len(feat)
        roots.append(base)
        n_inner = 2 ** depth - 1
        for i in range(2 ** (depth + 1) - 1):
            if i < n_inner:
                feat.append(int(rng.integers(features))), thr.append(float(rng.normal()))
                left.append(base + 2 * i + 1), right.append(base + 2 * i + 2), val.append(0.0)
            else:
                feat.append(-1), thr.append(0.0), left.append(base + i), right.append(base + i)
                val.append(float(rng.normal()))
    return sources.TreeEnsemble(np.array(feat), np.array(thr), np.array(left), np.array(right), np.array(val),
                                np.array(roots), 0.25)


def test_tree_arrays_against_a_python_walk(rng):
    ens = _random_ensemble(rng)
    x = rng.normal(size=(50, 4))
    ref = []
    for row in x:
        total = ens.base
        for r in ens.roots:
            node = r
            while ens.feature[node] >= 0:
                node = ens.left[node] if row[ens.feature[node]] <= ens.threshold[node] else ens.right[node]
            total += ens.value[node]
        ref.append(total)
    np.testing.assert_allclose(ens.predict(x), ref, rtol=0, atol=1e-12)
    assert ens.predict(np.zeros((0, 4))).shape == (0,)


def test_shipped_model_loads_without_torch_and_names_bad_files(tmp_path):
    model = sources.load_source_model()
    assert model.features == sources.FEATURES and model.path.stat().st_size < 20e6
    with pytest.raises(PanoLightError, match="missing"):
        sources.load_source_model(tmp_path / "gone.safetensors")
    from panolight_core.estimators.nn.safetensors_np import load_safetensors

    tensors, meta = load_safetensors(model.path)
    from safetensors.numpy import save_file

    bad = dict(tensors)
    bad["mean.left"] = bad["mean.left"].copy()
    bad["mean.left"][0] = 10 ** 6
    save_file(bad, str(tmp_path / "bad.safetensors"), metadata=meta)
    with pytest.raises(PanoLightError, match="bad.safetensors: .*out of range"):
        sources.load_source_model(tmp_path / "bad.safetensors")
    other = dict(meta, features=json.dumps(["x"]))
    save_file(tensors, str(tmp_path / "other.safetensors"), metadata=other)
    with pytest.raises(PanoLightError, match="other features"):
        sources.load_source_model(tmp_path / "other.safetensors")
    short = dict(tensors)
    del short["spread.value"]
    save_file(short, str(tmp_path / "short.safetensors"), metadata=meta)
    with pytest.raises(PanoLightError, match="missing tensor"):
        sources.load_source_model(tmp_path / "short.safetensors")
