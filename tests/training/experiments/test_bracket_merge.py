"""training.experiments.bracket_merge: the two rules it measures are swapped for the old ones and put back, and its
scores see what they say."""

import numpy as np

from panolight_core.camera import blend, response
from panolight_core.camera.resample import area_downsample
from panolight_core.data import load_studio_hdri
from training.experiments import bracket_merge


def test_the_old_rules_hold_only_inside_and_the_shipped_ones_come_back():
    ringing = np.full((32, 32), 240, np.uint8)
    ringing[0, 0] = 255  # one clipped code: its 16 x 16 block rings
    assert blend.clipped_or_ringing(ringing)[5, 5]
    with bracket_merge.ring_rule(False):
        assert not blend.clipped_or_ringing(ringing)[5, 5] and blend.clipped_or_ringing(ringing)[0, 0]
    assert blend.clipped_or_ringing(ringing)[5, 5]
    shipped = response.RESPONSE_GAIN
    with bracket_merge.response_gain(bracket_merge.OLD_GAIN):
        assert response.RESPONSE_GAIN == 0.35
    assert response.RESPONSE_GAIN == shipped == 0.7


def test_scores_count_dark_rings_and_midtone_error():
    hdr = np.full((4, 8, 3), 0.2)
    hdr[0, 0] = 50.0
    truth = hdr * bracket_merge.auto_exposure(hdr, 0.0)
    merged = truth.copy()
    merged[0, 0] = 0.1  # the bright pixel merged far under the ceiling
    assert bracket_merge.dark_ring_pixels(hdr, merged, 1.0) == 1
    assert bracket_merge.dark_ring_pixels(hdr, truth, 1.0) == 0
    ramp = np.linspace(0.02, 0.8, 64)[:, None, None] * np.ones((1, 1, 3))
    scale = 1 / bracket_merge.auto_exposure(ramp, 0.0)
    assert bracket_merge.midtone_error(ramp * scale, 3.0 * ramp) < 1e-9  # one scale off: no error
    assert bracket_merge.midtone_error(ramp * scale, ramp ** 1.1) > 0.03  # a curve off: seen (0.045)


def test_the_ring_rule_clears_a_sun_sets_dark_ring():
    forest = area_downsample(load_studio_hdri("forest"), 256)
    row = bracket_merge.ring_row(forest)
    assert row["without"] > 40 and row["with"] == 0  # 92 pixels to none here
    assert bracket_merge.srgb_share(forest, (-2, 0, 2)) > response.RESPONSE_GAIN  # an sRGB set stays on sRGB (0.96)


def test_the_gain_study_counts_sets_made_worse_first():
    """gain_summary: a set whose error passes 1.1x + 0.002 of the other gate's is worse; a curve change is counted
    as moved whatever its error; errors within the margin are neither."""
    def row(camera, a, b, curve_b="sRGB"):
        return {"camera": camera, "0.7": {"curve": "sRGB", "error": a}, "1": {"curve": curve_b, "error": b}}

    rows = {"x": [row("sRGB -2..+2", 0.010, 0.020, "recovered"), row("gamma 2.25", 0.010, 0.0105)],
            "y": [row("sRGB -2..+2", 0.030, 0.010, "recovered")]}
    s = bracket_merge.gain_summary(rows, (0.7, 1.0))
    assert (s["sets"], s["worse"], s["better"], s["moved"]) == (3, 1, 1, 2)
    assert s["worse_sets"] == ["x: sRGB -2..+2"]
    assert s["median_error_by_camera"]["sRGB -2..+2"] == {"sets": 2, "moved": 2, "0.7": 0.02, "1": 0.015}
