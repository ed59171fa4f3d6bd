"""training.benchmarks.bench_merge: a camera's set, a real set's folder, and the scores it compares."""
import numpy as np
import pytest
from PIL import Image

from training.benchmarks import bench_merge


def _scene(h=32):
    rng = np.random.default_rng(0)
    return np.exp(rng.normal(np.log(0.2), 1.0, (h, 2 * h, 1))) * np.array([1.0, 0.9, 0.8])


def test_a_planted_spike_is_a_firefly_and_a_truth_s_own_point_is_not_spurious():
    img = np.full((16, 16, 3), 0.1)
    img[8, 8] = 5.0
    assert bench_merge.fireflies(img, 1e-3) == 1
    assert bench_merge.fireflies(img, 1e-3, truth=img) == 0  # the truth has it: a lamp, not a firefly
    assert bench_merge.fireflies(np.full((16, 16, 3), 0.1), 1e-3) == 0


def test_both_merges_of_a_camera_set_are_scored():
    frames, exposures = bench_merge.camera_set(_scene(), (-2, 0, 2))
    assert len(frames) == 3 and frames[0].dtype == np.uint8 and exposures.tolist() == [0.25, 1.0, 4.0]
    truth = _scene() * bench_merge.auto_exposure(_scene(), 0.0, robust=True)
    r = bench_merge.score(frames, exposures, repeats=1, truth=truth)
    for name in ("panolight", "opencv"):
        assert r[name]["seconds"] > 0 and r[name]["fireflies"] >= 0 and r[name]["truth_error"] >= 0
    assert 0 <= r["agreement"] < 0.5 and r["pixels"] == 32 * 64
    assert r["curve"]["used"] == "sRGB" and r["curve"]["opencv_vs_srgb"] >= 0  # an sRGB camera keeps sRGB
    assert bench_merge.table([dict(r, set="s", frames=3)])[2].startswith("| s | 3 | 2048 |")


def test_a_real_set_is_read_with_its_shutter_times_and_refused_without_them(tmp_path):
    frames, _ = bench_merge.camera_set(_scene(), (-1, 1))
    for i, f in enumerate(frames):
        Image.fromarray(f).save(tmp_path / f"f{i}.png")
    (tmp_path / "shutter_times.txt").write_text("1/8\n1/2\n")
    got, times, names = bench_merge.read_set(tmp_path)
    assert names == ["f0.png", "f1.png"] and times.tolist() == [0.125, 0.5] and np.array_equal(got[1], frames[1])
    (tmp_path / "shutter_times.txt").unlink()
    with pytest.raises(SystemExit, match="records no exposure"):
        bench_merge.read_set(tmp_path)
