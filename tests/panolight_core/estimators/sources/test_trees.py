"""The tree arrays against a plain walk, and the shipped model file (loads without torch, names bad files)."""
import json

import numpy as np
import pytest

from panolight_core.errors import PanoLightError
from panolight_core.estimators import sources


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
    from panolight_core.io.safetensors_np import load_safetensors

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
    with pytest.raises(PanoLightError, match="other.safetensors: .*does not compute \\(x\\)"):
        sources.load_source_model(tmp_path / "other.safetensors")
    short = dict(tensors)
    del short["spread.value"]
    save_file(short, str(tmp_path / "short.safetensors"), metadata=meta)
    with pytest.raises(PanoLightError, match="missing tensor"):
        sources.load_source_model(tmp_path / "short.safetensors")


def test_a_model_reads_the_columns_it_was_trained_on_by_name(rng, tmp_path):
    """A model trained on some of FEATURES, in any order, is given those columns of the full feature rows."""
    from safetensors.numpy import save_file

    names = (sources.FEATURES[5], sources.FEATURES[0], sources.FEATURES[-1], sources.FEATURES[9])
    mean, spread = _random_ensemble(rng), _random_ensemble(rng)
    save_file({**sources.ensemble_arrays("mean", mean), **sources.ensemble_arrays("spread", spread)},
              str(tmp_path / "four.safetensors"), metadata={"features": json.dumps(list(names)), "shrink": "0.5"})
    model = sources.load_source_model(tmp_path / "four.safetensors")
    assert model.features == names
    full = rng.normal(size=(30, len(sources.FEATURES)))
    mu, sigma, _ = model.predict(full)
    np.testing.assert_allclose(mu, mean.predict(full[:, [sources.FEATURES.index(n) for n in names]]), rtol=0, atol=1e-12)
    assert not np.allclose(mu, mean.predict(full[:, :4]))  # by name, not by position
    # a tree that asks for a fifth column of a four-column model is refused
    bad = dict(sources.ensemble_arrays("mean", mean), **sources.ensemble_arrays("spread", spread))
    bad["mean.feature"] = np.where(bad["mean.feature"] >= 0, 4, -1).astype(np.int32)
    save_file(bad, str(tmp_path / "five.safetensors"), metadata={"features": json.dumps(list(names)), "shrink": "0.5"})
    with pytest.raises(PanoLightError, match="out of range"):
        sources.load_source_model(tmp_path / "five.safetensors")
