"""training.experiments.small_inputs: one scene's JPEG and clipped HDR at several widths, scored against the truth
at each width."""
import math

import numpy as np
import pytest

from panolight_core.data import load_studio_hdri
from training.experiments import small_inputs

from ...panolight_core.estimators.test_keylight import _lamps
from ..keylight.test_hidden_sun import _write_hdr


def test_each_width_scores_the_jpeg_and_the_restored_file_against_its_own_truth(tmp_path):
    path = _write_hdr(tmp_path, load_studio_hdri("city"))  # Blender's city: its sun clipped at +4 stops
    rows = small_inputs.scene_rows(path, widths=(512, 128), stops=4.0)
    assert [(r["capture"], r["width"]) for r in rows] == [
        ("JPEG, 512 wide", 512), ("HDR clipped at +4 stops, restored, 512 wide", 512),
        ("JPEG, 128 wide", 128), ("HDR clipped at +4 stops, restored, 128 wide", 128)]
    for jpeg in rows[0::2]:  # a JPEG's own projection is the naive baseline
        assert jpeg["m_rmse_over_naive"] == pytest.approx(jpeg["m_rmse_over_own"], rel=1e-12)
    restored = rows[1]
    assert 0.5 < restored["ratio"] < 2.0 and restored["angle_deg"] < 2.0  # 512 wide: the sun comes back
    assert all(math.isfinite(r["m_rmse"]) and r["true_contrast"] == rows[0]["true_contrast"] for r in rows)


def test_a_photo_made_narrower_keeps_its_key_light_and_is_warned_of_below_512(tmp_path):
    from panolight_core.camera import hdr_to_ldr, ldr_to_linear
    from panolight_core.io import write_image

    lamp = np.array([0.2, 0.5, 0.8]) / np.linalg.norm([0.2, 0.5, 0.8])
    photo = write_image(tmp_path / "room.jpg", ldr_to_linear(hdr_to_ldr(_lamps([lamp], h=512), 0.0)))  # 1024 wide
    rows = small_inputs.photo_rows(photo, widths=(2048, 512, 256))
    assert [r["width"] for r in rows] == [1024, 512, 256]  # its own size first, never a wider one
    assert rows[0]["key_over_full"] == 1.0 and rows[0]["angle_from_full_deg"] == 0.0
    assert all(0.5 < r["key_over_full"] < 2.0 and r["angle_from_full_deg"] < 3.0 for r in rows)
    assert [r["narrow_warning"] for r in rows] == [False, False, True]
