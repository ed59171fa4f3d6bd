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
