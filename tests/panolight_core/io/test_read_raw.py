"""Camera RAWs through rawpy (LibRaw), on DNGs the tests write themselves (tifffile): a Bayer mosaic of a known
linear scene, with a black level, a white level, an as-shot white balance and a colour matrix."""
import sys

import numpy as np
import pytest
import tifffile

from panolight_core.camera.ceiling import find_ceiling
from panolight_core.errors import ImageError
from panolight_core.io import read_image, sniff_format
from panolight_core.io.capture import read_exposure
from panolight_core.io.dng import write_dng
from panolight_core.io.read_raw import read_raw


def _scene(h=128, w=256):
    """A smooth linear scene (demosaicing is exact on it, away from the edges) with a bright 10 x 10 patch."""
    y, x = np.mgrid[0:h, 0:w]
    img = np.stack([0.2 + 0.3 * x / w, 0.3 + 0.2 * y / h, np.full((h, w), 0.25)], axis=-1)
    img[10:20, 100:110] = 50.0
    return img


def test_a_dng_reads_as_its_linear_scene_in_sensor_white_units(tmp_path):
    scene = _scene()
    path = write_dng(tmp_path / "a.dng", scene, scale=0.1)
    assert sniff_format(path) == "raw"
    px, record = read_raw(path)
    assert px.dtype == np.float32 and px.shape == scene.shape
    inner = np.s_[40:100, 20:236]  # away from the patch and the mosaic's border
    np.testing.assert_allclose(px[inner], 0.1 * scene[inner], rtol=1e-2)  # black off, white balanced, no curve (to the 12-bit counts)
    assert record["white_level"] == 15000 and record["black_level"] == [512] * 4
    assert record["white_balance"] == "as shot" and record["multipliers"] == pytest.approx([2.0, 1.0, 1.25], rel=1e-4)
    core = px[12:18, 102:108]
    assert (core == 1.0).all()  # clipped by the sensor: exactly its white in every channel
    assert record["sensor_clipped_fraction"] == pytest.approx((px == 1.0).all(-1).mean())
    ceiling = find_ceiling(px)  # the plateau the restoration fills
    assert ceiling is not None and ceiling.rgb == (1.0, 1.0, 1.0) and ceiling.pixels >= 36
    np.testing.assert_array_equal(read_image(path), px)  # the CLI's reader takes the same path


def test_an_unclipped_raw_has_no_ceiling(tmp_path):
    """A peaked bright spot under the sensor's white: nothing is restored."""
    scene = _scene()
    y, x = np.mgrid[0:128, 0:256]
    scene[:] = np.minimum(scene, 1.0)
    scene += (4.0 * np.exp(-((y - 15.3) ** 2 + (x - 104.7) ** 2) / 8.0))[..., None]
    px, record = read_raw(write_dng(tmp_path / "b.dng", scene, scale=0.2))
    assert px.max() < 1.0 and record["sensor_clipped_fraction"] == 0.0
    assert find_ceiling(px) is None


def test_the_files_orientation_is_applied(tmp_path):
    """A mosaic stored upright-turned (TIFF orientation 6: shown turned 90 degrees clockwise) reads 2:1, upright."""
    scene = _scene()
    stored = np.rot90(scene, 1)  # what turns clockwise into the scene
    px, _ = read_raw(write_dng(tmp_path / "c.dng", stored, scale=0.1, orientation=6))
    assert px.shape == scene.shape
    np.testing.assert_allclose(px[40:100, 20:236], 0.1 * scene[40:100, 20:236], rtol=1e-2)


def test_the_exposure_comes_from_the_raw(tmp_path):
    path = write_dng(tmp_path / "d.dng", _scene(), scale=0.1, time_s=1 / 250, f_number=8.0)
    assert read_exposure(path) == {"time_s": pytest.approx(1 / 250), "f_number": pytest.approx(8.0), "iso": 100.0,
                                   "taken_s": None, "iso_recorded": False, "bias_ev": None, "manual": False}  # no ISO: 100 assumed
    assert read_exposure(write_dng(tmp_path / "e.dng", _scene(), scale=0.1)) is None


def test_bad_raws_are_refused_in_one_line_naming_the_file(tmp_path):
    plain = tmp_path / "plain.dng"  # a plain TIFF under a RAW's name (a .tif is read as a TIFF picture)
    tifffile.imwrite(plain, np.zeros((64, 128, 3), np.uint16), photometric="rgb")
    with pytest.raises(ImageError, match=r"plain\.dng: .*cannot read it as a camera RAW"):
        read_image(plain)
    good = write_dng(tmp_path / "good.dng", _scene(), scale=0.1)
    cut = tmp_path / "cut.dng"
    cut.write_bytes(open(good, "rb").read()[:3000])
    with pytest.raises(ImageError, match=r"cut\.dng: ") as err:
        read_image(cut)
    assert "\n" not in str(err.value)
    square = write_dng(tmp_path / "square.dng", np.full((64, 64, 3), 0.2), scale=0.1)
    with pytest.raises(ImageError, match=r"square\.dng: .*2:1"):
        read_image(square)
    with pytest.raises(ImageError, match=r"good\.dng: .*decode budget"):
        read_image(good, max_megapixels=0.01)


def test_without_rawpy_a_raw_is_refused_with_the_remedy(tmp_path, monkeypatch):
    path = write_dng(tmp_path / "f.dng", _scene(), scale=0.1)
    monkeypatch.setitem(sys.modules, "rawpy", None)  # as in a stock Blender
    with pytest.raises(ImageError, match=r"f\.dng: a camera RAW needs rawpy"):
        read_image(path)
    assert read_exposure(path) is None


def test_a_raw_without_an_as_shot_white_balance_says_it_took_daylight(tmp_path):
    """No AsShotNeutral: LibRaw's daylight balance from the colour matrix (here the identity, so the sensor's own
    cast stays), and the record says so instead of claiming the camera's."""
    from panolight_core.io.dng import Sensor

    scene = _scene()
    px, record = read_raw(write_dng(tmp_path / "g.dng", scene, scale=0.1, sensor=Sensor(as_shot=False)))
    assert record["white_balance"].startswith("daylight") and record["multipliers"] is None
    cast = (px[40:100, 20:236] / (0.1 * scene[40:100, 20:236])).reshape(-1, 3).mean(axis=0)
    np.testing.assert_allclose(cast, Sensor().neutral, rtol=0.01)
