"""io.metadata, the validating layer every outside tag goes through: its typed readers on the legal but unexpected
shapes cameras write, and fuzzed (hypothesis) with random tag shapes, types, counts and ranges, directly and
through the exposure and ``io.capture``'s parsers. None of them may raise, and what they return is typed and in range."""
import math
from datetime import datetime, timedelta, timezone

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from panolight_core.io import metadata as tags
from panolight_core.io.capture import Capture, capture_utc, parse_capture
from panolight_core.io.metadata import MAX_EXPOSURE_S, MAX_F_NUMBER, MAX_ISO


def test_numbers_in_the_shapes_cameras_write():
    assert tags.number(0.004) == 0.004 and tags.number("1/250") == 0.004 and tags.number(" 8 ") == 8.0
    assert tags.number((100, 200)) == 100.0  # ISOSpeedRatings of two values: the first is the shot's
    assert tags.number(np.array([400], np.uint16)) == 400.0 and tags.number(b"2.8\x00") == 2.8
    for bad in (None, True, math.nan, math.inf, "0/0", "1/0", "fast", 10 ** 400, "1e999", (), [[1]], {}, "1" * 100):
        assert tags.number(bad) is None, bad
    assert tags.positive(0.0) is None and tags.positive(-1) is None and tags.positive(5, hi=4) is None
    assert tags.numbers((1, 2, 3), 3) == (1.0, 2.0, 3.0) and tags.numbers((1, 2), 3) is None
    assert tags.numbers((1, math.nan, 3), 3) is None and tags.numbers("123", 3) is None
    assert tags.integer(3, 0, 5) == 3 and tags.integer(True, 0, 5) is None and tags.integer(3.0, 0, 5) is None


def test_dates_and_zones_that_leave_the_calendar_are_absent_not_errors():
    assert tags.gps_time("9999:12:31", (23, 59, 60.5)) is None  # past year 9999
    assert tags.gps_time("2024:06:21", (10, 30, 15)) == datetime(2024, 6, 21, 10, 30, 15, tzinfo=timezone.utc)
    assert tags.gps_time("2024:02:30", (1, 0, 0)) is None and tags.gps_time("2024:06:21", (24, 0, 0)) is None
    year1, year9999 = tags.exif_datetime("0001:01:01 00:00:00"), tags.exif_datetime("9999:12:31 23:59:59")
    assert tags.as_utc(year1, tags.utc_offset("+14:00")) is None
    assert tags.as_utc(year9999, tags.utc_offset("-12:00")) is None
    assert tags.as_utc(tags.exif_datetime("2024:06:21 12:30:00"), tags.utc_offset("+02:00")) == \
        datetime(2024, 6, 21, 10, 30, tzinfo=timezone.utc)
    assert tags.utc_offset("+15:00") is None and tags.utc_offset("+02:75") is None and tags.utc_offset(2) is None
    assert tags.iso_datetime("0001-01-01T00:00:00+14:00") is None and tags.iso_datetime("2024-06-21T10:30:00") is None
    assert tags.subseconds("045") == pytest.approx(0.045) and tags.subseconds("x") == 0.0


def test_a_gps_position_needs_both_coordinates_and_their_references():
    lat = tags.gps_coordinate((48.0, 51.0, 0.0), "N", "NS", 90.0)
    assert lat == pytest.approx(48.85) and tags.gps_coordinate((48.0, 51.0, 0.0), "S", "NS", 90.0) == -lat
    assert tags.gps_coordinate((2.0, 17.0, 0.0), None, "EW", 180.0) is None  # no longitude reference
    assert tags.gps_coordinate((math.nan, 0.0, 0.0), "E", "EW", 180.0) is None  # a 0/0 rational
    assert tags.gps_coordinate((91.0, 0.0, 0.0), "N", "NS", 90.0) is None
    assert tags.gps_coordinate((2.0, 0.0, 0.0), "NE", "EW", 180.0) is None
    half = Capture(latitude=48.85, utc=datetime.now(timezone.utc), heading=0.0)
    assert half.missing == ["a GPS position"]  # a latitude alone is no position: the solar code never sees it


def test_json_records_too_deep_too_large_or_not_objects_are_absent():
    assert tags.json_object('{"files": {}}') == {"files": {}}
    assert tags.json_object("[" * 100000) is None and tags.too_deep("[" * 100000)
    assert tags.json_object('{"a": 1}', max_bytes=4) is None and tags.json_object("[1]") is None
    assert tags.json_object(b"\xff\xfe{") is None and tags.json_object(None) is None and tags.json_object(7) is None
    assert not tags.too_deep('{"a": [[1]]}')


# ---- fuzzing: raw tag values of any shape a reader can deliver

_leaves = st.one_of(
    st.none(), st.booleans(), st.integers(min_value=-(10 ** 400), max_value=10 ** 400),
    st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=40), st.binary(max_size=40),
    st.sampled_from(["1/250", "0/0", "-1/3", "8", "9999:12:31", "0001:01:01 00:00:00", "9999:12:31 23:59:59",
                     "+14:00", "-12:00", "+99:99", "N", "S", "E", "W", "2024-06-21T10:30:00Z", "1e308", "nan"]))
_values = st.recursive(_leaves, lambda inner: st.one_of(st.lists(inner, max_size=4), st.tuples(inner, inner, inner)),
                       max_leaves=8)
_TAG_NAMES = ["ExposureTime", "FNumber", "Exif:SubsecTimeOriginal", "Exif:PhotographicSensitivity", "Exif:ISOSpeedRatings", "GPS:Latitude",
              "GPS:LatitudeRef", "GPS:Longitude", "GPS:LongitudeRef", "GPS:DateStamp", "GPS:TimeStamp",
              "Exif:DateTimeOriginal", "Exif:OffsetTimeOriginal", "GPano:FirstPhotoDate", "Exif:ExposureBiasValue",
              "Exif:ExposureMode", "Exif:ExposureProgram"]
_tag_sets = st.dictionaries(st.sampled_from(_TAG_NAMES), _values, max_size=len(_TAG_NAMES))
FUZZ = settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@FUZZ
@given(_values)
@example("¹")  # a digit to str.isdigit that int() refuses: SubSecTimeOriginal raised
@example("٣٤")  # Arabic-Indic digits
def test_every_reader_takes_any_value_and_returns_its_type_or_none(raw):
    for value in (tags.number(raw), tags.positive(raw), tags.heading(raw)):
        assert value is None or (type(value) is float and math.isfinite(value))
    assert tags.positive(raw) is None or tags.positive(raw) > 0
    assert tags.heading(raw) is None or 0.0 <= tags.heading(raw) < 360.0
    assert tags.text(raw) is None or (type(tags.text(raw)) is str and len(tags.text(raw)) <= tags.MAX_TEXT)
    found = tags.numbers(raw, 3, 0.0, 60.0)
    assert found is None or (len(found) == 3 and all(0.0 <= v <= 60.0 for v in found))
    for when in (tags.exif_datetime(raw), tags.exif_date(raw)):
        assert when is None or (isinstance(when, datetime) and when.tzinfo is None)
    zone = tags.utc_offset(raw)
    assert zone is None or abs(zone.utcoffset(None)) <= timedelta(hours=14)
    for when in (tags.iso_datetime(raw), tags.gps_time(raw, raw), tags.as_utc(tags.exif_datetime(raw), zone)):
        assert when is None or when.tzinfo == timezone.utc
    assert 0.0 <= tags.subseconds(raw) < 1.0


@FUZZ
@given(_tag_sets, st.one_of(st.none(), st.text(max_size=20), st.floats()))
def test_the_capture_and_exposure_of_any_tags_are_typed_and_in_range(found, heading):
    exposure = tags.exposure(found.get)
    if exposure is not None:
        assert 0 < exposure["time_s"] <= MAX_EXPOSURE_S and 0 < exposure["f_number"] <= MAX_F_NUMBER
        assert 0 < exposure["iso"] <= MAX_ISO
        assert exposure["taken_s"] is None or (type(exposure["taken_s"]) is float and exposure["taken_s"] >= 0)
        bias = exposure["bias_ev"]
        assert bias is None or (type(bias) is float and abs(bias) <= 30.0)
        assert type(exposure["manual"]) is bool
    got = parse_capture(found.get, heading)
    assert got.latitude is None or -90.0 <= got.latitude <= 90.0
    assert got.longitude is None or -180.0 <= got.longitude <= 180.0
    assert got.heading is None or 0.0 <= got.heading < 360.0
    assert (got.utc is None) == (got.time_from is None)
    assert got.utc is None or got.utc.tzinfo == timezone.utc
    assert isinstance(got.describe(), str) and capture_utc(found.get) == (got.utc, got.time_from)


@FUZZ
@given(st.one_of(st.text(max_size=200), st.binary(max_size=200),
                 st.recursive(st.one_of(st.none(), st.integers(), st.text(max_size=8)),
                              lambda inner: st.one_of(st.lists(inner, max_size=3),
                                                      st.dictionaries(st.text(max_size=4), inner, max_size=3)),
                              max_leaves=20).map(repr)))
def test_any_text_is_a_json_object_or_absent(raw):
    doc = tags.json_object(raw)
    assert doc is None or isinstance(doc, dict)
