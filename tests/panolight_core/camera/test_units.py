"""The absolute scale's convention (camera/units.py), against hand arithmetic."""
import math

import pytest

from panolight_core.camera import units


def test_ev100_is_log2_of_n_squared_over_t_at_iso_100():
    # f/1, 1 s, ISO 100 is EV100 0 by definition; each stop of time, aperture or ISO moves it by one
    assert units.ev100(1.0, 1.0, 100.0) == 0.0
    assert units.ev100(0.5, 1.0, 100.0) == pytest.approx(1.0)
    assert units.ev100(1.0, math.sqrt(2.0), 100.0) == pytest.approx(1.0)
    assert units.ev100(1.0, 1.0, 200.0) == pytest.approx(-1.0)
    # sunny 16: f/16, 1/100 s, ISO 100 is EV100 log2(25600) = 14.64
    assert units.ev100(1 / 100, 16.0, 100.0) == pytest.approx(math.log2(25600.0))


@pytest.mark.parametrize("bad", [0.0, -1.0, math.nan, math.inf, "1/250", None])
def test_ev100_refuses_what_is_no_exposure(bad):
    with pytest.raises(ValueError):
        units.ev100(bad, 8.0, 100.0)


def test_white_is_one_point_two_times_two_to_the_ev100():
    assert units.WHITE_FACTOR == pytest.approx(1.2, rel=0.002)  # 78 / 65
    assert units.white_luminance(10.0) == pytest.approx(units.WHITE_FACTOR * 1024.0)


def test_exif_gives_an_absolute_scale_and_a_missing_one_stays_relative():
    s = units.from_exposure({"time_s": 1 / 100, "f_number": 16.0, "iso": 100.0})
    assert s.absolute and s.origin == "exif"
    assert s.cd_m2 == pytest.approx(units.WHITE_FACTOR * 25600.0)
    assert s.describe()["radiance"] == "cd/m^2" and s.describe()["ev100"] == pytest.approx(14.6439, abs=1e-4)
    for nothing in (None, {}, {"time_s": 0.0, "f_number": 8.0, "iso": 100.0}, {"time_s": 1e-30, "f_number": 8.0,
                                                                               "iso": 100.0}):
        assert not units.from_exposure(nothing).absolute
    assert units.RELATIVE.describe()["absolute"] is False


def test_lux_scales_the_upward_illuminance_to_the_meter():
    s = units.from_lux(20000.0, 4.0)
    assert s.cd_m2 == pytest.approx(5000.0) and s.origin == "lux"
    assert units.white_luminance(s.ev100) == pytest.approx(5000.0)
    with pytest.raises(ValueError, match="lux"):
        units.from_lux(-5.0, 4.0)
    with pytest.raises(ValueError, match="nothing"):
        units.from_lux(100.0, 0.0)


def test_the_one_line_says_the_units_and_survives_an_edited_block():
    s = units.from_exposure({"time_s": 2.5, "f_number": 11.0, "iso": 200.0})
    line = units.summary({**s.describe(), "applied": False, "upward_illuminance_lux": 17.3})
    assert line.startswith("relative: 1 = the camera's white = 29 cd/m^2 (from EXIF); 17.3 lux")
    assert units.summary({**s.describe(), "applied": True}).startswith("cd/m^2 and lux (white 29 cd/m^2")
    assert units.summary(None).startswith("relative (1 = the camera's white); no exposure")
    for edited in ({"absolute": True}, {"absolute": True, "white_cd_m2": "bright"}, ["x"]):
        assert units.summary(edited) == "the stored scale cannot be read"


def test_blender_s_factor_is_watts_per_unit_at_683_lumens():
    s = units.from_ev100(10.0)
    assert units.blender_factor({**s.describe(), "applied": False}) == pytest.approx(1228.8 / 683.0)
    assert units.blender_factor({**s.describe(), "applied": True}) == pytest.approx(1.0 / 683.0)
    for none in (None, {"absolute": False}, {"absolute": True}, {"absolute": True, "white_cd_m2": -1.0}):
        assert units.blender_factor(none) is None


def test_an_iso_the_file_does_not_record_is_said_to_be_assumed():
    s = units.from_exposure({"time_s": 1 / 100, "f_number": 8.0, "iso": 100.0, "iso_recorded": False})
    assert s.iso_assumed and s.describe()["iso_assumed"] is True
    assert "no ISO recorded, 100 assumed" in units.summary({**s.describe(), "applied": False})
    kept = units.from_exposure({"time_s": 1 / 100, "f_number": 8.0, "iso": 100.0, "iso_recorded": True})
    assert not kept.iso_assumed and "iso_assumed" not in kept.describe()
