"""camera.agreement: whether a bracket set's frames show one still scene at their exposures."""
from pathlib import Path

import numpy as np
import pytest

from panolight_core.camera import auto_exposure, hdr_to_ldr
from panolight_core.camera.brackets import merge_brackets
from panolight_core.errors import PanoLightError, PanoLightWarning

SHARED_HDRI = Path(__file__).resolve().parents[4] / "shared" / "data" / "hdri"  # ../shared beside the repository


def test_frames_that_contradict_their_exposures_or_show_another_scene_are_left_out_or_refused():
    """Blender's city at -2, 0, +2 (a camera's S-curve too): a still set's neighbours in exposure agree (none of
    their pixels darker in the frame exposed more, ranked alike), recorded; listed the other way round it is refused
    naming the frames, nothing merged. With the forest's frame in it (a set grouped across two scenes) that frame is
    left out, said in a warning and the record, and the rest merged as a set of their own; a pair with the forest's
    frame is refused (no set holds without it). A wrong step (a 1-stop set told 2) is not caught: a camera's steeper
    curve reads the same."""
    from panolight_core.camera.agreement import consistent_frames
    from panolight_core.camera.resample import area_downsample
    from panolight_core.data import load_studio_hdri

    city = load_studio_hdri("city")
    for curve in ("srgb", "contrast"):
        frames = [hdr_to_ldr(city, ev, 90, curve=curve) for ev in (-2, 0, 2)]
        _, info = merge_brackets(frames, [0.25, 1.0, 4.0])
        assert len(info["agreement"]) == 2
        assert all(a["contradicting"] <= 0.01 and a["rank_correlation"] >= 0.9 for a in info["agreement"])
    names = ["dark.jpg", "mid.jpg", "bright.jpg"]
    with pytest.raises(PanoLightError, match=r"^mid.jpg \(exposed 2 stops more than bright.jpg\) is darker than "
                                             r"bright.jpg over 100 % of what both expose well"):
        merge_brackets(frames[::-1], [0.25, 1.0, 4.0], names=names[::-1])
    forest = area_downsample(load_studio_hdri("forest"), city.shape[0]).astype(np.float32)
    mixed = [frames[0], frames[1], hdr_to_ldr(forest, 2, 90)]
    with pytest.warns(PanoLightWarning, match=r"^frame 3: left out of the merge, the set holding without it: frame 3 "
                                              r"\(exposed 2 stops more than frame 2\) does not show the scene"):
        merged, info = merge_brackets(mixed, [0.25, 1.0, 4.0])
    assert [d["frame"] for d in info["left_out"]] == [2] and info["reference"] == 0 and info["stops"] == [0.0, 2.0, 4.0]
    np.testing.assert_array_equal(merged, merge_brackets(frames[:2], [0.25, 1.0])[0])
    with pytest.raises(PanoLightError, match=r"^frame 2 \(exposed 2 stops more than frame 1\) does not show the "
                                             r"scene frame 1 shows"):
        merge_brackets(mixed[1:], [1.0, 4.0])
    one_stop = [hdr_to_ldr(city, ev, 90) for ev in (-1, 0, 1)]
    assert len(consistent_frames(one_stop, np.array([0.25, 1.0, 4.0]))[1]) == 2  # passes: see the docstring
    flat = np.full((16, 32, 3), 120, np.uint8)  # too few pixels to compare, or codes to rank: no test, no refusal
    assert consistent_frames([flat, flat + 60], np.array([1.0, 4.0]))[1][0].compared == 16 * 32
    wall = np.full((64, 64, 3), 120, np.uint8)
    assert consistent_frames([wall, wall + 60], np.array([1.0, 4.0]))[1][0].rank_correlation is None


def test_block_codes_are_the_brightest_channel_s_block_means_on_the_sampled_grid():
    from panolight_core.camera.agreement import AGREE_GRID_WIDTH, block_codes

    rng = np.random.default_rng(7)
    for width, step, k in ((2048, 4, 4), (1024, 2, 4), (512, 1, 4), (300, 1, 2), (64, 1, 1)):
        frame = rng.integers(0, 256, (width // 2 + 3, width, 3), dtype=np.uint8)  # rows not a multiple of k
        top = frame[::step, ::step].max(axis=-1).astype(np.float64)
        h, w = top.shape[0] // k, top.shape[1] // k
        want = top[:h * k, :w * k].reshape(h, k, w, k).mean(axis=(1, 3))
        got = block_codes(frame)
        assert got.dtype == np.float32 and got.shape == (h, w) and np.allclose(got, want, atol=1e-4)
        assert width < 4 * AGREE_GRID_WIDTH or w == AGREE_GRID_WIDTH


def test_a_still_pair_far_apart_through_an_s_curve_is_one_scene_and_a_studio_relit_is_not():
    """A still pair 3.5 stops apart through a camera's S-curve, with photon noise and JPEG q90 (Blender's sunset): the
    darker frame's toe and the brighter one's shoulder squeeze what both expose well into a few codes, and their
    blocks rank at 0.32-0.39, under BAD_SET_RANK (what refused a real night set, St. Louis 3.3 stops apart). But
    their resolved steps keep their sign and no block runs against the exposures: one scene, merged. The same studio
    from the same tripod with its lights set another way (two real HDRs of ../shared) keeps its edges' steps too,
    but 2 % of its blocks darken in the frame exposed more: refused as another scene."""
    from panolight_core.camera.agreement import (
        BAD_SET_CROSSING,
        BAD_SET_RANK,
        STILL_CONTRADICTING,
        consistent_frames,
        frame_agreement,
    )
    from panolight_core.data import load_studio_hdri
    from panolight_core.io import read_image

    sunset = load_studio_hdri("sunset")
    k = auto_exposure(sunset, 0.0, robust=True)
    for seed in range(3):
        rng = np.random.default_rng(seed)
        pair = [hdr_to_ldr(sunset, scale=k * 2.0 ** s, jpeg_quality=90, noise=rng, curve="contrast") for s in (0, 3.5)]
        kept, (agree,), out = consistent_frames(pair, np.array([1.0, 2.0 ** 3.5]))  # no refusal
        assert kept == [0, 1] and out == []
        assert agree.rank_correlation < BAD_SET_RANK and agree.crossing < 0.2 and agree.contradicting == 0.0
    merged, _ = merge_brackets(pair, [1.0, 2.0 ** 3.5])
    assert np.isfinite(merged).all()
    studio = [np.maximum(read_image(SHARED_HDRI / f"ferndale_studio_0{n}.hdr"), 0.0) for n in (4, 2)]
    darker, brighter = hdr_to_ldr(studio[0], -2, 90), hdr_to_ldr(studio[1], 0, 90)
    agree = frame_agreement(darker, brighter, 4.0)
    assert agree.crossing < BAD_SET_CROSSING and agree.rank_correlation < BAD_SET_RANK
    assert agree.contradicting > 2 * STILL_CONTRADICTING
    with pytest.raises(PanoLightError, match=r"^frame 2 \(exposed 2 stops more than frame 1\) does not show the "
                                             r"scene frame 1 shows .* 2 % of its patches darker .* light changed"):
        merge_brackets([darker, brighter], [1.0, 4.0])


def test_one_exposure_listed_as_two_is_refused_where_no_one_frame_explains_it():
    """Four real sets (a camera whose auto ISO undid the bracket's steps) listed frames a stop apart that read the same
    exposure, and were merged in silence, 0.4-0.96 off OpenCV's merge. Two shots at one exposure (noise and JPEG each
    their own) listed a stop apart move no codes: refused, naming them. In a set of three, either of the pair could be
    the mislabelled one: refused. A still pair a stop apart moves 11 codes or more a stop, recorded (step_codes)."""
    from panolight_core.camera.agreement import FLAT_STEP_CODES, consistent_frames, frame_agreement
    from panolight_core.data import load_studio_hdri

    city = load_studio_hdri("city")
    k = auto_exposure(city, 0.0, robust=True)
    shot = [hdr_to_ldr(city, scale=k * 2.0 ** s, jpeg_quality=90, noise=np.random.default_rng(seed))
            for seed, s in enumerate((-1, 0, 0))]
    right = frame_agreement(shot[0], shot[1], 2.0)
    assert right.step_codes > 2.5 * FLAT_STEP_CODES and right.contradicting <= 0.01
    assert abs(frame_agreement(shot[1], shot[2], 2.0).step_codes) < 1.0
    with pytest.raises(PanoLightError, match=r"^b \(exposed 1 stops more than a\) reads the same exposure as a: what "
                                             r"both expose well moves [+-]\d\.\d codes .* --evs"):
        consistent_frames(shot[1:], np.array([1.0, 2.0]), ["a", "b"])
    with pytest.raises(PanoLightError, match="reads the same exposure"):
        consistent_frames(shot, np.array([0.5, 1.0, 2.0]))
    _, info = merge_brackets(shot[:2], [0.5, 1.0])
    assert info["agreement"][0]["step_codes"] == pytest.approx(right.step_codes, abs=0.01)
