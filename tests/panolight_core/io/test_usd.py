"""lighting.usda: the stage round-trips lighting.json (directions, energies, the dome's orientation)."""
import json
import math

import numpy as np
import pytest

pytest.importorskip("pxr")

from panolight_core.apps.cli import main  # noqa: E402
from panolight_core.io import read_image  # noqa: E402
from panolight_core.io.usd import DOME_TO_WORLD, light_frame, read_usd, write_usd  # noqa: E402


def _angle_deg(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return math.degrees(math.acos(np.clip(a @ b / np.linalg.norm(a) / np.linalg.norm(b), -1, 1)))


@pytest.fixture(scope="module")
def sunny(tmp_path_factory):
    """An estimate folder of a small sky with a sun, from its 8-bit photo (lights + hdr.exr)."""
    from panolight_core import sh

    tmp = tmp_path_factory.mktemp("usd")
    h, w = 64, 128
    dirs = sh.pixel_directions(h, w)
    sun_dir = np.array([0.3, -0.8, 0.52]) / np.linalg.norm([0.3, -0.8, 0.52])
    hdr = (0.25 + 0.2 * np.clip(dirs[..., 2:3], 0, 1)) * np.array([0.7, 0.8, 1.0])
    hdr = np.broadcast_to(hdr, (h, w, 3)).copy()
    hdr[dirs @ sun_dir > math.cos(math.radians(4))] = [60.0, 50.0, 40.0]
    ldr = np.round(np.clip(hdr, 0, 1) ** (1 / 2.2) * 255).astype(np.uint8)
    from panolight_core.io import write_srgb8

    src = write_srgb8(tmp / "sky.png", ldr)
    assert main(["estimate", str(src), "-o", str(tmp / "out"), "-q"]) == 0
    return tmp / "out", sun_dir


def test_the_stage_says_its_frame_and_the_lights_round_trip(sunny):
    out, _ = sunny
    doc = json.loads((out / "lighting.json").read_text())
    assert doc["lights"], "the clipped sun should be an explicit light"
    stage = read_usd(out / "lighting.usda")
    assert stage["up_axis"] == "Z" and stage["meters_per_unit"] == 1.0
    assert stage["dome"]["texture"] == "./radiance.exr"
    assert len(stage["lights"]) == len(doc["lights"])
    for want, got in zip(doc["lights"], stage["lights"]):
        assert _angle_deg(got["direction"], want["direction"]) < 0.5
        energy = got["intensity"] * got["color"]  # RGB irradiance on a surface facing the light
        np.testing.assert_allclose(energy, want["intensity"] * np.asarray(want["color"]), rtol=0.01)
        assert got["angle"] == pytest.approx(want["angle"], rel=0.01)
    hdri = read_usd(out / "lighting.usda", variant="hdri")
    assert hdri["dome"]["texture"] == "./hdr.exr" and hdri["lights"] == []  # its sources are in the image


def _openexr_latlong_texel(local, w, h):
    """The pixel the OpenEXR lat-long convention puts a dome-local direction at (pole +Y, longitude 0
    along +Z, pi/2 along +X, longitude +pi at the left edge, latitude +pi/2 at the top)."""
    x, y, z = local
    lon, lat = math.atan2(x, z), math.asin(np.clip(y, -1, 1))
    col = (math.pi - lon) / (2 * math.pi) * w
    row = (math.pi / 2 - lat) / math.pi * h
    return int(min(h - 1, row)), int(col) % w


def test_the_domes_texel_at_the_light_direction_is_the_brightest(sunny):
    out, sun_dir = sunny
    hdri = read_usd(out / "lighting.usda", variant="hdri")
    img = read_image(out / hdri["dome"]["texture"])
    lum = img @ np.array([0.2126, 0.7152, 0.0722])
    light = read_usd(out / "lighting.usda")["lights"][0]["direction"]
    local = hdri["dome"]["rotation"].T @ light  # world -> dome-local
    row, col = _openexr_latlong_texel(local, img.shape[1], img.shape[0])
    window = lum[max(0, row - 1):row + 2, [(col + d) % img.shape[1] for d in (-1, 0, 1)]]
    assert window.max() == lum.max()
    assert _angle_deg(light, sun_dir) < 3.0  # and it is where the sun was


def test_frames_are_rotations_and_the_dome_maps_the_equirect_centre_to_plus_x():
    assert np.allclose(DOME_TO_WORLD @ DOME_TO_WORLD.T, np.eye(3)) and np.isclose(np.linalg.det(DOME_TO_WORLD), 1)
    assert np.allclose(DOME_TO_WORLD @ [0, 0, 1], [1, 0, 0])  # OpenEXR longitude 0 = the image centre = +X
    assert np.allclose(DOME_TO_WORLD @ [0, 1, 0], [0, 0, 1])  # the pole is the stage's up axis
    for d in ([0, 0, 1], [0, 0, -1], [1, 2, 3], [-0.3, 0.1, 0.95]):
        f = light_frame(d)
        assert np.allclose(f.T @ f, np.eye(3)) and np.isclose(np.linalg.det(f), 1)
        assert np.allclose(f[:, 2], np.asarray(d) / np.linalg.norm(d))


def test_write_usd_without_hdri_has_one_rig(tmp_path):
    doc = {"units": "u", "lights": [{"type": "sun", "direction": [0, 0, 1], "color": [1, 1, 1], "intensity": 2.0}]}
    write_usd(tmp_path / "l.usda", doc, hdri=None)
    stage = read_usd(tmp_path / "l.usda")
    assert stage["lights"][0]["intensity"] == 2.0 and stage["lights"][0]["angle"] == 0.0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["l.usda"]  # written atomically, nothing else


def test_distant_lights_are_normalised_so_intensity_is_irradiance(tmp_path):
    from pxr import Usd, UsdLux

    write_usd(tmp_path / "l.usda", {"lights": [{"type": "sun", "direction": [1, 0, 0], "color": [1, 1, 1],
                                                "intensity": 3.0, "angle": 0.01}]})
    stage = Usd.Stage.Open(str(tmp_path / "l.usda"))
    lights = [UsdLux.DistantLight(p) for p in stage.Traverse() if p.IsA(UsdLux.DistantLight)]
    assert len(lights) == 1 and lights[0].GetNormalizeAttr().Get() is True
    assert lights[0].GetAngleAttr().Get() == pytest.approx(math.degrees(0.01), rel=1e-6)


def test_a_key_light_says_how_it_was_found_and_how_sure_it_is(tmp_path):
    """A key light's source and its 68 % ranges (energy, in the light's intensity units; direction) ride along as
    custom data, so a pipeline reading only the stage knows a capped sun could be brighter; other lights carry none."""
    from pxr import Usd, UsdLux

    key = {"type": "sun", "direction": [0.0, 0.6, 0.8], "color": [1.6, 0.8, 0.2], "intensity": 0.5, "angle": 0.01,
           "source": "clear-sky fit (turbidity 6.5)", "energy_68": [1.2, 4.8], "direction_68_deg": 2.5}
    other = {"type": "area", "direction": [1.0, 0.0, 0.0], "color": [1.0, 1.0, 1.0], "intensity": 2.0, "angle": 0.1}
    write_usd(tmp_path / "l.usda", {"lights": [key, other]})
    stage = Usd.Stage.Open(str(tmp_path / "l.usda"))
    prims = {p.GetName(): p for p in stage.Traverse() if p.IsA(UsdLux.DistantLight)}
    data = prims["Light_0"].GetCustomData()["panolight"]  # USD reads "panolight:x" as the nested key path
    assert data["source"] == key["source"] and data["direction68Deg"] == 2.5 and data["type"] == "sun"
    lo, hi = data["intensity68"]
    intensity = UsdLux.DistantLight(prims["Light_0"]).GetIntensityAttr().Get()
    assert (lo / intensity, hi / intensity) == pytest.approx((1.2 / 0.5, 4.8 / 0.5))  # the range over the light
    assert set(prims["Light_1"].GetCustomData()["panolight"]) == {"type"}


def test_the_stage_carries_the_absolute_scale_where_one_is_known(tmp_path):
    """lighting.json's physical block rides along on the root (docs/units.md): a pipeline reading only the stage
    knows what one unit is, and whether the values are already cd/m^2 and lux; a stage without a scale carries none."""
    from pxr import Usd

    physical = {"absolute": True, "applied": False, "from": "exif", "ev100": 4.5969, "white_cd_m2": 29.04}
    write_usd(tmp_path / "a.usda", {"lights": [], "units": "relative", "physical": physical})
    stage = Usd.Stage.Open(str(tmp_path / "a.usda"))  # held: a prim of a dropped stage expires
    scale = stage.GetDefaultPrim().GetCustomData()["panolight"]["physicalScale"]
    assert scale["whiteCdM2"] == pytest.approx(29.04) and scale["applied"] is False and scale["from"] == "exif"
    assert scale["lumensPerWatt"] == 683.0 and scale["ev100"] == pytest.approx(4.5969)
    write_usd(tmp_path / "b.usda", {"lights": [], "physical": {"absolute": False, "applied": False}})
    other = Usd.Stage.Open(str(tmp_path / "b.usda"))
    assert "physicalScale" not in other.GetDefaultPrim().GetCustomData()["panolight"]
    assert read_usd(tmp_path / "b.usda")["dome"]["exposure"] == 0.0  # no scale: 1 is the camera's white


def test_the_stage_emits_nits_and_lux_whether_the_files_are_absolute_or_relative(tmp_path):
    """UsdLux's units: a light emits intensity x 2^exposure nits, a normalised distant light gives that many lux. A
    relative estimate (--relative) gets exposure log2(white cd/m^2) on every light, an absolute one (the default where
    EXIF gives the scale) exposure 0 on values already in cd/m^2 and lux: both stages emit the same. renderExposureEV
    is the camera exposure that shows the plate as shot: -log2 of its white in the stage's units."""
    white, ev = 29.04, 1.0  # the tunnel's camera white; --exposure 1 doubles the estimate
    sun = {"type": "sun", "direction": [0.0, 0.6, 0.8], "color": [1.0, 0.5, 0.25], "intensity": 0.5, "angle": 0.01}
    physical = {"absolute": True, "from": "exif", "ev100": 4.5969, "white_cd_m2": white}
    relative = {"lights": [sun], "exposure_ev": ev, "physical": {**physical, "applied": False}}
    absolute = {"lights": [dict(sun, intensity=0.5 * white)], "exposure_ev": ev, "physical": {**physical, "applied": True}}
    got = {}
    for name, doc in (("relative", relative), ("absolute", absolute)):
        write_usd(tmp_path / f"{name}.usda", doc)
        stage = read_usd(tmp_path / f"{name}.usda")
        (light,) = stage["lights"]
        got[name] = (stage["dome"]["exposure"], light["intensity"] * 2.0 ** light["exposure"])
        from pxr import Usd

        held = Usd.Stage.Open(str(tmp_path / f"{name}.usda"))  # held: a prim of a dropped stage expires
        scale = held.GetDefaultPrim().GetCustomData()["panolight"]["physicalScale"]
        assert scale["renderExposureEV"] == pytest.approx(-math.log2(white * 2.0 ** ev), abs=1e-6)
        assert scale["lightExposure"] == pytest.approx(stage["dome"]["exposure"], abs=1e-6)  # a float attribute
    assert got["relative"][0] == pytest.approx(math.log2(white)) and got["absolute"][0] == 0.0
    assert got["relative"][1] == pytest.approx(got["absolute"][1], rel=1e-6)  # the same lux either way
    assert got["absolute"][1] == pytest.approx(0.5 * white * 1.0, rel=1e-6)  # the colour's peak is 1
