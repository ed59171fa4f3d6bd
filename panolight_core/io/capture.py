"""Where and when a 360 photo was taken, and how it was exposed, from its own metadata (through OpenImageIO, which
the CLI and Blender both have): the GPS position (EXIF), the UTC time (EXIF GPS time; else the original time with
its offset; else XMP ``GPano:FirstPhotoDate`` with its zone), the compass heading of the panorama's centre (XMP
``GPano:PoseHeadingDegrees``, as Ricoh Theta, Insta360 and Google's Photo Sphere write it), and the exposure (EXIF
ExposureTime, FNumber, ISO). With position, time and heading the sun's direction follows
(``pipeline.metadata_sun``); without them nothing is guessed.

Every tag goes through ``io.metadata``'s validating readers: ``parse_capture`` (here) and ``metadata.exposure``
take a getter of raw tag values (whatever shape a file holds) and never raise.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path

from ..threads import optional_module
from . import metadata as tags
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
        position = None if self.latitude is None or self.longitude is None else (self.latitude, self.longitude)
        return [what for what, v in (("a GPS position", position), ("a UTC time", self.utc),
                                     ("the panorama's heading (GPano:PoseHeadingDegrees)", self.heading)) if v is None]

    def describe(self) -> str:
        """One line: the position, the time and the heading, as read."""
        lat = f"{abs(self.latitude):.4f} {'N' if self.latitude >= 0 else 'S'}" if self.latitude is not None else "?"
        lon = f"{abs(self.longitude):.4f} {'E' if self.longitude >= 0 else 'W'}" if self.longitude is not None else "?"
        when = f"{self.utc:%Y-%m-%d %H:%M:%S} UTC ({self.time_from})" if self.utc is not None else "?"
        heading = f"{self.heading:g} deg" if self.heading is not None else "?"
        return f"GPS {lat} {lon}, {when}, heading {heading}"


def _open_spec(path):
    """(OpenImageIO's spec of the file's first subimage, or None when OpenImageIO is missing or cannot open it)."""
    oiio = optional_module("OpenImageIO")
    if oiio is None:
        return None
    inp = oiio.ImageInput.open(str(Path(path)))
    if inp is None:
        oiio.geterror()
        return None
    try:
        return inp.spec()
    finally:
        inp.close()


def _getter(spec):
    """name -> the raw value OpenImageIO holds (any type, any count), or None: never raises."""
    def get(name):
        try:
            return spec.getattribute(name)
        except Exception:  # noqa: BLE001 - an attribute OpenImageIO cannot convert is not there
            return None
    return get


def read_capture(path) -> Capture:
    """The capture metadata of an image file (any format OpenImageIO reads); an empty Capture when OpenImageIO
    is missing or the file cannot be opened (the pixels' reader reports that)."""
    spec = _open_spec(path)
    if spec is None:
        return Capture()
    return parse_capture(_getter(spec), _xmp_text(path, "GPano:PoseHeadingDegrees"))


def parse_capture(get, heading_text=None) -> Capture:
    """The Capture of a file's tags: ``get(name)`` gives each raw value (None when absent), ``heading_text`` the
    XMP heading as written. Each field that is absent, malformed or out of range is None."""
    utc, time_from = capture_utc(get)
    return Capture(tags.gps_coordinate(get("GPS:Latitude"), get("GPS:LatitudeRef"), "NS", 90.0),
                   tags.gps_coordinate(get("GPS:Longitude"), get("GPS:LongitudeRef"), "EW", 180.0),
                   utc, tags.heading(heading_text), time_from)


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


def capture_utc(get) -> tuple[datetime | None, str | None]:
    """(UTC time, the tag it came from): GPS time, else the original time and its offset (EXIF 2.31), else
    GPano:FirstPhotoDate when it carries a zone. A local time without its offset is not a UTC time."""
    found = tags.gps_time(get("GPS:DateStamp"), get("GPS:TimeStamp"))
    if found is not None:
        return found, "EXIF GPS time"
    found = tags.as_utc(tags.exif_datetime(get("Exif:DateTimeOriginal")), tags.utc_offset(get("Exif:OffsetTimeOriginal")))
    if found is not None:
        return found, "EXIF original time and its offset"
    found = tags.iso_datetime(get("GPano:FirstPhotoDate"))
    if found is not None:
        return found, "GPano:FirstPhotoDate"
    return None, None


def read_exposure(path) -> dict | None:
    """A frame's exposure settings from its EXIF (through OpenImageIO; a camera RAW's through LibRaw):
    {"time_s", "f_number", "iso"} (ISO 100 where the file records none: a set shot at one ISO then still merges
    right), or None when the file records no valid ExposureTime and FNumber (or its reader is missing)."""
    if sniff_format(path) == RAW_FORMAT:
        return read_raw_exposure(path)
    spec = _open_spec(path)
    return None if spec is None else tags.exposure(_getter(spec))
