"""training.experiments.bracket_alignment: still frames stay, moved frames are put back."""
import numpy as np

from panolight_core.data import load_studio_hdri
from training.experiments import bracket_alignment

from ..keylight.test_hidden_sun import _write_hdr


def test_a_still_set_stays_and_a_moved_one_is_put_back(tmp_path):
    path = _write_hdr(tmp_path, load_studio_hdri("city").astype(np.float64))
    got = bracket_alignment.scene_shifts(path, 2, -30)
    assert got["still_ok"] == 4 and got["moved_ok"] >= 3
    assert got["moved"]["-2.0"] == [-2, 30]
