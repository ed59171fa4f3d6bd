"""A camera RAW, and a set of RAW brackets, through ``panolight estimate`` and ``batch``: read linear in the sensor's
white, its clipped sun restored as an HDR's is, recorded in lighting.json."""
import json

import numpy as np
import pytest

from panolight_core import metrics
from panolight_core.apps.cli import main
from panolight_core.camera import hdr_to_ldr
from panolight_core.io import read_image
from panolight_core.io.dng import write_dng
from tests.panolight_core.estimators.sources.test_restore import _clear_day

RAW_WHITE = 4.0  # the sensor's white at the ev-0 JPEG's exposure: 2 stops of highlight headroom over its white


@pytest.fixture(scope="module")
def day():
    return _clear_day()


def test_a_raw_s_clipped_sun_is_restored_and_recorded(tmp_path, day):
    truth, s, _ = day
    path = write_dng(tmp_path / "day.dng", truth, scale=1 / RAW_WHITE)
    assert main(["estimate", path, "-o", str(tmp_path / "out"), "-q"]) == 0
    doc = json.loads((tmp_path / "out" / "lighting.json").read_text())
    assert doc["source"]["dynamic_range"] == "raw-linear"
    raw = doc["source"]["raw"]
    assert raw["white_level"] == 15000 and raw["white_balance"] == "as shot" and raw["sensor_clipped_fraction"] > 0
    restoration = doc["estimator"]["restoration"]
    assert restoration["restored"] and restoration["ceiling"] == [1.0, 1.0, 1.0]
    key = metrics.brightest_light(doc["lights"])
    assert metrics.angle_deg(key["direction"], s) < 1.0
    out = read_image(tmp_path / "out" / "hdr.exr")
    px = read_image(path)
    plateau = (px == 1.0).sum(axis=-1) >= 2
    assert np.array_equal(out[~plateau], px[~plateau])  # every pixel the sensor held, as LibRaw gave it
    true = metrics.cone_energy(truth / RAW_WHITE, s)
    assert metrics.cone_energy(px, s) < 0.2 * true  # the RAW held a small part of its sun ...
    assert 0.25 < metrics.cone_energy(out, s) / true < 4.0  # ... and hdr.exr holds about all of it


def test_raw_brackets_merge_by_their_own_exposures(tmp_path, day):
    """Three RAWs at 1/1000, 1/250 and 1/62.5 s, f/8 (-2, 0, +2 stops, from the files): merged in the reference
    frame's sensor white, the sun clipped in every frame restored."""
    truth, s, _ = day
    files = [write_dng(tmp_path / f"r{i}.dng", truth, scale=k / RAW_WHITE, time_s=t, f_number=8.0)
             for i, (k, t) in enumerate(((0.25, 1 / 1000), (1.0, 1 / 250), (4.0, 1 / 62.5)))]
    assert main(["estimate", *files, "-o", str(tmp_path / "out"), "-q"]) == 0
    doc = json.loads((tmp_path / "out" / "lighting.json").read_text())
    b = doc["source"]["brackets"]
    assert doc["source"]["dynamic_range"] == "hdr-merged-brackets" and b["exposures_from"].startswith("EXIF")
    assert b["stops"] == pytest.approx([-2, 0, 2], abs=0.01) and b["ceiling"] == pytest.approx(4.0, rel=0.01)
    assert doc["estimator"]["restoration"]["restored"]
    assert metrics.angle_deg(metrics.brightest_light(doc["lights"])["direction"], s) < 1.0


def test_a_set_mixing_raws_and_pictures_is_refused(tmp_path, day, capsys):
    truth, _, _ = day
    from panolight_core.io import write_image

    jpeg = tmp_path / "a.jpg"
    write_image(jpeg, hdr_to_ldr(truth, 0.0).astype(np.float32) / 255.0)
    raw = write_dng(tmp_path / "b.dng", truth, scale=1 / RAW_WHITE)
    assert main(["estimate", str(jpeg), raw, "--evs=0,2", "-o", str(tmp_path / "out"), "-q"]) != 0
    err = capsys.readouterr().err
    assert "b.dng: a camera RAW, but a.jpg is not" in err and "Traceback" not in err
    assert not (tmp_path / "out").exists()


def test_batch_finds_raws_in_a_folder(tmp_path, day):
    truth, _, _ = day
    shots = tmp_path / "shots"
    shots.mkdir()
    write_dng(shots / "IMG_0001.DNG", truth, scale=1 / RAW_WHITE)
    assert main(["batch", str(shots), "-o", str(tmp_path / "out"), "--jobs", "1", "-q"]) == 0
    doc = json.loads((tmp_path / "out" / "IMG_0001" / "lighting.json").read_text())
    assert doc["source"]["dynamic_range"] == "raw-linear"
