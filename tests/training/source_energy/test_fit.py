"""Training the per-source energy model: the exported trees equal scikit-learn's, the data is honest."""
import json

import numpy as np
import pytest

from panolight_core.errors import PanoLightError
from panolight_core.estimators import sources
from training.common.real_hdri import scene_files
from training.source_energy import data as sd
from training.source_energy import fit as se


def test_exported_trees_match_sklearn_and_round_trip_through_safetensors(tmp_path, rng):
    from sklearn.ensemble import GradientBoostingRegressor

    x = rng.normal(size=(400, len(sources.FEATURES)))
    y = np.sin(x[:, 0]) + 0.5 * x[:, 3] ** 2 + 0.1 * rng.normal(size=400)
    w = rng.random(400)
    gbt = GradientBoostingRegressor(n_estimators=40, max_depth=3, learning_rate=0.1, random_state=0)
    gbt.fit(x, y, sample_weight=w)
    ens = se._export(gbt)
    np.testing.assert_allclose(ens.predict(x), gbt.predict(x), rtol=0, atol=1e-10)
    path = se.save(tmp_path / "m.safetensors", ens, ens, 0.5, {"trained_on": "test", "environment": se.environment()})
    model = sources.load_source_model(path)
    mu, sigma, reported = model.predict(x[:10])
    np.testing.assert_allclose(mu, gbt.predict(x[:10]), atol=1e-10)
    assert model.shrink == 0.5 and model.meta["trained_on"] == "test"
    import sklearn  # the model says which libraries drew and fitted it
    assert json.loads(model.meta["environment"])["scikit-learn"] == sklearn.__version__


def test_training_data_refuses_the_public_set_and_a_missing_folder(tmp_path):
    from panolight_core.data import studio_hdri_dir

    with pytest.raises(PanoLightError, match="public evaluation set"):
        scene_files(studio_hdri_dir())
    with pytest.raises(PanoLightError, match="no such folder"):
        scene_files(tmp_path / "nothing")


def test_random_camera_rows_have_honest_targets(rng):
    h = 64
    hdr = np.full((h, 2 * h, 3), 0.2)
    hdr[10:12, 30:32] = 2000.0  # a sun
    for _ in range(4):
        ldr, truth = sd.camera(hdr, rng)
        assert ldr.dtype == np.uint8 and ldr.shape == truth.shape and truth.shape[0] in (h // 2, h, 2 * h)
        x, y, share = sd.region_rows(ldr, truth)
        assert x.shape == (y.size, len(sources.FEATURES)) and np.all(np.isfinite(x))
        assert np.all(y >= 0) and np.all((share >= 0) & (share <= 1 + 1e-9))
        if y.size:
            assert np.exp(y.max()) > 10  # the sun's region holds far more than its clipped pixels show


def test_cross_validation_scores_a_scene_by_the_protocol():
    from panolight_core import metrics, sh
    from panolight_core.camera import hdr_to_ldr, ldr_to_linear
    from training.source_energy.cv import DECIDED, EVS, fold_variants, score_scene

    h = 64
    hdr = np.full((h, 2 * h, 3), 0.2)
    hdr[10:12, 30:32] = 3000.0  # a sun
    variants = fold_variants(sources.load_source_model())
    rows = score_scene(hdr, variants)
    assert len(rows) == len(EVS) * len(variants) and DECIDED in variants
    naive = next(r for r in rows if r["estimator"] == "naive" and r["ev"] == 0.0)
    q = sh.project(ldr_to_linear(hdr_to_ldr(hdr, 0.0, 90, robust=True)), 2)
    assert naive["m_rmse"] == pytest.approx(metrics.m_rmse(sh.project(hdr, 2), q))
    learned = next(r for r in rows if r["estimator"] == DECIDED and r["ev"] == 0.0)
    assert learned["m_rmse"] < naive["m_rmse"]  # the sun's energy comes back


def test_an_injected_source_adds_a_compact_disk_of_the_drawn_energy():
    from panolight_core import sh
    from panolight_core.camera.color import LUMINANCE_WEIGHTS

    h = 256
    p = np.full((h, 2 * h, 3), 0.5)
    om = sh.pixel_solid_angles(h, 2 * h)
    scene = float(((p @ LUMINANCE_WEIGHTS) * om).sum())
    for seed in range(6):
        added = sd.inject_source(p, np.random.default_rng(seed)) - p
        assert added.min() >= 0.0
        lum = added @ LUMINANCE_WEIGHTS
        energy = float((lum * om).sum())
        assert 0.05 * scene * 0.999 <= energy <= 3.0 * scene * 1.001  # 5 %-300 % of the scene's energy
        peak = np.unravel_index(np.argmax(lum), lum.shape)
        t = np.degrees(np.arccos(np.clip(sh.pixel_directions(h, 2 * h) @ sh.pixel_directions(h, 2 * h)[peak], -1, 1)))
        assert float((lum * om)[t < 3.0].sum()) >= 0.85 * energy  # compact: the halo holds 10 % at most
    # the experiment is off by default: the same cameras as before, draw for draw
    hdr = np.random.default_rng(1).uniform(0.1, 2.0, (32, 64, 3))
    a, b = sd.camera(hdr, np.random.default_rng(3)), sd.camera(hdr, np.random.default_rng(3), inject=0.0)
    np.testing.assert_array_equal(a[0], b[0])
    c = sd.camera(hdr, np.random.default_rng(3), inject=1.0)
    assert c[1].max() > 10 * b[1].max()


def test_a_camera_saved_again_is_a_second_generation_and_none_draws_nothing_extra():
    """resave 0 (the default) is the first-generation stream, draw for draw; resave 1 saves every
    picture again, and about half of those at least 1024 wide are made half as wide first."""
    hdr = np.random.default_rng(1).uniform(0.05, 3.0, (256, 512, 3))  # cameras 256, 512 or 1024 wide
    hdr[40:56, 240:280] = 50.0  # a clipped source, so JPEG's ringing at its rim shows
    widths = []
    for seed in range(16):
        first = sd.camera(hdr, np.random.default_rng(seed))
        np.testing.assert_array_equal(first[0], sd.camera(hdr, np.random.default_rng(seed), resave=0.0)[0])
        again = sd.camera(hdr, np.random.default_rng(seed), resave=1.0)
        np.testing.assert_array_equal(again[1], first[1])  # the same scene and exposure: only the picture differs
        if again[0].shape == first[0].shape:
            assert (again[0] != first[0]).any()  # saved again: not the same bytes
        else:
            assert again[0].shape == (first[0].shape[0] // 2, first[0].shape[1] // 2, 3)
            assert first[0].shape[1] >= 1024
        widths.append((first[0].shape[1], again[0].shape[1]))
    assert any(a != b for a, b in widths) and any(a == b >= 1024 for a, b in widths)


def test_each_scene_is_in_the_fold_whose_hold_out_model_never_saw_it():
    from training.common.folds import fold_files, fold_of

    files = [f"scene_{i:02d}.hdr" for i in range(23)]
    of = fold_of(files)
    assert sorted(of) == sorted(files) and set(of.values()) == {1, 2, 3, 4, 5}
    for k in range(1, 6):
        assert sorted(fold_files(files, (k, 5))) == sorted(f for f, j in of.items() if j == k)


def test_one_cached_table_serves_every_model_and_is_built_again_for_other_cameras(tmp_path, monkeypatch, rng):
    """``cached_table`` builds the rows once and reads them back (no pickle) for the same scenes, cameras and seed;
    other cameras build them again. An ablation names the columns it was trained on and is given them by name."""
    from sklearn.ensemble import GradientBoostingRegressor

    calls = []

    def fake_build(files, augment, seed, log=print, inject=0.0, resave=sd.RESAVE, hdr_cameras=0):
        calls.append((tuple(files), augment, seed, hdr_cameras, resave))
        n = 6 * len(files)
        return (rng.normal(size=(n, len(sources.FEATURES))), rng.random(n), rng.random(n),
                np.repeat(np.arange(len(files)), 6), (np.arange(n) % 2).astype(np.int8) * (hdr_cameras > 0))

    monkeypatch.setattr(sd, "build_table", fake_build)
    files = [tmp_path / "a.hdr", tmp_path / "b.hdr"]
    first = sd.cached_table(tmp_path / "t.npz", files, 16, 0, 0.0, log=lambda *_: None)
    again = sd.cached_table(tmp_path / "t.npz", files, 16, 0, 0.0, log=lambda *_: None)
    assert len(calls) == 1 and all(np.array_equal(u, v) for u, v in zip(first, again))
    sd.cached_table(tmp_path / "t.npz", files, 16, 1, 0.0, log=lambda *_: None)  # another seed: other cameras
    assert len(calls) == 2
    sd.cached_table(tmp_path / "t.npz", files, 16, 1, 0.0, log=lambda *_: None, resave=0.35)  # pictures saved again
    assert len(calls) == 3 and calls[-1][-1] == 0.35
    both = sd.cached_table(tmp_path / "t.npz", files, 16, 1, 0.0, log=lambda *_: None, resave=0.35, hdr_cameras=8)
    assert len(calls) == 4 and calls[-1][3] == 8 and set(both[4]) == {0, 1}  # clipped HDR files: other rows, marked
    again = sd.cached_table(tmp_path / "t.npz", files, 16, 1, 0.0, log=lambda *_: None, resave=0.35, hdr_cameras=8)
    assert len(calls) == 4 and np.array_equal(again[4], both[4])  # the kinds come back from the file
    names = sources.FEATURES[3:7]
    X = first[0][:, [sources.FEATURES.index(n) for n in names]]
    ens = se._export(GradientBoostingRegressor(n_estimators=5, max_depth=2).fit(X, first[1]))
    model = sources.load_source_model(se.save(tmp_path / "ablation.safetensors", ens, ens, 0.5, {}, names))
    assert model.features == names
    np.testing.assert_allclose(model.predict(first[0])[0], ens.predict(X), atol=1e-12)


def test_the_held_share_weight_does_not_look_at_the_target():
    """--weight held-share weighs a row by the share of the scene the picture gives it (log_scene_over_held), so
    two rows with the same features get the same weight whatever their truth; the shipped weight follows the truth."""
    X = np.zeros((3, len(sources.FEATURES)))
    X[:, sources.FEATURES.index("log_scene_over_held")] = [2.0, 2.0, 0.0]  # 1 %, 1 %, the whole scene
    share = np.array([0.01, 0.6, 0.5])
    held = se.sample_weight(share, X, "held-share")
    assert held[0] == held[1] == pytest.approx(0.02 + 0.1) and held[2] == pytest.approx(1.02)
    true = se.sample_weight(share)
    assert true[1] > true[0]
    with pytest.raises(ValueError, match="unknown weight"):
        se.sample_weight(share, X, "energy")


def test_the_narrowest_training_camera_is_the_width_the_product_warns_below(rng):
    """``pipeline.estimate.narrow_warning`` warns below sources.TRAINED_MIN_WIDTH: the narrowest view the training
    cameras frame of the 1024-wide real HDRs (``data.scene_view``), none narrower."""
    hdr = np.ones((512, 1024, 3))
    widths = {sd.scene_view(hdr, rng).shape[1] for _ in range(40)}
    assert min(widths) == sources.TRAINED_MIN_WIDTH and widths == {512, 1024, 2048}
