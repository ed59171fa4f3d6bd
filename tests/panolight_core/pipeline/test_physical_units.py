"""Physical units through the pipeline (issue 60): a camera made to the convention gives its scene's cd/m^2, a light
meter's --lux is the model's upward illuminance, and a bracket set agrees with its own frames on the scale."""
import json
import math
from pathlib import Path

import numpy as np
import pytest

from panolight_core import sh
from panolight_core.camera import hdr_to_ldr, units
from panolight_core.camera.color import LUMINANCE_WEIGHTS
from panolight_core.errors import PanoLightError
from panolight_core.pipeline import Settings, estimate_lighting, run_estimate
from panolight_core.pipeline.brackets import BracketSet

from .test_brackets import _city, _frame

EXIF = {"time_s": 1 / 100, "f_number": 8.0, "iso": 200.0}  # EV100 = log2(64 / 0.01) - 1 = 11.64


def _sky_in_cd_m2(h=64):
    """A smooth scene in cd/m^2 (a sky 3000 at the zenith, 1000 at the horizon, a ground of 400) that a camera at
    EXIF's exposure (white 3,840 cd/m^2) holds without clipping."""
    d = sh.pixel_directions(h, 2 * h)
    z = d[..., 2:3]
    lum = np.where(z > 0, 1000.0 + 2000.0 * z, 400.0)
    return lum * np.array([0.9, 1.0, 1.15]) / (np.array([0.9, 1.0, 1.15]) @ LUMINANCE_WEIGHTS)


def test_a_camera_made_to_the_convention_gives_its_scene_s_luminance():
    """Exact arithmetic: the photo is the scene over the white 1.2 x 2^EV100 cd/m^2 its EXIF gives, in sRGB; the
    naive projection, made absolute, is the scene's own within 2 % (8-bit steps)."""
    scene = _sky_in_cd_m2()
    white = units.white_luminance(units.ev100(**EXIF))
    assert white == pytest.approx(1.2 * 2 ** (math.log2(6400) - 1))
    ldr = hdr_to_ldr(scene, scale=1.0 / white)
    got = estimate_lighting(ldr, Settings(estimator="naive", model="sh", lmax=2, absolute=True), exposure=EXIF)
    want = sh.project(scene, 2)
    assert got.document["physical"]["from"] == "exif" and got.document["physical"]["applied"]
    assert got.document["units"].startswith("cd/m^2")
    assert float(got.model.coeffs[0] @ LUMINANCE_WEIGHTS) == pytest.approx(float(want[0] @ LUMINANCE_WEIGHTS), rel=0.02)
    up = got.document["physical"]["upward_illuminance_lux"]  # the upper hemisphere's cosine-weighted integral
    assert up == pytest.approx(math.pi * (1000.0 + 2000.0 * 2.0 / 3.0), rel=0.03)
    assert Settings().absolute  # the default where a scale is known; --relative keeps the files relative
    relative = estimate_lighting(ldr, Settings(estimator="naive", model="sh", lmax=2, absolute=False), exposure=EXIF)
    assert not relative.document["physical"]["applied"] and relative.document["units"].startswith("relative")
    assert relative.document["physical"]["upward_illuminance_lux"] == pytest.approx(up, rel=1e-9)
    assert got.scale == pytest.approx(white)  # hdr.exr carries the same scale


def test_lux_makes_the_whole_model_s_upward_illuminance_the_meter_s(tmp_path):
    ldr = hdr_to_ldr(_city(64), 0.0)
    res = estimate_lighting(ldr, Settings(lux=25000.0, absolute=True), exposure=EXIF)  # the meter wins over EXIF
    p = res.document["physical"]
    assert p["from"] == "lux" and p["upward_illuminance_lux"] == pytest.approx(25000.0, rel=1e-9)
    e = float(res.model.irradiance(np.array([[0.0, 0.0, 1.0]]))[0] @ LUMINANCE_WEIGHTS)
    assert e == pytest.approx(25000.0, rel=0.02)  # recomputed from the written model: lights and SH
    for light, said in zip(res.document["lights"], p["lights"]):
        assert said["illuminance_lux"] == pytest.approx(light["intensity"])
        assert said["irradiance_w_m2"] == pytest.approx(light["intensity"] / 683.0)
    assert estimate_lighting(ldr, Settings(ev100=10.0)).document["physical"]["white_cd_m2"] == pytest.approx(1228.8)


@pytest.mark.parametrize("bad", [{"ev100": 99.0}, {"ev100": math.nan}, {"lux": 0.0}, {"lux": -3.0}, {"lux": 1e9}])
def test_a_scale_out_of_range_is_refused_in_one_line(bad):
    with pytest.raises(PanoLightError, match=next(iter(bad))):
        Settings(**bad)


def test_without_a_scale_the_files_stay_relative_and_say_how_to_set_one():
    """No EXIF, --ev100 or --lux: the default (absolute where a scale is known) writes relative values, with no
    warning (the common case), and lighting.json's physical block and the units line say how to set the scale."""
    res = estimate_lighting(hdr_to_ldr(_city(32), 0.0), Settings(absolute=True))
    assert not res.document["physical"]["absolute"] and res.document["units"].startswith("relative")
    assert not any("relative" in w or "scale" in w for w in res.warnings) and res.scale == 1.0
    assert "--ev100 or --lux" in res.document["physical"]["why"]
    assert "--ev100 or --lux" in units.summary(res.document["physical"])


def test_a_bracket_set_and_its_frames_agree_on_the_absolute_scale(tmp_path):
    """A -2/0/+2 set whose EXIF changes time (1/400, 1/100, 1/25 s at f/8, ISO 200) and each of its frames alone:
    the merged set's upward illuminance in lux is each frame's within 5 % where the frame clips nothing much."""
    truth = _sky_in_cd_m2(64) * 0.5
    white0 = units.white_luminance(units.ev100(**EXIF))
    files = []
    for i, (ev, t) in enumerate(((-2, 1 / 400), (0, 1 / 100), (2, 1 / 25))):
        files.append(_frame(tmp_path / f"f{i}.jpg", hdr_to_ldr(truth, scale=2.0 ** ev / white0), t, 8.0, 200))
    merged = run_estimate(BracketSet(tuple(files)), tmp_path / "set", outputs=("lighting",))
    e_set = merged["physical"]["upward_illuminance_lux"]
    for i in (0, 1):  # the +2 frame clips the sky: a single frame's lower bound only
        one = run_estimate(Path(files[i]), tmp_path / f"one{i}", outputs=("lighting",))
        assert one["physical"]["upward_illuminance_lux"] == pytest.approx(e_set, rel=0.05)
    assert e_set == pytest.approx(0.5 * math.pi * (1000.0 + 2000.0 * 2.0 / 3.0), rel=0.05)
    assert json.loads((tmp_path / "set" / "lighting.json").read_text())["physical"]["from"] == "exif"


def test_the_bundled_photo_with_exif_gives_a_lit_tunnel_s_figures(tmp_path):
    """../shared/data/ldr/tunnel.jpg keeps its camera's EXIF (f/11, 2.5 s, ISO 200: EV100 4.6, a night exposure):
    its white is 29 cd/m^2, and an upward surface at the camera gets a few to a few tens of lux, as street lighting
    gives (docs/units.md); the lighting file validates with its physical block."""
    from panolight_core.io.lighting import validate

    photo = Path(__file__).resolve().parents[3].parent / "shared" / "data" / "ldr" / "tunnel.jpg"
    if not photo.is_file():
        pytest.skip("../shared/data/ldr is not beside this checkout")
    doc = run_estimate(photo, tmp_path / "out", outputs=("lighting",))
    p = doc["physical"]
    assert p["from"] == "exif" and p["ev100"] == pytest.approx(math.log2(121 / 2.5) - 1, abs=1e-3)
    assert p["white_cd_m2"] == pytest.approx(29.04, rel=1e-3)
    assert 2.0 < p["upward_illuminance_lux"] < 100.0
    validate(doc)
