"""training.keylight.hidden_sun: the sky-alone location of a masked sun, and the census of invented suns."""
import math

import numpy as np
import pytest

from panolight_core import sh
from panolight_core.camera.color import LUMINANCE_WEIGHTS
from panolight_core.estimators import keylight, sky, sun_search
from training.keylight import hidden_sun


def _sky_hdr(with_sun: bool, h: int = 256):
    """The tabulated clear sky (sun 40 degrees up, turbidity 3) over a dark ground, as an HDR; with its solar
    disk's energy in the pixel that holds the sun, or without it and with the 20 degrees around the sun painted
    at that ring's level (retouched out). Returns (hdr, sun direction)."""
    t = sky.load_sky_table()
    j = int(np.argmin(abs(t.turbidities - 3.0)))
    e, az = math.radians(40.0), 1.0
    s = np.array([math.cos(e) * math.cos(az), math.cos(e) * math.sin(az), math.sin(e)])
    d = sh.pixel_directions(h, 2 * h)
    hdr = t.sky_radiance(d.reshape(-1, 3), s)[j].reshape(h, 2 * h, 3)
    hdr[d[..., 2] <= 0] = 0.03 * float(np.median(hdr[d[..., 2] > 0] @ LUMINANCE_WEIGHTS))
    ang = np.degrees(np.arccos(np.clip(d @ s, -1, 1)))
    if with_sun:
        y, x = sh.grid.pixel_at(s, h, 2 * h)
        hdr[y, x] += t.sun_energy(40.0)[j] / sh.pixel_solid_angles(h, 2 * h)[y, x]
    else:
        hdr[ang < 20.0] = hdr[(abs(ang - 20.0) < 1.0) & (d[..., 2] > 0)].mean(axis=0)
    return hdr, s


def test_a_masked_sun_is_located_and_weighed_from_its_sky():
    hdr, s = _sky_hdr(with_sun=True)
    row = hidden_sun.located(hdr, -2.0, 20.0)
    assert row["found"] and row["angle_deg"] <= sun_search.REFINE_STEP_DEG
    # the model's own sky: the physics is exact, so the ratio is the real-sky correction alone
    assert row["energy_ratio"] / keylight.PARAMS.sky_correction == pytest.approx(1.0, rel=0.25)
    assert hidden_sun.located(_sky_hdr(with_sun=False)[0], -2.0, 20.0) is None  # no dominant source: not scored


def test_the_census_counts_a_sun_the_truth_does_not_have_as_false():
    hdr, s = _sky_hdr(with_sun=False)
    row = hidden_sun.invented(hdr, -2.0)  # ev -2: enough of the sky unclipped
    assert not row["dominant"] and len(row["hidden"]) == 1 and not row["hidden"][0]["right"]
    got = hidden_sun.summary([dict(row, kind="invented", scene="retouched", clipped_truth=False)], [-2.0])["-2"]
    assert got["hidden_suns"] == 1 and got["right"] == 0 and got["false"][0].startswith("retouched")
    assert got["found"] == 0 and got["median_angle_deg"] is None


def test_the_picture_draws_the_search_and_says_what_lighting_json_says(tmp_path):
    from PIL import Image

    from panolight_core.camera import hdr_to_ldr
    from panolight_core.io import write_srgb8

    hdr, s = _sky_hdr(with_sun=False)
    photo = write_srgb8(tmp_path / "retouched.png", hdr_to_ldr(hdr, -2.0))
    report = hidden_sun.picture(photo, tmp_path / "search.jpg", width=256)
    assert report["searched"] and report["hidden_sun"] and report["refused"] == []
    img = np.asarray(Image.open(tmp_path / "search.jpg"))
    assert img.shape == (128, 256, 3)
    y, x = sh.grid.pixel_at(np.asarray(report["direction"]), 128, 256)
    assert img[y, x].min() > 200  # the search's sun is drawn (white: a hidden sun was made)
    with pytest.raises(SystemExit, match="8-bit photo"):
        hidden_sun.picture(_write_hdr(tmp_path, hdr), tmp_path / "x.png")


def _write_hdr(tmp_path, hdr):
    from panolight_core.io import write_image

    path = tmp_path / "sky.exr"
    write_image(path, hdr.astype(np.float32))
    return path


def test_retouching_paints_the_source_out_and_the_whole_estimate_brings_it_back():
    hdr, s = _sky_hdr(with_sun=True)
    painted = hidden_sun.retouch(hdr, s, 20.0)
    d = sh.pixel_directions(*hdr.shape[:2])
    near = d @ s > math.cos(math.radians(20.0))
    assert np.ptp(painted[near], axis=0).max() == 0 and np.array_equal(painted[~near], hdr[~near])
    assert painted[near].max() < hdr[near].max() / 100  # the sun is gone
    row = hidden_sun.retouched(hdr, -2.0, 20.0)
    key, plain = row["keylight"], row["sources"]
    assert key["hidden_sun"] and key["angle_deg"] < key["direction_68_deg"]
    assert plain["ratio"] < 0.05 < key["ratio"]  # the retouched photo alone shows no sun; the sky puts it back
    assert key["m_rmse_over_naive"] < plain["m_rmse_over_naive"]
