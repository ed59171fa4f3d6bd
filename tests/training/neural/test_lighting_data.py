"""The prepared training set: deterministic, in the LDR's units, relit targets consistent with Eq. 5."""
import numpy as np
import pytest

from panolight_core import sh
from panolight_core.lighting.relight import relight
from training.neural import lighting_data as L
from training.neural.relight_data import procedural_pool
from training.synth import store


@pytest.fixture
def synth(tiny_synth):
    return tiny_synth


def test_procedural_examples_are_deterministic_and_exposed():
    a, b = L.procedural_example(5, 16, 2), L.procedural_example(5, 16, 2)
    np.testing.assert_array_equal(a["x"], b["x"])
    assert a["x"].shape == (7, 16, 32) and a["log_hdr"].shape == (3, 16, 32) and a["sh"].shape == (9, 3)
    # the target is the exposed HDR's projection: its mean radiance matches the AE target's (same map)
    mean_map = sh.project(np.moveaxis(np.expm1(a["log_hdr"].astype(np.float64)), 0, -1), 0)[0]
    np.testing.assert_allclose(mean_map, a["sh"][0], rtol=0.02)


def test_relit_targets_relight_the_image_into_the_autoencoder_target(synth):
    files = store.list_samples(synth)
    coupled, relit = L.synthetic_examples(files[0], 0, 16, 2, procedural_pool(8, 2), seed=3)
    assert coupled["kind"] == L.KINDS.index("synthetic") and relit["kind"] == L.KINDS.index("relit")
    n = np.moveaxis(relit["normals"], 0, -1)
    img = np.moveaxis(relit["image"], 0, -1)
    rendered = relight(img, n, relit["sh"].astype(np.float64))
    target = np.moveaxis(np.expm1(relit["log_hdr"].astype(np.float64)), 0, -1)
    surface = (np.linalg.norm(n, axis=-1) > 0.5) & (target.sum(-1) > 1e-3)
    ratio = rendered[surface].sum() / target[surface].sum()
    assert ratio == pytest.approx(1.0, rel=0.1)  # downsampled normals and JPEG make it approximate


def test_prepare_writes_loadable_arrays_without_pickles(synth, tmp_path):
    out = L.prepare(tmp_path / "p.npz", synth=synth, procedural=3, height=8, lmax=1, workers=1)
    arr = L.load(out)
    assert len(arr["sh"]) == 3 + 2 * 6 and arr["sh"].shape[1:] == (4, 3)
    assert (arr["geo_index"] >= 0).sum() == 6 == len(arr["normals"])
    both = L.concat([arr, arr])
    assert len(both["sh"]) == 30 and both["geo_index"].max() == 11
    name = L.cache_name(synth=synth, procedural=3, height=8, lmax=1, seed=0)
    assert name != L.cache_name(synth=synth, procedural=4, height=8, lmax=1, seed=0)


def test_real_hdr_folders_become_coupled_examples_and_the_public_set_is_refused(tmp_path):
    from panolight_core.data import studio_hdri_dir
    from panolight_core.errors import PanoLightError
    from panolight_core.io import write_image
    from panolight_core.synthetic import environment
    from training.common.real_hdri import hdr_files
    from training.neural.models import load_config
    from training.neural.train import _datasets

    folder = tmp_path / "laval"
    folder.mkdir()
    for i in range(10):
        write_image(folder / f"pano{i}.exr", environment(100 + i, 32)[0].astype(np.float32))
    cfg = {**load_config("small"), "input_height": 8}
    train, val = _datasets(cfg, None, 2, 1, 0, tmp_path / "cache", lambda m: None, hdr=folder)
    assert (train["kind"] == L.KINDS.index("hdr")).sum() == 9 and (val["kind"] == L.KINDS.index("hdr")).sum() == 1
    example = L.hdr_example(folder / "pano3.exr", 3, 8, 2, 0)
    assert np.isfinite(example["sh"]).all() and example["x"].shape == (7, 8, 16)
    with pytest.raises(PanoLightError, match="public evaluation set"):
        hdr_files(studio_hdri_dir())


def test_augmented_views_and_held_out_scenes_never_reach_training(tmp_path):
    from panolight_core.io import read_image, write_image
    from panolight_core.synthetic import environment
    from training.common.folds import scene_folds
    from training.neural.models import load_config
    from training.neural.train import _datasets, held_out_scenes

    folder = tmp_path / "real"
    folder.mkdir()
    for i in range(10):
        write_image(folder / f"scene{i}.exr", environment(200 + i, 32)[0].astype(np.float32))
    test = held_out_scenes(folder, (2, 5))
    files = sorted(folder.glob("*.exr"))  # no MANIFEST: scene_files lists the folder sorted
    assert test == sorted(files[i].stem for i in scene_folds(10, 5)[1]) and len(test) == 2
    cfg = {**load_config("small"), "input_height": 8}
    train, val = _datasets(cfg, None, 0, 0, 0, tmp_path / "cache", lambda m: None, hdr=folder, hdr_copies=3,
                           hold_out=(2, 5))
    assert len(train["x"]) == 7 * 3 and len(val["x"]) == 1 * 3  # 8 scenes left: 7 train, 1 validation
    held = {L.hdr_example(folder / f"{s}.exr", 0, 8, 2, 0, 0)["x"].tobytes() for s in test}
    seen = {x.astype(np.float16).tobytes() for x in np.concatenate([train["x"], val["x"]])}
    assert not held & seen  # no view of a held-out scene anywhere
    a, b = (L.hdr_example(files[0], 0, 8, 2, 0, c) for c in (0, 1))
    assert not np.array_equal(a["x"], b["x"])  # two views differ (yaw, camera)
    np.testing.assert_array_equal(a["x"], L.hdr_example(files[0], 0, 8, 2, 0, 0)["x"])  # and are reproducible
    hdr = read_image(files[0]).astype(np.float64)
    assert np.isfinite(a["sh"]).all() and a["sh"][0].min() > 0 and hdr.max() > 0


def test_an_hdr_relighting_pool_is_each_panorama_turned_and_mirrored_and_refuses_the_public_set(tmp_path):
    from panolight_core.data import studio_hdri
    from panolight_core.errors import PanoLightError
    from panolight_core.io import write_image
    from panolight_core.sh.rotation import rotate_z
    from panolight_core.synthetic import environment
    from training.neural.relight_data import hdr_pool

    path = tmp_path / "sky.exr"
    write_image(path, environment(7, 32)[0].astype(np.float32))
    pool = hdr_pool([path], lmax=2, yaws=4)
    assert pool.shape == (8, 9, 3)
    # whole-column turns are exact rotations about the up axis: entry k is entry 0 turned by k quarter turns
    for k in range(1, 4):
        turned = [rotate_z(pool[0], s * k * np.pi / 2) for s in (1, -1)]
        assert min(np.abs(t - pool[k]).max() for t in turned) < 1e-6 * np.abs(pool[0]).max()
    np.testing.assert_allclose(pool[4][[0, 2, 6]], pool[0][[0, 2, 6]], rtol=1e-6)  # mirroring keeps m = 0
    assert not np.allclose(pool[4], pool[0])
    with pytest.raises(PanoLightError, match="public evaluation set"):
        hdr_pool([studio_hdri("forest")])


def test_the_hdr_relighting_pool_of_each_split_holds_only_its_own_scenes(synth, tmp_path, monkeypatch):
    from panolight_core.errors import PanoLightError
    from panolight_core.io import write_image
    from panolight_core.synthetic import environment
    from training.neural.models import load_config
    from training.neural.train import _datasets, held_out_scenes

    folder = tmp_path / "real"
    folder.mkdir()
    for i in range(10):
        write_image(folder / f"scene{i}.exr", environment(300 + i, 32)[0].astype(np.float32))
    calls = []

    def fake_prepare(path, **kw):
        calls.append(kw)
        real_prepare(path, **kw)
        return path

    real_prepare = L.prepare
    monkeypatch.setattr(L, "prepare", fake_prepare)
    cfg = {**load_config("small"), "input_height": 8}
    _datasets(cfg, synth, 0, 0, 0, tmp_path / "cache", lambda m: None, hdr=folder, hold_out=(1, 5),
              relight_pool="hdr")
    pools = [{p.stem for p in kw["pool_hdr"]} for kw in calls if kw.get("synth")]
    train_hdr, val_hdr = ({p.stem for p in kw["hdr"]} for kw in calls if kw.get("hdr"))
    assert len(pools) == 1 and pools[0] == train_hdr  # six samples: all train (a tenth, 0, validates)
    assert not pools[0] & val_hdr and not pools[0] & set(held_out_scenes(folder, (1, 5)))
    metas = [L.load(p)["meta"] for p in (tmp_path / "cache").glob("*.npz")]
    assert [sorted(m["relight_pool"]) for m in metas if m["synthetic"]] == [sorted(f"{s}.exr" for s in train_hdr)]
    with pytest.raises(PanoLightError, match="give both"):
        _datasets(cfg, synth, 0, 0, 0, tmp_path / "cache", lambda m: None, relight_pool="hdr")
