"""io.capture: the GPS position, UTC time and heading a 360 photo records, read through OpenImageIO."""
from datetime import datetime, timedelta, timezone

import numpy as np
import pytest

from panolight_core.io.capture import Capture, read_capture

XMP = ('<x:xmpmeta xmlns:x="adobe:ns:meta/"><rdf:RDF xmlns:rdf="http://www.w3.org/1999/02/22-rdf-syntax-ns#">'
       '<rdf:Description rdf:about="" xmlns:GPano="http://ns.google.com/photos/1.0/panorama/" '
       'GPano:ProjectionType="equirectangular"{extra}/></rdf:RDF></x:xmpmeta>')


def write_photo(path, ldr=None, *, gps=None, gps_time=None, original=None, offset=None, heading=None, first=None):
    """A JPEG with the capture metadata a 360 camera writes: gps (lat, lon) signed degrees; gps_time an aware
    datetime (EXIF GPS date and time stamps, UTC); original / offset: EXIF DateTimeOriginal and
    OffsetTimeOriginal; heading: XMP GPano:PoseHeadingDegrees; first: XMP GPano:FirstPhotoDate."""
    from PIL import Image

    exif = Image.Exif()
    if original:
        exif[0x9003] = original
    if offset:
        exif[0x9011] = offset
    if gps or gps_time:
        ifd = exif.get_ifd(0x8825)
        if gps:
            for tag, value, refs in ((2, gps[0], "NS"), (4, gps[1], "EW")):
                d = abs(value)
                ifd[tag - 1] = refs[value < 0]
                ifd[tag] = (float(int(d)), float(int(d * 60) % 60), round((d * 3600) % 60, 4))
        if gps_time:
            utc = gps_time.astimezone(timezone.utc)
            ifd[29] = f"{utc:%Y:%m:%d}"
            ifd[7] = (float(utc.hour), float(utc.minute), utc.second + utc.microsecond / 1e6)
    extra = (f' GPano:PoseHeadingDegrees="{heading}"' if heading is not None else "") + \
            (f' GPano:FirstPhotoDate="{first}"' if first else "")
    img = Image.fromarray(np.full((32, 64, 3), 128, np.uint8) if ldr is None else ldr)
    img.save(path, quality=95, exif=exif, xmp=XMP.format(extra=extra).encode())
    return path


def test_a_full_capture_is_read_with_its_signs_and_its_gps_time(tmp_path):
    when = datetime(2024, 6, 21, 10, 30, 15, tzinfo=timezone.utc)
    got = read_capture(write_photo(tmp_path / "a.jpg", gps=(-33.9249, 18.4241 - 40), gps_time=when, heading=123.5))
    assert got.latitude == pytest.approx(-33.9249, abs=1e-5) and got.longitude == pytest.approx(-21.5759, abs=1e-5)
    assert got.utc == when and got.time_from == "EXIF GPS time" and got.heading == 123.5 and not got.missing
    assert "33.9249 S" in got.describe() and "21.5759 W" in got.describe() and "2024-06-21 10:30:15 UTC" in got.describe()


def test_the_time_comes_from_the_original_time_and_its_offset_or_the_first_photo_date(tmp_path):
    got = read_capture(write_photo(tmp_path / "b.jpg", gps=(48.85, 2.29), original="2024:06:21 12:30:00",
                                   offset="+02:00", heading=-10))
    assert got.utc == datetime(2024, 6, 21, 10, 30, tzinfo=timezone.utc) and got.heading == 350.0
    got = read_capture(write_photo(tmp_path / "c.jpg", gps=(48.85, 2.29), first="2024-06-21T10:30:00.000Z", heading=5))
    assert got.utc == datetime(2024, 6, 21, 10, 30, tzinfo=timezone.utc) and got.time_from == "GPano:FirstPhotoDate"


def test_without_all_three_nothing_is_guessed(tmp_path):
    """A local time without its offset is not a UTC time; no heading, no GPS: each is missing, said in words."""
    got = read_capture(write_photo(tmp_path / "d.jpg", gps=(48.85, 2.29), original="2024:06:21 12:30:00", heading=5))
    assert got.utc is None and got.missing == ["a UTC time"]
    got = read_capture(write_photo(tmp_path / "e.jpg", gps_time=datetime.now(timezone.utc)))
    assert got.missing == ["a GPS position", "the panorama's heading (GPano:PoseHeadingDegrees)"]
    assert read_capture(write_photo(tmp_path / "f.jpg")) == Capture()
    assert read_capture(write_photo(tmp_path / "g.jpg", heading="north")).heading is None
    assert read_capture(tmp_path / "missing.jpg") == Capture()
    local = datetime(2024, 6, 21, 12, 30, tzinfo=timezone(timedelta(hours=2)))
    got = read_capture(write_photo(tmp_path / "h.jpg", gps=(1.0, 2.0), gps_time=local, heading=0))
    assert got.utc == local and got.utc.tzinfo == timezone.utc


def _raw_exif_photo(path, exif_tags=(), gps_tags=()):
    """A JPEG whose Exif and GPS IFDs hold exactly the given (tag, value) pairs, legal but unexpected shapes."""
    from PIL import Image

    exif = Image.Exif()
    for ifd, pairs in ((exif.get_ifd(0x8769), exif_tags), (exif.get_ifd(0x8825), gps_tags)):
        for tag, value in pairs:
            ifd[tag] = value
    Image.fromarray(np.full((32, 64, 3), 128, np.uint8)).save(path, quality=95, exif=exif)
    return path


def test_exposures_in_legal_but_unexpected_shapes_are_read_or_absent(tmp_path):
    """ISOSpeedRatings of two values (the first is the shot's), ExposureTime and FNumber written as text (trust
    round 4: an unguarded float() gave a traceback, and killed batch --brackets auto), a 0/0 exposure time."""
    from PIL.TiffImagePlugin import IFDRational

    from panolight_core.io.capture import read_exposure

    two = _raw_exif_photo(tmp_path / "iso2.jpg", [(0x829A, IFDRational(1, 250)), (0x829D, IFDRational(8, 1)),
                                                  (0x8827, (400, 800)), (0x9204, IFDRational(-5, 3)),
                                                  (0xA402, 1)])  # ExposureMode: manual
    assert read_exposure(two) == {"time_s": pytest.approx(0.004), "f_number": 8.0, "iso": 400.0, "taken_s": None,
                                  "iso_recorded": True, "bias_ev": pytest.approx(-5 / 3), "manual": True}
    text = _raw_exif_photo(tmp_path / "text.jpg", [(0x829A, "1/250"), (0x829D, "8"), (0x8827, "200"),
                                                   (0x9204, "99")])  # a bias no camera records: none
    assert read_exposure(text) == {"time_s": 0.004, "f_number": 8.0, "iso": 200.0, "taken_s": None,
                                   "iso_recorded": True, "bias_ev": None, "manual": False}
    assert read_exposure(_raw_exif_photo(tmp_path / "nan.jpg", [(0x829A, IFDRational(0, 0)),
                                                                (0x829D, IFDRational(8, 1))])) is None


def test_dates_past_the_calendar_and_a_half_gps_position_are_absent_not_errors(tmp_path):
    """A GPS date of 9999:12:31 at 23:59:60.5, DateTimeOriginal 0001 at +14:00 and 9999 at -12:00 (trust round 4:
    OverflowError), a longitude without its reference or of 0/0: no time, no position, nothing guessed."""
    from PIL.TiffImagePlugin import IFDRational

    late = _raw_exif_photo(tmp_path / "late.jpg", [(0x9003, "9999:12:31 23:59:59"), (0x9011, "-12:00")],
                           [(29, "9999:12:31"), (7, (23.0, 59.0, 60.5)), (1, "N"), (2, (10.0, 0.0, 0.0)),
                            (4, (20.0, 0.0, 0.0))])
    got = read_capture(late)
    assert got.utc is None and got.latitude == 10.0 and got.longitude is None
    assert got.missing[:2] == ["a GPS position", "a UTC time"]
    early = read_capture(_raw_exif_photo(tmp_path / "early.jpg", [(0x9003, "0001:01:01 00:00:00"), (0x9011, "+14:00")]))
    assert early.utc is None
    nan = read_capture(_raw_exif_photo(tmp_path / "nan.jpg", gps_tags=[
        (1, "N"), (2, (10.0, 0.0, 0.0)), (3, "E"), (4, (IFDRational(0, 0), IFDRational(0, 1), IFDRational(0, 1)))]))
    assert nan.latitude == 10.0 and nan.longitude is None and "a GPS position" in nan.missing
