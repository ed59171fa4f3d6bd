
import numpy as np
import pytest
import torch

from panolight_core import metrics, sh
from panolight_core.errors import PanoLightError
from panolight_core.lighting.relight import relight
from training.neural.relight_data import folder_pool, paired_sources, relight_dataset, synthetic_sources
from training.render import mitsuba as mr
from training.synth import scenes, store

mi = mr.mitsuba()


def test_lamps_appear_where_they_are_placed():
    """The frame check: a small lamp at a known direction is the brightest pixel in that direction."""
    for d in ([1.0, 0, 0], [0, 1.0, 0], [-0.5, -0.5, 0.7], [0.3, -0.8, -0.5]):
        d = np.array(d) / np.linalg.norm(d)
        items = {"lamp": {"type": "sphere", "center": (3 * d).tolist(), "radius": 0.15,
                          "emitter": {"type": "area", "radiance": {"type": "rgb", "value": [50.0, 50.0, 50.0]}}}}
        out = scenes.render_panorama(items, [0, 0, 0], height=64, spp=4)
        lum = out["radiance"].sum(-1)
        assert metrics.angle_deg(metrics.dominant_light_direction(out["radiance"]), d) < 3.0, d
        assert lum.max() > 10


def test_sample_normals_are_unit_face_the_camera_and_are_deterministic():
    a = scenes.sample(3, height=32, spp=2)
    b = scenes.sample(3, height=32, spp=2)
    np.testing.assert_array_equal(a["radiance"], b["radiance"])
    n, m = a["normals"], a["mask"]
    np.testing.assert_allclose(np.linalg.norm(n[m], axis=-1), 1.0, atol=1e-6)
    assert np.all(n[~m] == 0)
    assert np.all(np.sum(n * sh.pixel_directions(32, 64), axis=-1)[m] <= 1e-6)
    assert a["params"]["seed"] == 3 and a["params"]["kind"] in ("room", "outdoor")


def test_relit_sphere_matches_a_mitsuba_render_under_the_same_sh_light():
    """Paper Eq. 5 against path tracing: a diffuse sphere's radiance is albedo / pi x E(n)."""
    c = np.random.default_rng(4).normal(size=(9, 3)) * 0.3
    c[0] += 5.0
    items = {**mr.scene_emitters(c, [], 128),
             "ball": {"type": "sphere", "center": [2.5, 0, 0], "radius": 1.2,
                      "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.7, 0.5, 0.3]}}}}
    out = scenes.render_panorama(items, [0, 0, 0], height=64, spp=256, max_depth=2)
    m = out["mask"].copy()
    m[1:-1, 1:-1] &= out["mask"][:-2, 1:-1] & out["mask"][2:, 1:-1] & out["mask"][1:-1, :-2] & out["mask"][1:-1, 2:]
    expect = relight(out["albedo"], out["normals"], c) / np.pi
    got = out["radiance"]
    assert m.sum() > 100
    assert np.abs(got[m] - expect[m]).mean() < 0.03 * expect[m].mean()


def test_store_resumes_repairs_and_shards(tmp_path):
    res = store.synthesize(tmp_path, 3, height=16, spp=1, shard=(1, 2))
    assert res["rendered"] == 2 and [p.name for p in store.list_samples(tmp_path)] == ["sample-0000000.npz",
                                                                                       "sample-0000002.npz"]
    res = store.synthesize(tmp_path, 3, height=16, spp=1, shard=(2, 2))
    assert res["rendered"] == 1 and len(store.list_samples(tmp_path)) == 3
    store.sample_path(tmp_path, 1).write_bytes(b"damaged")
    res = store.synthesize(tmp_path, 3, height=16, spp=1)
    assert res == {**res, "rendered": 1, "skipped": 2}
    s = store.read_sample(store.sample_path(tmp_path, 1))
    assert s["radiance"].shape == (16, 32, 3) and s["sh"].shape == (81, 3) and s["params"]["seed"] == 1
    np.testing.assert_allclose(s["sh"], sh.project(s["radiance"], 8), rtol=1e-4, atol=1e-6)


def test_dataset_yields_pairs_with_workers(tmp_path):
    store.synthesize(tmp_path, 4, height=16, spp=1)
    pool = np.stack([sh.project(np.full((8, 16, 3), 0.5) + sh.pixel_directions(8, 16)[..., 2:3] * k, 2)
                     for k in (0.1, 0.4, 0.8)])
    ds = relight_dataset(synthetic_sources(tmp_path), pool, seed=7)
    item = ds[1]
    assert item["input"].shape == (3, 16, 32) and item["target_sh"].shape == (9, 3)
    assert item["normals"].shape == (3, 16, 32) and item["mask"].shape == (1, 16, 32)
    assert 0 <= float(item["input"].min()) and float(item["input"].max()) <= 1
    torch.testing.assert_close(ds[1]["input"], item["input"])  # deterministic per index
    loader = torch.utils.data.DataLoader(ds, batch_size=2, num_workers=2)
    batches = list(loader)
    assert len(batches) == 2 and batches[0]["input"].shape == (2, 3, 16, 32)
    lam = float(item["blend"])
    assert 0 <= lam <= 1


def test_real_dataset_readers(tmp_path):
    from PIL import Image

    from panolight_core.io import write_image

    n = sh.pixel_directions(8, 16).astype(np.float32)
    (tmp_path / "a").mkdir()
    Image.fromarray(np.full((8, 16, 3), 128, np.uint8)).save(tmp_path / "a" / "room1_color_0_Left.png")
    write_image(tmp_path / "a" / "room1_normal_0_Left.exr", n)  # 3D60 style (EXR keeps the negative values)
    (tmp_path / "b").mkdir()
    Image.fromarray(np.full((8, 16, 3), 90, np.uint8)).save(tmp_path / "b" / "rgb_rawlight.png")
    Image.fromarray(np.round((n * 0.5 + 0.5) * 255).astype(np.uint8)).save(tmp_path / "b" / "normal.png")
    sources = paired_sources(tmp_path)
    assert len(sources) == 2
    from training.neural.relight_data import load_source

    for src in sources:
        image, normals, mask, _ = load_source(src)
        assert mask.all() and np.abs(np.linalg.norm(normals, axis=-1) - 1).max() < 1e-6
        assert np.abs(normals - n).max() < (1e-6 if src["normals"].suffix == ".exr" else 0.01)
    with pytest.raises(PanoLightError, match="no colour panorama"):
        paired_sources(tmp_path / "a" / "missing")


def test_lighting_pool_refuses_the_public_set(tmp_path):
    from panolight_core.data import studio_hdri_dir
    from panolight_core.io import write_image

    with pytest.raises(PanoLightError, match="public evaluation set"):
        folder_pool(studio_hdri_dir())
    write_image(tmp_path / "l1.exr", np.ones((8, 16, 3), np.float32))
    write_image(tmp_path / "l2.hdr", np.full((8, 16, 3), 2.0, np.float32))
    pool = folder_pool(tmp_path)
    assert pool.shape == (2, 9, 3) and pool[0, 0, 0] == pytest.approx(np.sqrt(4 * np.pi), rel=1e-5)


def test_contact_sheet_and_synth_cli(tmp_path):
    from panolight_core.apps.cli import main

    assert main(["synth", "--count", "2", "--out", str(tmp_path / "ds"), "--resolution", "32x16", "--spp", "1",
                 "-q"]) == 0
    assert main(["sheet", str(tmp_path / "ds"), "-o", str(tmp_path / "sheet.png"), "--count", "2"]) == 0
    from PIL import Image

    assert Image.open(tmp_path / "sheet.png").size[0] > 4 * 100
