"""training.digests: the same code gives the same digests, a changed estimate is found, and eval results compare
without their timings."""
import numpy as np

from panolight_core.io import write_image
from training import digests


def test_the_same_estimates_compare_equal_and_a_changed_one_does_not(tmp_path):
    rng = np.random.default_rng(0)
    for name in ("a", "b"):
        img = rng.random((32, 64, 3)).astype(np.float32) * 0.5
        img[4:6, 10:12] = 40.0  # a clipped sun at ev 0
        write_image(tmp_path / f"{name}.exr", img)
    photos = tmp_path / "ldr"
    photos.mkdir()
    from panolight_core.io import write_srgb8

    write_srgb8(photos / "p.jpg", (rng.random((32, 64, 3)) * 255).astype(np.uint8))
    first = digests.digests(tmp_path, [0.0], photos, log=lambda *_: None)
    again = digests.digests(tmp_path, [0.0], photos, log=lambda *_: None)
    assert first == again and set(first) == {"a@0", "b@0", "a@clip+4", "b@clip+4", "photo:p.jpg"}
    assert first["a@0"]["lighting"]["coefficients"] and len(first["a@0"]["hdr"]) == 64
    changed = dict(first["a@0"], hdr_sums=[[v * (1 + 1e-6) for v in row] for row in first["a@0"]["hdr_sums"]])
    assert not digests._close(first["a@0"]["hdr_sums"], changed["hdr_sums"])
    rounding = [[v * (1 + 1e-15) for v in row] for row in first["a@0"]["hdr_sums"]]
    assert digests._close(first["a@0"]["hdr_sums"], rounding)


def test_eval_results_compare_without_their_timings():
    before = {"scenes": [{"m_rmse": 0.5, "time_ms": 3.0}], "speed": {"x": 1}}
    assert digests.eval_differences(before, {"scenes": [{"m_rmse": 0.5, "time_ms": 9.0}], "speed": {"x": 2}}) == []
    assert digests.eval_differences(before, {"scenes": [{"m_rmse": 0.51, "time_ms": 3.0}], "speed": {"x": 1}}) == \
        ["/scenes[0]/m_rmse: 0.5 -> 0.51"]


def test_two_models_compare_by_their_tensors_and_metadata_not_their_header_order(tmp_path):
    import numpy as np
    from safetensors.numpy import save_file

    from training.digests import model_differences

    t = {"a": np.arange(4.0), "b": np.ones((2, 2), np.float32)}
    save_file(t, str(tmp_path / "one.safetensors"), metadata={"x": "1", "y": "2"})
    save_file(dict(reversed(list(t.items()))), str(tmp_path / "two.safetensors"), metadata={"y": "2", "x": "1"})
    # (safetensors writes the metadata in a hash map's order: the two files' bytes may or may not differ)
    assert model_differences(tmp_path / "one.safetensors", tmp_path / "two.safetensors") == []
    save_file({**t, "a": np.arange(4.0) + 1e-12}, str(tmp_path / "three.safetensors"), metadata={"x": "1", "y": "3"})
    assert model_differences(tmp_path / "one.safetensors", tmp_path / "three.safetensors") == ["tensor a", "metadata y"]
