"""camera.blend: the per-pixel merge against an independent float64 weighted log average, block by block."""
import numpy as np

from panolight_core.camera.blend import Blend
from panolight_core.camera.response import SRGB
from panolight_core.camera.weights import noise_weights


def _frames(rng, shape=(40, 80)):
    """Three frames of codes under 230 (no ringing rule at work) and one pixel clipped in every frame."""
    frames = [rng.integers(0, 230, shape + (3,), dtype=np.uint8) for _ in range(3)]
    for f in frames:
        f[7, 9] = 255
    return frames


def test_blend_is_the_worst_channel_weighted_log_average_in_float64_and_a_pixel_clipped_everywhere_takes_the_ceiling():
    rng = np.random.default_rng(5)
    frames = _frames(rng)
    rel = np.array([0.25, 1.0, 4.0])
    blend = Blend(frames, None, rel, 1, SRGB, ghosts=False, ceiling=4.0)
    out = np.empty(frames[0].shape, np.float32)
    clipped = blend.merge_rows(out, 0, 40)
    table = SRGB.table.astype(np.float64)
    weight = noise_weights(SRGB.table).astype(np.float64)
    num = np.zeros(out.shape)
    den = np.zeros(out.shape[:2])
    for f, k in zip(frames, rel):
        w = weight[f.max(axis=-1)]
        num += w[..., None] * np.log(np.maximum(table[f], 0.5 * table[1]) / k)
        den += w
    want = np.exp(num / np.where(den > 0, den, 1.0)[..., None])
    ok = den > 0
    assert clipped == 1 and not ok[7, 9] and ok.sum() == ok.size - 1
    np.testing.assert_allclose(out[ok], want[ok], rtol=2e-5)
    assert (out[7, 9] == 4.0).all()


def test_blend_rows_are_the_same_numbers_in_any_blocks_and_for_linear_frames_of_the_same_codes():
    rng = np.random.default_rng(6)
    frames = _frames(rng)
    rel = np.array([0.25, 1.0, 4.0])
    whole = np.empty(frames[0].shape, np.float32)
    Blend(frames, None, rel, 1, SRGB, ghosts=True, ceiling=4.0).merge_rows(whole, 0, 40)
    parts = np.empty_like(whole)
    blend = Blend(frames, None, rel, 1, SRGB, ghosts=True, ceiling=4.0)
    for r0, r1 in ((0, 16), (16, 32), (32, 40)):
        blend.merge_rows(parts, r0, r1)
    assert np.array_equal(whole, parts)
    linear = [SRGB.table[f].astype(np.float32) for f in frames]  # a RAW's values that round to the same codes
    raw = np.empty_like(whole)
    Blend(frames, linear, rel, 1, SRGB, ghosts=True, ceiling=4.0).merge_rows(raw, 0, 40)
    np.testing.assert_allclose(raw, whole, rtol=1e-5)
