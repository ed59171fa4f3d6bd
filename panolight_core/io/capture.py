"""Where and when a 360 photo was taken, from its own metadata (through OpenImageIO, which the CLI and Blender
both have): the GPS position (EXIF), the UTC time (EXIF GPS time; else the original time with its offset;
else XMP ``GPano:FirstPhotoDate`` with its zone), and the compass heading of the panorama's centre (XMP
``GPano:PoseHeadingDegrees``, as Ricoh Theta, Insta360 and Google's Photo Sphere write it). With all three the
sun's direction follows (``pipeline.metadata_sun``); without them nothing is guessed.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from datetime import datetime, timedelta, timezone
from pathlib import Path

from .checks import RAW_FORMAT, sniff_format
from .read_raw import read_raw_exposure


@dataclass(frozen=True)
class Capture:
    """latitude, longitude: degrees (north, east positive); utc: an aware datetime; heading: degrees clockwise
    from true north of the panorama's centre column; ``time_from``: which tag the time came from. None: not in
    the file (or not readable)."""

    latitude: float | None = None
    longitude: float | None = None
    utc: datetime | None = None
    heading: float | None = None
    time_from: str | None = None

    @property
    def missing(self) -> list[str]:
        """What the sun's direction still needs, in words (empty: complete)."""
        return [what for what, v in (("a GPS position", self.latitude), ("a UTC time", self.utc),
                                     ("the panorama's heading (GPano:PoseHeadingDegrees)", self.heading)) if v is None]

    def describe(self) -> str:
        """One line: the position, the time and the heading, as read."""
        lat = f"{abs(self.latitude):.4f} {'N' if self.latitude >= 0 else 'S'}" if self.latitude is not None else "?"
        lon = f"{abs(self.longitude):.4f} {'E' if self.longitude >= 0 else 'W'}" if self.longitude is not None else "?"
        when = f"{self.utc:%Y-%m-%d %H:%M:%S} UTC ({self.time_from})" if self.utc is not None else "?"
        heading = f"{self.heading:g} deg" if self.heading is not None else "?"
        return f"GPS {lat} {lon}, {when}, heading {heading}"


def read_capture(path) -> Capture:
    """The capture metadata of an image file (any format OpenImageIO reads); an empty Capture when OpenImageIO
    is missing or the file cannot be opened (the pixels' reader reports that)."""
    try:
        import OpenImageIO as oiio
    except ImportError:
        return Capture()
    inp = oiio.ImageInput.open(str(Path(path)))
    if inp is None:
        oiio.geterror()
        return Capture()
    try:
        spec = inp.spec()

        def get(name):
            return spec.getattribute(name)

        utc, time_from = _utc(get)
        return Capture(_coordinate(get("GPS:Latitude"), get("GPS:LatitudeRef"), "S", 90.0),
                       _coordinate(get("GPS:Longitude"), get("GPS:LongitudeRef"), "W", 180.0),
                       utc, _heading(_xmp_text(path, "GPano:PoseHeadingDegrees")), time_from)
    finally:
        inp.close()


XMP_SCAN_BYTES = 1 << 20  # a JPEG's XMP packet sits in its first APP1 segment (at most 64 kB), near the start


def _xmp_text(path, name: str) -> str | None:
    """An XMP property's text as written (attribute or element form) in the file's first XMP_SCAN_BYTES: not
    OpenImageIO's typed value, which reads a heading of "north" as 0."""
    try:
        with open(path, "rb") as f:
            head = f.read(XMP_SCAN_BYTES)
    except OSError:
        return None
    key = re.escape(name.encode())
    found = re.search(rb"\b" + key + rb'\s*=\s*"([^"]{0,64})"', head) or re.search(rb"<" + key + rb">([^<]{0,64})</", head)
    return found.group(1).decode("ascii", "replace") if found else None


def _coordinate(dms, ref, negative: str, limit: float) -> float | None:
    """Degrees from EXIF's (degrees, minutes, seconds) and its N/S or E/W reference; None when absent or absurd."""
    try:
        d, m, s = (float(v) for v in dms)
    except (TypeError, ValueError):
        return None
    value = d + m / 60.0 + s / 3600.0
    if not (math.isfinite(value) and 0.0 <= value <= limit and isinstance(ref, str) and ref.strip().upper() in
            ("N", "S", "E", "W")):
        return None
    return -value if ref.strip().upper() == negative else value


def _heading(value) -> float | None:
    """Degrees in [0, 360) from the written text; None when absent or not a finite number."""
    try:
        h = float(str(value).strip())
    except (TypeError, ValueError):
        return None
    return h % 360.0 if math.isfinite(h) else None


_OFFSET = re.compile(r"^([+-])(\d{2}):?(\d{2})$")


def _utc(get) -> tuple[datetime | None, str | None]:
    """(UTC time, the tag it came from): GPS time, else the original time and its offset (EXIF 2.31), else
    GPano:FirstPhotoDate when it carries a zone. A local time without its offset is not a UTC time."""
    date, stamp = get("GPS:DateStamp"), get("GPS:TimeStamp")
    try:
        day = datetime.strptime(str(date).strip(), "%Y:%m:%d")
        h, m, s = (float(v) for v in stamp)
        if 0 <= h < 24 and 0 <= m < 60 and 0 <= s < 61:
            return day.replace(tzinfo=timezone.utc) + timedelta(hours=h, minutes=m, seconds=s), "EXIF GPS time"
    except (TypeError, ValueError):
        pass
    original, offset = get("Exif:DateTimeOriginal"), get("Exif:OffsetTimeOriginal")
    match = _OFFSET.match(str(offset).strip()) if offset else None
    if original and match:
        try:
            local = datetime.strptime(str(original).strip(), "%Y:%m:%d %H:%M:%S")
        except ValueError:
            local = None
        if local is not None:
            sign = 1 if match.group(1) == "+" else -1
            zone = timezone(sign * timedelta(hours=int(match.group(2)), minutes=int(match.group(3))))
            return local.replace(tzinfo=zone).astimezone(timezone.utc), "EXIF original time and its offset"
    first = get("GPano:FirstPhotoDate")
    if first:
        try:
            when = datetime.fromisoformat(str(first).strip().replace("Z", "+00:00"))
        except ValueError:
            when = None
        if when is not None and when.utcoffset() is not None:
            return when.astimezone(timezone.utc), "GPano:FirstPhotoDate"
    return None, None


def read_exposure(path) -> dict | None:
    """A frame's exposure settings from its EXIF (through OpenImageIO; a camera RAW's through LibRaw):
    {"time_s", "f_number", "iso"} (ISO 100 where the file records none: a set shot at one ISO then still merges
    right), or None when the file records no ExposureTime and FNumber (or its reader is missing)."""
    if sniff_format(path) == RAW_FORMAT:
        return read_raw_exposure(path)
    try:
        import OpenImageIO as oiio
    except ImportError:
        return None
    inp = oiio.ImageInput.open(str(Path(path)))
    if inp is None:
        oiio.geterror()
        return None
    try:
        spec = inp.spec()
        time_s, f_number = spec.getattribute("ExposureTime"), spec.getattribute("FNumber")
        iso = spec.getattribute("Exif:PhotographicSensitivity") or spec.getattribute("Exif:ISOSpeedRatings")
    finally:
        inp.close()
    if time_s is None or f_number is None:
        return None
    return {"time_s": float(time_s), "f_number": float(f_number), "iso": float(iso) if iso else 100.0}
