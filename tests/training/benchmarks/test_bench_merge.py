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


def test_a_left_out_frame_is_taken_again_through_each_merge_s_own_curve():
    """_codes_of inverts a curve (sRGB's codes come back exactly); a noise-free sRGB set's middle frame, left out, is
    predicted from the other two within a code or two by PanoLight's merge, and OpenCV's is scored the same way."""
    from panolight_core.camera.color import SRGB8_TO_LINEAR

    codes = np.arange(256)
    values = np.repeat(SRGB8_TO_LINEAR.astype(np.float64)[:, None], 3, axis=1)
    assert np.array_equal(bench_merge._codes_of(values, SRGB8_TO_LINEAR), np.repeat(codes[:, None], 3, axis=1))
    scene = _scene(64)
    frames = [bench_merge.hdr_to_ldr(scene, ev) for ev in (-2, 0, 2)]
    got = bench_merge.held_out(frames, np.array([0.25, 1.0, 4.0]))
    assert got["panolight"]["median"] <= 1.0 and got["panolight"]["mean"] < 2.0
    assert got["opencv"]["median"] >= 0.0 and np.isfinite(got["opencv"]["mean"])


def test_a_lamp_only_the_darkest_frame_holds_is_the_scene_s_own():
    """shown_by_a_frame: a point the darkest frame holds over its neighbours where every brighter frame clips, or
    holds over its well-exposed codes, is the scene's; a point one middle frame alone shows is not."""
    dark = np.full((16, 16, 3), 30, np.uint8)
    bright = np.full((16, 16, 3), 120, np.uint8)
    dark[4, 4], bright[4, 4] = 200, 255  # a lamp: the darkest frame holds it, the brighter one clips
    dark[8, 8], bright[8, 8] = 250, 255  # a lamp over the darkest frame's well-exposed codes
    bright[12, 12] = 250  # a bright point of the brighter frame alone (its darker frame reads the wall)
    table = np.linspace(0.0, 1.0, 256) ** 2.2
    shown = bench_merge.shown_by_a_frame([dark, bright], np.array([1.0, 4.0]), table)
    assert shown[4, 4] and shown[8, 8] and not shown[12, 12] and shown.sum() == 2


def test_the_merge_weighed_as_opencv_reads_opencv_s_curve_and_the_hat_only_inside_and_a_real_set_scores_it():
    """Inside ``weighed_as_opencv`` the merge decodes through OpenCV's monotone curve (code 250 where sRGB's is) and
    weighs by the hat; outside, the shipped rules come back; a real set's score has both parts, finite."""
    from panolight_core.camera import blend, brackets, response

    frames = [bench_merge.hdr_to_ldr(_scene(32), ev) for ev in (-2, 0, 2)]
    e = np.array([0.25, 1.0, 4.0])
    curve = bench_merge.opencv_curve(frames, e)
    assert curve.shape == (256,) and (np.diff(curve) >= 0).all()
    assert curve[250] == pytest.approx(float(response.SRGB.table[250]), rel=1e-5)
    shipped = brackets.recover_response, blend.noise_weights
    with bench_merge.weighed_as_opencv(frames, e, hat=True):
        assert np.array_equal(brackets.recover_response(frames, e, 1).table, curve)
        assert blend.noise_weights(response.SRGB.table)[128] == 128.0  # the hat, unscaled
    assert (brackets.recover_response, blend.noise_weights) == shipped
    r = bench_merge.score(frames, e, repeats=1)
    parts = r["agreement_parts"]
    assert set(parts) == {"opencv_curve", "opencv_curve_hat_no_ghosts"}
    assert all(0 <= v < 1 for v in parts.values())
    assert set(r["held_out"]) == {"panolight", "panolight_hat", "opencv"}
    assert all(np.isfinite(v["mean"]) for v in r["held_out"].values())


def test_a_real_set_the_merge_refuses_is_said_and_not_scored(tmp_path, capsys):
    """Four public sets list frames a stop apart that their camera took at one exposure: the merge refuses them, and
    the bench says so in its row rather than scoring an HDR PanoLight would not make."""
    frames = [bench_merge.hdr_to_ldr(_scene(64), ev) for ev in (-1, 0, 0)]
    for i, f in enumerate(frames):
        Image.fromarray(f).save(tmp_path / f"f{i}.png")
    (tmp_path / "shutter_times.txt").write_text("1/4\n1/2\n1\n")
    assert bench_merge.main(["--frames", str(tmp_path), "--repeats", "1"]) == 0
    out = capsys.readouterr().out
    assert (f"| {tmp_path.name} | 3 | refused by PanoLight: f2.png (exposed 1 stops more than f1.png) reads the "
            f"same exposure as f1.png") in out
