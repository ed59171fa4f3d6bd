"""training.keylight.cv: the tone-curve picture of one scene."""
import numpy as np
import pytest

from panolight_core import sh
from training.common.study import SRGB
from training.keylight import cv

from .test_hidden_sun import _sky_hdr, _write_hdr


def test_the_curve_picture_draws_each_camera_with_the_source_and_the_key_light(tmp_path):
    from PIL import Image

    hdr, s = _sky_hdr(with_sun=True)  # 256 x 512, a clear sky with its sun 40 degrees up
    path = _write_hdr(tmp_path, hdr)
    rows = cv.curve_picture(path, tmp_path / "curves.png", 0.0, curves=(SRGB, ("contrast", 1.6)), width=256)
    assert [r["curve"] for r in rows] == [["srgb", None], ["contrast", 1.6]]
    assert all(0.0 <= r["angle_deg"] <= 180.0 and r["ratio"] >= 0.0 for r in rows)
    img = np.asarray(Image.open(tmp_path / "curves.png").convert("RGB")).astype(int)
    assert img.shape == (2 * 128, 256, 3)  # the upper half of 180 degrees of azimuth, once per curve, at scale 1
    y, _ = sh.grid.pixel_at(s, 256, 512)
    ring = 5.0 / 180.0 * 256  # the 5-degree cone around the true sun, which sits mid-panel
    box = img[y - 3:y + 4, int(128 + ring) - 3:int(128 + ring) + 4]
    assert ((box[..., 0] > 200) & (box[..., 1] > 180) & (box[..., 2] < 90)).any()  # its yellow ring
    red = (img[..., 0] > 200) & (img[..., 1] < 150)  # the clipped pixels are tinted red, more through the S-curve
    assert red[128:].sum() > red[:128].sum() > 0
    d = sh.pixel_directions(64, 128)
    flat = np.where(d[..., 2:] > 0, 1.0, 0.1) * np.ones(3)  # an even sky over a dark ground: no compact source
    with pytest.raises(SystemExit, match="no dominant compact source"):
        cv.curve_picture(_write_hdr(tmp_path, flat), tmp_path / "x.png")


def test_each_scene_row_has_the_shadow_contrast_and_the_summary_how_far_it_is(tmp_path):
    """EVALUATION.md's shadow: C of a surface facing the true sun, estimated (the brightest light's share of
    the model's irradiance there) and true (the HDR's 5 degrees less their ring), summarised as "within 2^x"."""
    from panolight_core import metrics
    from panolight_core.camera import hdr_to_ldr
    from panolight_core.pipeline import Settings, estimate_lighting
    from training.common.real_hdri import load_hdr

    path = _write_hdr(tmp_path, _sky_hdr(with_sun=True)[0])
    (row,) = rows = cv.score_scene(path, [0.0], clipped=False)
    hdr = load_hdr(path)
    ds = metrics.dominant_source(hdr)
    assert row["true_contrast"] == pytest.approx(metrics.true_shadow_contrast(hdr, ds["direction"]), rel=1e-12)
    assert row["true_contrast"] > 1.5
    model = estimate_lighting(hdr_to_ldr(hdr, 0.0, 90), Settings()).model
    assert row["contrast"] == pytest.approx(metrics.model_shadow_contrast(model, ds["direction"]), rel=1e-12)
    assert row["contrast"] > 1.0  # (a second run of the estimate may differ in the last bit)
    summary = cv.summary(rows, 0.0)
    ratio = row["contrast"] / row["true_contrast"]
    assert summary["contrast_within"] == pytest.approx(2 ** abs(np.log2(ratio))) and summary["contrast_worst"] == ratio
    assert 0 < row["m_rmse"] < row["naive_m_rmse"]  # a clipped sun: the key light beats sRGB -> linear
    assert summary["m_rmse_over_naive_median"] == row["m_rmse"] / row["naive_m_rmse"] and summary["blinding"] == [] and summary["harmed"] == 0
