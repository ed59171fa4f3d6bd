"""A bracket set's own camera curve (Debevec and Malik), recovered where it explains the frames better than sRGB."""
import numpy as np
import pytest

from panolight_core.camera import auto_exposure, hdr_to_ldr, tone_curve
from panolight_core.camera.brackets import merge_brackets
from panolight_core.camera.ceiling import find_ceiling
from panolight_core.camera.color import SRGB8_TO_LINEAR
from panolight_core.camera.response import recover_response
from panolight_core.data import load_studio_hdri

EVS = (-2, 0, 2)


CAMERAS = [("gamma", 2.8), ("contrast", 1.6), ("shoulder", 3.0)]  # camera.TONE_CURVES: a power law, an S-curve
# about mid grey, a soft highlight shoulder


def _inverse(curve, param):
    """(256,) the true code -> radiance of the tone curve, by inverting it on a fine grid."""
    x = np.linspace(0.0, 2.0 * param if curve == "shoulder" else 1.0, 400001)
    z = np.round(tone_curve(x, curve, param) * 255.0).astype(np.int64)
    return np.array([x[z == c].mean() if (z == c).any() else np.nan for c in range(256)])


@pytest.fixture(scope="module")
def city():
    t = load_studio_hdri("city")
    return (t * auto_exposure(t, 0.0)).astype(np.float32)


def _shape_error(merged, truth):
    """The median relative error once the one scale a curve cannot fix (its units) is taken out."""
    held = truth.max(axis=-1) < 3.0
    ratio = merged[held] / np.maximum(truth[held], 1e-6)
    return float(np.median(np.abs(ratio / np.median(ratio) - 1.0)))


def test_a_set_the_srgb_curve_explains_keeps_it(city):
    """The evaluation's camera (sRGB, JPEG q90): its own curve explains it no better, so sRGB stays, and the merge is
    bit for bit the one without the recovery."""
    frames = [hdr_to_ldr(city, ev, 90) for ev in EVS]
    r = recover_response(frames, [2.0 ** ev for ev in EVS], 1)
    assert r.name == "sRGB" and r.table is SRGB8_TO_LINEAR
    assert r.disagreement["recovered"] > 0.35 * r.disagreement["sRGB"]
    merged, info = merge_brackets(frames, [2.0 ** ev for ev in EVS])
    plain, _ = merge_brackets(frames, [2.0 ** ev for ev in EVS], response=False)
    assert info["response"]["curve"] == "sRGB" and merged.tobytes() == plain.tobytes()


@pytest.mark.parametrize("curve, param", CAMERAS)
def test_a_camera_s_own_curve_is_recovered_and_merges_the_set_true(city, curve, param):
    """A gamma-2.8 camera, an S-curve profile and a highlight shoulder (JPEG q90): the recovered curve has the
    camera's shape (within 8 % over the codes the frames pin), and the merge comes within 3 % of the truth's shape,
    half sRGB decoding's error or less (7-60 %)."""
    frames = [hdr_to_ldr(city, ev, 90, scale=2.0 ** ev, curve=curve, curve_param=param) for ev in EVS]
    r = recover_response(frames, [2.0 ** ev for ev in EVS], 1)
    assert r.name == "recovered" and r.disagreement["recovered"] < 0.2 * r.disagreement["sRGB"]
    truth = _inverse(curve, param)
    codes = np.arange(40, 240)
    shape = r.table[codes] / truth[codes]
    assert np.max(np.abs(shape / np.median(shape) - 1.0)) < 0.08
    assert r.table[0] == 0.0 and np.all(np.diff(r.table) >= 0)
    merged, info = merge_brackets(frames, [2.0 ** ev for ev in EVS])
    plain, _ = merge_brackets(frames, [2.0 ** ev for ev in EVS], response=False)
    assert info["response"]["curve"] == "recovered" and "less under their own curve" in info["response"]["why"]
    # the sun, clipped in every frame, is the merged file's plateau: above every value a frame holds
    assert info["clipped_in_every_frame"] > 0 and float(merged.max()) == pytest.approx(info["ceiling"])
    assert find_ceiling(merged).rgb == pytest.approx((info["ceiling"],) * 3)
    assert _shape_error(merged, city) < min(0.03, 0.5 * _shape_error(plain, city))
    # units: the radiance at which the camera reaches code 250 comes out where sRGB puts it (0.955)
    held = city.max(axis=-1) < 3
    scale = float(np.median(merged[held] / city[held]))
    assert scale == pytest.approx(float(SRGB8_TO_LINEAR[250]) / truth[250], rel=0.1)


def test_two_frames_keep_srgb_and_say_why(city):
    frames = [hdr_to_ldr(city, ev, scale=2.0 ** ev, curve="gamma", curve_param=2.8) for ev in (0, 2)]
    r = recover_response(frames, [1.0, 4.0], 0)
    assert r.name == "sRGB" and "2 frames pin too little" in r.why
