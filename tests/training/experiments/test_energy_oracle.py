"""training.experiments.energy_oracle: a restored file's key light given the truth's energy, and the ways of
combining its two estimates."""
import math

import pytest

from panolight_core.data import load_studio_hdri
from training.experiments import energy_oracle

from ..keylight.test_hidden_sun import _write_hdr


def test_the_key_light_at_the_truth_s_energy_scores_no_worse_than_shipped_and_the_best_factor_is_a_bound(tmp_path):
    path = _write_hdr(tmp_path, load_studio_hdri("city"))  # Blender's city: its sun clipped at +4 stops
    row = energy_oracle.scene_row(path, 4.0)
    assert row["best"] <= min(row["oracle"], row["shipped"]) + 1e-12
    assert row["oracle"] < 0.5 and row["key_angle_deg"] < 2.0 and row["method"].startswith("clear-sky fit")
    # the light's energy is the geometric mean of its two estimates: their r bracket the scene's, in log
    assert math.log(row["trees_r"]) + math.log(row["fit_r"]) == pytest.approx(2.0 * math.log(row["r"]), abs=1e-9)


def test_combinations_weigh_the_two_estimates_in_log():
    suns = [{"trees_r": 2.0, "fit_r": 0.5, "trees_sigma": 1.0, "key_angle_deg": 0.5},
            {"trees_r": 4.0, "fit_r": 1.0, "trees_sigma": 1.0, "key_angle_deg": 0.5},
            {"trees_r": 4.0, "fit_r": 1.0, "trees_sigma": 1.0, "key_angle_deg": 30.0}]  # off the truth: left out
    got = energy_oracle.combinations(suns)
    assert got["suns"] == 2
    assert got["w=0.5"] == pytest.approx(2.0 ** 0.5)  # |0| and |1| stops: median 0.5
    assert got["w=1"] == pytest.approx(2.0 ** 1.5) and got["w=0"] == pytest.approx(2.0 ** 0.5)
    assert got["inverse variance, fit sigma 1.00"] == pytest.approx(got["w=0.5"])


def _sunny_field(lit_over_shadow: float, w: int = 512):
    """A uniform sky of radiance 1 over +Z, a 3-degree sun 40 degrees up carrying 3 pi of irradiance on the ground
    (so the truth's G = 1 + 3 pi / pi = 4), and a ground half in sun, half in shadow, ``lit_over_shadow`` apart."""
    import numpy as np

    from panolight_core import sh

    h = w // 2
    dirs, omega = sh.pixel_directions(h, w), sh.pixel_solid_angles(h, w)
    el = math.radians(40.0)
    sun_dir = np.array([math.cos(el), 0.0, math.sin(el)])
    disk = dirs @ sun_dir >= math.cos(math.radians(3.0))
    lum = np.where(dirs[..., 2] > 0, 1.0, 0.0)
    lum[disk] = 1.0 + 3.0 * math.pi / (omega[disk].sum() * math.sin(el))
    ground = dirs[..., 2] < 0
    lum[ground] = np.where(dirs[ground][:, 1] > 0, 0.1 * lit_over_shadow, 0.1)
    return np.repeat(lum[..., None], 3, axis=2), sun_dir


def test_the_ground_reads_its_lit_over_shadowed_contrast_and_the_truth_s_sun_over_its_sky():
    hdr, sun_dir = _sunny_field(4.0)
    got = energy_oracle.ground_contrast(hdr, sun_dir)
    assert got["ground_g"] == pytest.approx(4.0, rel=1e-9)  # the two halves are the two means
    # the truth's cone less its ring: the disk's discretised edge and the sky it covers cost a few per cent
    assert got["true_g"] == pytest.approx(4.0, rel=0.05)
    assert got["ground_r"] == pytest.approx(1.0, rel=0.08)
    weak = energy_oracle.ground_contrast(_sunny_field(2.0)[0], sun_dir)
    assert weak["ground_r"] == pytest.approx(1.0 / 3.0, rel=0.08)  # G - 1 = 1 against the truth's 3


def test_the_ground_s_weight_in_log_moves_the_shipped_mean_toward_it():
    suns = [{"trees_r": 2.0, "fit_r": 2.0, "ground_r": 0.5, "key_angle_deg": 0.1}]
    got = energy_oracle.with_ground(suns, weights=(0.0, 0.5, 1.0))
    assert got["ground weight 0.00"]["within"] == pytest.approx(2.0)
    assert got["ground weight 0.50"]["within"] == pytest.approx(1.0)
    assert got["ground weight 1.00"]["within"] == pytest.approx(2.0)
    assert got["ground weight 0.00"]["over_3x"] == 0
