"""camera.brackets: 8-bit exposures of one scene merged into one linear HDR."""
import numpy as np
import pytest

from panolight_core.camera import auto_exposure, hdr_to_ldr
from panolight_core.camera.brackets import exposure, linear_codes, merge_brackets
from panolight_core.camera.ceiling import find_ceiling
from panolight_core.camera.color import SRGB8_TO_LINEAR, linear_to_srgb
from panolight_core.camera.weights import hat
from panolight_core.errors import PanoLightError, PanoLightWarning
from tests.panolight_core.estimators.sources.test_restore import _clear_day


@pytest.fixture(scope="module")
def day():
    return _clear_day()


def test_exposure_is_time_times_iso_over_f_number_squared():
    assert exposure(1 / 250, 8.0, 400) == pytest.approx(exposure(1 / 125, 8.0, 200))  # ISO changed in the set
    assert exposure(1 / 100, 4.0, 100) == pytest.approx(4 * exposure(1 / 100, 8.0, 100))
    with pytest.raises(PanoLightError, match="FNumber 0"):
        exposure(0.01, 0, 100)


def test_three_exposures_merge_to_the_truth_and_the_sun_clips_at_the_darkest_white(day):
    """EVALUATION.md's camera at -2, 0 and +2: every pixel some frame holds comes back within the 8-bit steps
    (in the ev-0 frame's units, the truth's), and the sun, clipped in every frame, sits at 4 in every channel: a
    plateau the restoration finds."""
    truth, s, _ = day  # median luminance 0.18: the ev-0 camera's exposure is 1
    frames = [hdr_to_ldr(truth, ev) for ev in (-2, 0, 2)]
    merged, info = merge_brackets(frames, [0.25, 1.0, 4.0])
    assert info["reference"] == 1 and info["stops"] == [-2.0, 0.0, 2.0] and info["ceiling"] == 4.0
    held = truth.max(axis=-1) < 4.0 * 0.99
    rel = np.abs(merged[held] - truth[held]) / np.maximum(truth[held], 1e-3)
    assert np.median(rel) < 0.01 and np.percentile(rel, 99) < 0.06
    clipped = truth.min(axis=-1) > 4.0 * 1.01
    assert clipped.any() and (merged[clipped] == 4.0).all()
    assert info["clipped_in_every_frame"] == pytest.approx((merged == 4.0).all(axis=-1).mean())
    ceiling = find_ceiling(merged)
    assert ceiling is not None and ceiling.rgb == (4.0, 4.0, 4.0)


def test_linear_frames_merge_as_the_8_bit_frames_they_decode_from(day):
    """Camera RAWs are merged in their own linear values, weighed by their nearest sRGB codes: frames that are
    exactly the 8-bit frames' decoded values merge to the same HDR (to float32 rounding), shifts and ghosts alike."""
    truth, _, _ = day
    frames = [hdr_to_ldr(truth, ev) for ev in (-2, 0, 2)]
    merged, info = merge_brackets(frames, [0.25, 1.0, 4.0])
    linear = [SRGB8_TO_LINEAR[f] for f in frames]
    np.testing.assert_array_equal(linear_codes(np.stack(linear)), np.stack(frames))  # the codes come back
    merged_linear, info_linear = merge_brackets(linear, [0.25, 1.0, 4.0])
    assert info.pop("response")["curve"] == "sRGB" and info_linear == info  # a RAW has no curve to recover
    np.testing.assert_allclose(merged_linear, merged, rtol=1e-6)


def test_a_channel_clipped_in_one_frame_takes_nothing_from_that_frame():
    """A warm highlight: red clips at +2 but not at 0. The merged pixel keeps the ev-0 frame's colour, not a
    clipped red averaged into it (a magenta or dark halo)."""
    truth = np.full((4, 8, 3), 0.18, np.float32)
    truth[1, 2] = (0.6, 0.3, 0.1)  # red over 0.25: clipped at +2 (x4), held at 0
    frames = [hdr_to_ldr(truth, 0.0), hdr_to_ldr(truth, 2.0)]
    merged, _ = merge_brackets(frames, [1.0, 4.0])
    assert merged[1, 2] == pytest.approx(truth[1, 2], rel=0.03)


def test_a_warm_sun_keeps_the_channels_its_darkest_frame_holds():
    """A sunset's aureole: red clips in every frame, green and blue not in the darkest. The pixel is clipped (by its
    brightest channel: no frame is averaged into it), its red at the ceiling and its green and blue the darkest
    frame's, as in an HDR file clipped there; a pixel every channel clips sits at the ceiling in all three. Set to
    the ceiling in every channel, the aureole was a white plateau wider than the sun's, and its centroid drew the
    key light off the sun (3 brackets of a sunset: 5.6 degrees, against 3.1 for the HDR clipped at +2 stops)."""
    truth = np.full((4, 8, 3), 0.18, np.float32)
    truth[1, 2] = (30.0, 3.0, 0.5)  # red 7.5x the -2 frame's white, green and blue under it
    truth[2, 5] = (40.0, 30.0, 20.0)  # the sun: every channel clipped in every frame
    frames = [hdr_to_ldr(truth, ev) for ev in (-2, 0, 2)]
    merged, info = merge_brackets(frames, [0.25, 1.0, 4.0])
    assert merged[1, 2, 0] == 4.0 and merged[1, 2, 1:] == pytest.approx(truth[1, 2, 1:], rel=0.03)
    assert (merged[2, 5] == 4.0).all()
    assert info["clipped_in_every_frame"] == pytest.approx(2 / 32)


@pytest.mark.parametrize("frames, exposures, match", [
    ([np.zeros((4, 8, 3), np.uint8)] * 2, [1.0, 1.05], "less than an eighth of a stop apart"),
    ([np.zeros((4, 8, 3), np.uint8)], [1.0], "two or more positive exposures"),
    ([np.zeros((4, 8, 3), np.uint8), np.zeros((4, 6, 3), np.uint8)], [1.0, 4.0], "frames of one size"),
    ([np.zeros((4, 8, 3), np.uint8)] * 2, [1.0, -4.0], "positive exposures"),
    ([np.zeros((4, 8, 3), np.uint8), np.zeros((4, 8, 3), np.float32)], [1.0, 4.0], "all 8-bit or all linear"),
])
def test_bad_sets_are_refused_in_one_line(frames, exposures, match):
    with pytest.raises(PanoLightError, match=match):
        merge_brackets(frames, exposures)


def test_a_hand_held_set_is_aligned_round_the_panorama_and_merges_as_the_still_one():
    """Blender's city, three frames turned by 40 and -25 columns and tipped by 3 and -2 rows (a 360 camera turned in
    the hand): the median threshold bitmaps find each shift, and the merge equals the still set's away from the
    poles' edge rows."""
    from panolight_core.camera.brackets import align_shift, shift_frame
    from panolight_core.data import load_studio_hdri

    truth = load_studio_hdri("city")
    frames = [hdr_to_ldr(truth, ev) for ev in (-2, 0, 2)]
    assert [align_shift(frames[1], f) for f in frames] == [(0, 0)] * 3  # a still set stays where it is
    moved = [shift_frame(frames[0], 3, -40), frames[1], shift_frame(frames[2], -2, 25)]
    still, _ = merge_brackets(frames, [0.25, 1.0, 4.0])
    merged, info = merge_brackets(moved, [0.25, 1.0, 4.0])
    w = truth.shape[1]
    assert info["shifts"] == [[-3, 40], [0, 0], [2, w - 25]]
    assert np.array_equal(merged[4:-4], still[4:-4])
    far = [frames[0], frames[1], shift_frame(frames[2], 0, 300)]  # turned 105 degrees: beyond the alignment's reach
    with pytest.warns(PanoLightWarning, match=r"frame 3: left out .* does not show the scene .* moved further than "
                                              r"the alignment"):
        _, info = merge_brackets(far, [0.25, 1.0, 4.0])
    assert [d["frame"] for d in info["left_out"]] == [2] and info["shifts"][2] is None


def test_a_shift_that_makes_a_still_pair_agree_worse_is_not_made(monkeypatch):
    """A still tripod pair 4 stops apart that the bitmaps moved 16 rows and 10 columns (a real Canon pair: then
    refused as "a set grouped across two scenes", though unmoved it agreed): a frame is moved only where the move
    makes it rank its blocks more like the middle frame's. Without alignment (--no-align) nothing moves."""
    from panolight_core.camera.agreement import block_codes
    from panolight_core.camera.brackets import AlignmentReference, kept_shift, shift_frame
    from panolight_core.data import load_studio_hdri

    truth = load_studio_hdri("city")
    frames = [hdr_to_ldr(truth, ev, 90) for ev in (-2, 2)]  # 1/250 s and 1/4000 s of one still scene
    assert kept_shift(block_codes(frames[0]), frames[1], 16.0, (16, 10)) == (0, 0)
    moved = shift_frame(frames[1], 5, -30)  # a frame truly turned is still put back
    assert kept_shift(block_codes(frames[0]), moved, 16.0, (-5, 30)) == (-5, 30)
    monkeypatch.setattr(AlignmentReference, "shift_of", lambda self, frame, ratio=1.0: (16, 10))  # what it found
    merged, info = merge_brackets(frames, [1.0, 16.0])
    assert info["shifts"] == [[0, 0], [0, 0]] and info["agreement"][0]["rank_correlation"] > 0.9
    _, plain = merge_brackets(frames, [1.0, 16.0], align=False)
    assert "shifts" not in plain


def test_no_dark_ring_round_a_sun_clipped_in_every_frame():
    """JPEG frames ring 10-20 codes round a clipped edge: a brighter frame's ringing pixel was trusted where every
    darker frame clipped, and came out far under the truth (a dark ring round the sun). A code from RING_CODE up in
    a compression block holding a clipped code counts as clipped: a pixel over every frame's white is never darker
    than what the darkest frame holds there (its own ring, RING_CODE up: at least 0.79 of its white)."""
    from panolight_core import sh
    from panolight_core.camera.blend import RING_CODE, clipped_or_ringing

    top = np.full((32, 48), 200, np.uint8)
    top[3, 5], top[4, 6], top[20, 40] = 252, 240, 240  # a clipped pixel and ringing in its block; 240 alone
    lost = clipped_or_ringing(top)
    assert lost[3, 5] and lost[4, 6] and not lost[20, 40] and lost.sum() == 2 and RING_CODE <= 240
    truth, s, _ = _clear_day(512)
    frames = [hdr_to_ldr(truth, ev, 90) for ev in (-2, 0, 2)]
    merged, info = merge_brackets(frames, [0.25, 1.0, 4.0])
    t = truth * auto_exposure(truth, 0.0)
    near = np.degrees(np.arccos(np.clip(sh.pixel_directions(512, 1024) @ s, -1.0, 1.0))) < 10.0
    over = near & (t.max(axis=-1) > info["ceiling"])
    from panolight_core.camera.color import SRGB8_TO_LINEAR

    assert over.sum() > 10 and merged.max(axis=-1)[over].min() >= info["ceiling"] * SRGB8_TO_LINEAR[RING_CODE]


def test_the_alignment_s_median_code_is_numpy_s_median_read_from_the_histogram():
    from panolight_core.camera.brackets import _median_code

    rng = np.random.default_rng(5)
    for shape in ((7, 9), (8, 10), (1, 1), (2, 1)):  # odd and even counts (an even one averages its middle pair)
        for high in (2, 256):
            grey = rng.integers(0, high, shape, dtype=np.uint8)
            assert _median_code(grey) == int(np.median(grey))
    assert _median_code(np.array([[3, 4]], np.uint8)) == 3 and _median_code(np.array([[255]], np.uint8)) == 255


def test_what_moves_between_frames_is_the_reference_frame_s_alone():
    """A passer-by in the +2 frame only (a dark coat over a grey wall): that frame gives the patch nothing, and the
    merge there is the still set's, not a half-dark ghost; with ghosts off it is darkened."""
    truth = np.full((32, 64, 3), 0.12, np.float32)
    truth[:, 32:] = 0.05  # a darker half: well exposed in every frame
    frames = [hdr_to_ldr(truth, ev) for ev in (-2, 0, 2)]
    coat = linear_to_srgb(np.float32(0.01 * auto_exposure(truth, 2.0)))  # 12x darker than the wall, in one frame
    frames[2][10:20, 10:20] = np.round(255 * coat).astype(np.uint8)
    still, _ = merge_brackets([hdr_to_ldr(truth, ev) for ev in (-2, 0, 2)], [0.25, 1.0, 4.0], align=False)
    merged, _ = merge_brackets(frames, [0.25, 1.0, 4.0], align=False)
    ghost, _ = merge_brackets(frames, [0.25, 1.0, 4.0], align=False, ghosts=False)
    patch = (slice(10, 20), slice(10, 20))
    assert merged[patch] == pytest.approx(still[patch], rel=0.02)
    # with ghosts off the coat darkens the patch (less than a plain hat would: its dark code reads a wide range of
    # light, and the noise weight gives it little)
    assert float(ghost[patch].mean()) < 0.9 * float(still[patch].mean())
    assert np.array_equal(merged[:, 32:], still[:, 32:])  # the still part is untouched


def test_a_noisy_camera_s_set_merges_nearer_its_truth_than_the_plain_hat(monkeypatch):
    """Frames a small sensor takes (photon and read noise, sRGB, JPEG q90, -4..+4 stops): the noise-weighted merge
    is nearer the truth's mid-tones than Debevec's hat alone would be."""
    from panolight_core.camera import blend, sensor_noise
    from panolight_core.camera.color import LUMINANCE_WEIGHTS

    rng = np.random.default_rng(3)
    truth = np.exp(rng.normal(np.log(0.2), 1.2, (64, 128, 1))) * np.array([1.0, 0.9, 0.8])
    stops = (-4, -2, 0, 2, 4)
    frames = [hdr_to_ldr(truth, scale=2.0 ** s, jpeg_quality=90, noise=rng) for s in stops]
    assert sensor_noise(np.full(10000, 0.5), rng).std() == pytest.approx((0.5 * 1e4 + 16) ** 0.5 / 1e4, rel=0.05)

    def error(merged):
        lt, lm = truth @ LUMINANCE_WEIGHTS, merged @ LUMINANCE_WEIGHTS
        mid = (lt > 0.01) & (lt < 0.9)
        r = np.log(lm[mid] / lt[mid])
        return float(np.median(np.abs(r - np.median(r))))

    weighed = error(merge_brackets(frames, [2.0 ** s for s in stops], align=False)[0])
    monkeypatch.setattr(blend, "noise_weights", lambda table: hat(np.arange(256, dtype=np.uint8)))
    plain = error(merge_brackets(frames, [2.0 ** s for s in stops], align=False)[0])
    assert weighed < 0.9 * plain


def test_a_speck_on_one_frame_where_the_reference_is_in_its_toe_makes_no_bright_point():
    """Five frames 2 stops apart, as a noisy camera takes them (photon and read noise, JPEG q95), of a dim wall (0.004
    of the ev-0 white: code 13 in the reference, too dark for the ghost test to trust) beside a grey card. Specks of
    dust on the darkest frame read code 60 there, 180x the wall's light at that exposure. The merge averages the
    frames' logarithms and leaves out a reading that a well-exposed frame holds GHOST_RATIO off the weighted median of
    the others' well-exposed readings: the specks come out within 1.5x of the wall, as the wall around them does.
    (A linear average had put them at 60x: a firefly in every specked pixel.)"""
    truth = np.full((32, 64, 3), 0.004, np.float32)
    truth[:, 32:] = 0.18
    rng = np.random.default_rng(5)
    stops = (-4, -2, 0, 2, 4)
    frames = [hdr_to_ldr(truth, scale=2.0 ** s, jpeg_quality=95, noise=rng) for s in stops]
    specks = (np.array([5, 9, 17, 22, 28]), np.array([4, 20, 11, 27, 6]))
    frames[0] = frames[0].copy()
    frames[0][specks] = 60
    merged, _ = merge_brackets(frames, [2.0 ** s for s in stops], align=False)
    lum = merged @ np.array([0.2126, 0.7152, 0.0722])
    assert np.median(lum[:, 4:28]) == pytest.approx(0.004, rel=0.1)  # the wall itself
    assert np.all(lum[specks] < 1.5 * 0.004) and np.all(lum[specks] > 0.004 / 1.5)


def test_a_camera_s_third_stop_steps_merge(day):
    """A camera's nominal third-stop steps are 1.25x (1/250, 1/200, 1/160 s), under a third of a stop: they are a
    set, merged to the truth like any other (a third of a stop had refused them); the same exposure twice is not."""
    truth, _, _ = day
    times = [1 / 250, 1 / 200, 1 / 160]
    frames = [hdr_to_ldr(truth, scale=t * 200.0) for t in times]  # 1/200 s: the ev-0 camera's exposure
    merged, info = merge_brackets(frames, times)
    assert info["reference"] == 1 and info["stops"] == pytest.approx([-0.3219, 0.0, 0.3219], abs=1e-4)
    held = truth.max(axis=-1) < 0.8
    rel = np.abs(merged[held] - truth[held]) / np.maximum(truth[held], 1e-3)
    assert np.median(rel) < 0.01
    with pytest.raises(PanoLightError, match="less than an eighth of a stop apart"):
        merge_brackets(frames[:2], [1 / 200, 1 / 200])


def test_the_packed_mismatch_counts_what_the_moved_bitmaps_count():
    """The alignment's bit-packed mismatch equals ((rb ^ moved cb) & re & moved ce).sum() for every move of a few rows
    and columns, at widths that are not whole bytes (the packing's padding counts nothing)."""
    from panolight_core.camera.brackets import _bitmaps, _Mismatch, shift_frame

    rng = np.random.default_rng(7)
    for h, w in ((9, 13), (16, 64), (31, 77)):
        a, b = (rng.integers(0, 256, (h, w), dtype=np.uint8) for _ in range(2))
        (rb, re), (cb, ce) = _bitmaps(a, 128), _bitmaps(b, 100)
        mismatch = _Mismatch((rb, re), (cb, ce))
        for ty in range(-3, 4):
            for tx in (-w - 1, -2, 0, 1, 5):
                want = int(((rb ^ shift_frame(cb, ty, tx)) & re & shift_frame(ce, ty, tx)).sum())
                assert mismatch(ty, tx) == want
