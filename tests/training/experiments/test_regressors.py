"""training.experiments.regressors: out-of-fold by scene, networks held to their training range, the scores."""
import numpy as np
import pytest

pytest.importorskip("torch")
pytest.importorskip("sklearn")

from panolight_core.estimators import sources  # noqa: E402
from training.common.folds import scene_folds  # noqa: E402
from training.experiments import regressors  # noqa: E402
from training.source_energy.fit import fit_mean  # noqa: E402


def _rows(scenes=10, per_scene=40, seed=0):
    rng = np.random.default_rng(seed)
    scene = np.repeat(np.arange(scenes), per_scene)
    X = rng.normal(size=(scene.size, 4))
    return X, scene, rng


def test_a_scene_is_never_predicted_by_a_model_that_saw_it():
    """Targets that are a per-scene secret, with the scene's own code as a feature: a model that had seen a row's
    scene would recall its offset; out of fold none can, so the error stays about the offsets' spread."""
    X, scene, rng = _rows()
    offset = rng.normal(0.0, 2.0, 10)
    X[:, 0] = rng.normal(size=10)[scene]  # a code unique to each scene
    y = offset[scene]
    w = np.ones_like(y)
    pred = regressors.out_of_fold(X, y, w, scene, scene_folds(10, 5), networks=1, log=lambda *_: None)
    spread = float(np.sqrt(np.mean((y - y.mean()) ** 2)))
    for name in ("trees", "networks", "average"):
        rms = float(np.sqrt(np.mean((pred[name] - y) ** 2)))
        assert rms > 0.6 * spread, name
    in_sample = fit_mean(X, y, w).predict(X)  # the same trees with the scenes seen: near exact
    assert float(np.sqrt(np.mean((in_sample - y) ** 2))) < 0.1 * spread


def test_networks_learn_a_law_shared_by_the_scenes():
    X, scene, rng = _rows(per_scene=400)  # enough rows for a few hundred steps of 256
    y = 1.5 * X[:, 1] - X[:, 2] + 0.05 * rng.normal(size=len(X))
    pred = regressors.out_of_fold(X, y, np.ones_like(y), scene, scene_folds(10, 5), networks=2, log=lambda *_: None)
    assert float(np.sqrt(np.mean((pred["networks"] - y) ** 2))) < 0.2 * float(y.std())


def test_a_network_holds_its_inputs_to_the_training_range():
    X, _, rng = _rows(scenes=2, per_scene=100)
    y = X[:, 0] - 2.0 * X[:, 3]
    net = regressors.fit_network(X, y, np.ones_like(y), seed=0, epochs=5)
    far = np.array([[1e6, -1e6, 1e6, -1e6]])
    edge = np.array([[X[:, 0].max(), X[:, 1].min(), X[:, 2].max(), X[:, 3].min()]])
    out = regressors.network_predict(net, far)
    assert np.isfinite(out).all()
    np.testing.assert_allclose(out, regressors.network_predict(net, edge), rtol=1e-9, atol=1e-9)


def test_row_groups_and_weighted_scores():
    X = np.zeros((4, len(sources.FEATURES)))
    X[:, sources.FEATURES.index("log_extent_deg")] = np.log10([2.0, 30.0, 5.0, 8.0])
    share = np.array([0.5, 0.5, 0.01, 0.2])
    groups = regressors.row_groups(X, share)
    assert [int(m.sum()) for m in groups.values()] == [4, 3, 2, 1]
    y = np.zeros(4)
    pred = np.array([1.0, -1.0, 2.0, 0.0])
    w = np.array([1.0, 1.0, 2.0, 4.0])
    sc = regressors.scores(pred, y, w, groups)
    everything = sc["all regions"]
    assert everything["rows"] == 4
    assert everything["wrms"] == pytest.approx(np.sqrt((1 + 1 + 8) / 8.0))
    assert everything["wmean"] == pytest.approx((1 - 1 + 4) / 8.0)
    assert "| trees |" in regressors.table({"trees": sc})
