"""The one validating layer between outside metadata and PanoLight: every value read from a file's tags (EXIF,
XMP, GPano, GPS, dates), from a manifest or sidecar PanoLight finds on disk, or from a Blender ID property goes
through these readers. Each takes whatever its source delivered (None, a number, text, bytes, a sequence of them,
nested, NaN, a number too large for a float) and returns a typed value within its stated range, or None. None of
them raises: what is not a valid value is simply not there, and the caller says what it then lacks.

numpy only (no decoder library): Blender's add-on uses it too.
"""
from __future__ import annotations

import json
import math
import re
from datetime import datetime, timedelta, timezone
from numbers import Real

MAX_TEXT = 256  # no tag PanoLight reads is longer: a longer one is not the value it names
_RATIONAL = re.compile(r"^\s*([-+]?[0-9.eE+-]+)\s*/\s*([-+]?[0-9.eE+-]+)\s*$")
_SEQUENCES = (list, tuple)


def _plain(raw):
    """``raw`` with a numpy scalar or array made plain Python (its ``tolist``); None where that fails."""
    if hasattr(raw, "tolist") and not isinstance(raw, (str, bytes)):
        try:
            return raw.tolist()
        except (TypeError, ValueError):
            return None
    return raw


def _scalar(raw):
    """The one value ``raw`` holds: itself, or the first item of a sequence (EXIF's ISOSpeedRatings may hold
    several; the first is the one the shot used), or a numpy array's first element; None when empty or nested."""
    raw = _plain(raw)
    if isinstance(raw, _SEQUENCES):
        if not raw or isinstance(raw[0], _SEQUENCES):
            return None
        raw = raw[0]
    return raw


def text(raw, max_len: int = MAX_TEXT) -> str | None:
    """A tag's text: a str, or bytes read as UTF-8 (undecodable bytes replaced), stripped of spaces and NULs
    (EXIF pads its ASCII fields); None when absent, empty, or longer than ``max_len``."""
    if isinstance(raw, (bytes, bytearray)):
        raw = bytes(raw[:4 * max_len + 4]).decode("utf-8", "replace")
    if not isinstance(raw, str):
        return None
    value = raw.strip().strip("\x00").strip()
    return value if value and len(value) <= max_len else None


def number(raw, lo: float = -math.inf, hi: float = math.inf) -> float | None:
    """A finite float within [lo, hi] from a number, a number's text ("0.004", "1/250"), or a one-value sequence
    (the first of several); None for anything else: a bool, NaN or infinity, 0/0, an integer too large for a
    float, text that is not a number, a value out of range."""
    raw = _scalar(raw)
    if isinstance(raw, bool):
        return None
    if isinstance(raw, (str, bytes, bytearray)):
        s = text(raw, 64)
        if s is None:
            return None
        match = _RATIONAL.match(s)
        try:
            if match:
                den = float(match.group(2))
                value = float(match.group(1)) / den if den != 0 else math.nan
            else:
                value = float(s)
        except (ValueError, OverflowError):
            return None
    elif isinstance(raw, Real):
        try:
            value = float(raw)
        except (OverflowError, ValueError):
            return None
    else:
        return None
    return value if math.isfinite(value) and lo <= value <= hi else None


def positive(raw, hi: float = math.inf) -> float | None:
    """``number`` above zero (an exposure time, an f-number, an ISO)."""
    value = number(raw, 0.0, hi)
    return value if value is not None and value > 0 else None


def numbers(raw, count: int, lo: float = -math.inf, hi: float = math.inf) -> tuple[float, ...] | None:
    """Exactly ``count`` numbers (``number`` each, within [lo, hi]) from a sequence of that length (GPS's degrees,
    minutes and seconds; its hours, minutes and seconds); None otherwise."""
    raw = _plain(raw)
    if not isinstance(raw, _SEQUENCES) or len(raw) != count:
        return None
    values = tuple(number(v, lo, hi) if not isinstance(v, _SEQUENCES) else None for v in raw)
    return None if None in values else values


def integer(raw, lo: int, hi: int) -> int | None:
    """A Python int within [lo, hi] (not a bool, not a float): a count, an inode, a size in a record PanoLight
    wrote itself."""
    return raw if type(raw) is int and lo <= raw <= hi else None


_EXIF_TIME = re.compile(r"^(\d{4}):(\d{2}):(\d{2})[ T](\d{2}):(\d{2}):(\d{2})$")
_EXIF_DATE = re.compile(r"^(\d{4}):(\d{2}):(\d{2})$")
_OFFSET = re.compile(r"^([+-])(\d{2}):?(\d{2})$")
MAX_OFFSET_H = 14  # the widest time zones: UTC-12 to UTC+14


def exif_date(raw) -> datetime | None:
    """EXIF's "YYYY:MM:DD" (GPSDateStamp) as a naive midnight; None when not a real calendar date."""
    return _calendar(_EXIF_DATE, raw)


def exif_datetime(raw) -> datetime | None:
    """EXIF's "YYYY:MM:DD HH:MM:SS" (DateTimeOriginal) as a naive datetime; None when not a real date and time."""
    return _calendar(_EXIF_TIME, raw)


def _calendar(pattern: re.Pattern, raw) -> datetime | None:
    """The naive datetime of the numbers ``pattern`` reads from ``raw``'s text; None when it is not a real one."""
    match = pattern.match(text(raw, 32) or "")
    try:
        return datetime(*(int(g) for g in match.groups())) if match else None
    except ValueError:
        return None


def subseconds(raw) -> float:
    """EXIF's SubSecTimeOriginal ("123": 0.123 s) in seconds; 0 when absent or not digits."""
    s = text(raw, 9) or ""
    return int(s) / 10 ** len(s) if s.isascii() and s.isdigit() else 0.0  # "¹" is a digit to str.isdigit, not to int


def utc_offset(raw) -> timezone | None:
    """EXIF's OffsetTimeOriginal ("+02:00") as a timezone; None when absent or beyond +-14 hours."""
    match = _OFFSET.match(text(raw, 16) or "")
    if not match:
        return None
    h, m = int(match.group(2)), int(match.group(3))
    if m >= 60 or h * 60 + m > MAX_OFFSET_H * 60:
        return None
    return timezone((1 if match.group(1) == "+" else -1) * timedelta(hours=h, minutes=m))


def as_utc(moment: datetime | None, zone: timezone | None = None) -> datetime | None:
    """``moment`` (naive local time in ``zone``, or aware) in UTC; None when either is missing or the conversion
    leaves the calendar (year 1 at +14:00, year 9999 at -12:00)."""
    if moment is None or (moment.tzinfo is None and zone is None):
        return None
    try:
        return (moment if moment.tzinfo is not None else moment.replace(tzinfo=zone)).astimezone(timezone.utc)
    except (OverflowError, ValueError):
        return None


def gps_time(date_raw, stamp_raw) -> datetime | None:
    """EXIF's GPSDateStamp and GPSTimeStamp (hours, minutes, seconds; UTC) as an aware UTC datetime; None when
    either is absent, out of range, or the sum leaves the calendar (9999:12:31 at 23:59:60.5)."""
    day, stamp = exif_date(date_raw), numbers(stamp_raw, 3, 0.0, 61.0)
    if day is None or stamp is None:
        return None
    h, m, s = stamp
    if not (h < 24 and m < 60 and s < 61):
        return None
    try:
        return day.replace(tzinfo=timezone.utc) + timedelta(hours=h, minutes=m, seconds=s)
    except OverflowError:
        return None


def iso_datetime(raw) -> datetime | None:
    """An ISO 8601 time with its zone (XMP's GPano:FirstPhotoDate, "...Z" too) in UTC; None without a zone."""
    s = text(raw, 64)
    if s is None:
        return None
    try:
        when = datetime.fromisoformat(s.replace("Z", "+00:00"))
    except ValueError:
        return None
    return as_utc(when) if when.utcoffset() is not None else None


def gps_coordinate(dms, ref, refs: str, limit: float) -> float | None:
    """Signed degrees from EXIF's (degrees, minutes, seconds) and its reference (``refs``: "NS" or "EW", the
    second negative); None when either is absent or the value is not within [0, limit] degrees."""
    parts, side = numbers(dms, 3, 0.0, 360.0), (text(ref, 8) or "").upper()
    if parts is None or len(side) != 1 or side not in refs:
        return None
    d, m, s = parts
    value = d + m / 60.0 + s / 3600.0
    if not value <= limit:
        return None
    return -value if side == refs[1] else value


def heading(raw) -> float | None:
    """Degrees in [0, 360) from a heading's text or number (XMP's GPano:PoseHeadingDegrees); None otherwise."""
    value = number(raw)
    if value is None:
        return None
    value %= 360.0
    return 0.0 if value >= 360.0 else value  # -1e-144 % 360 rounds to 360.0


MAX_EXPOSURE_S = 3600.0 * 24  # a day: longer is no exposure a camera records
MAX_F_NUMBER = 1024.0
MAX_ISO = 1.0e7
MAX_BIAS_EV = 30.0  # an exposure bias beyond +-30 stops is no camera's (--evs takes the same range)


def exposure(get) -> dict | None:
    """{"time_s", "f_number", "iso", "taken_s", "iso_recorded", "bias_ev", "manual"} from raw tag values
    (``get(name)``, None when absent): each a positive finite number, as a number, its text, a rational's text
    ("1/250") or the first of several values (ISOSpeedRatings); None when the time or the f-number is not one. An
    ISO that is not one is taken as 100 (``iso_recorded`` False: an absolute scale from it is a guess,
    ``camera.units``). bias_ev: the exposure bias the shot was compensated by (ExposureBiasValue, stops within
    +-MAX_BIAS_EV), or None.
    taken_s: when the shot was taken (DateTimeOriginal and SubSecTimeOriginal, the camera's own clock), seconds
    from year 1, or None: what tells a bracket sequence from shots minutes apart. manual: whether the photographer
    set the exposure by hand (ExposureMode 1, or ExposureProgram 1: "Manual"), as a bracket shot one setting at a
    time is."""
    time_s = positive(get("ExposureTime"), MAX_EXPOSURE_S)
    f_number = positive(get("FNumber"), MAX_F_NUMBER)
    if time_s is None or f_number is None:
        return None
    iso = positive(get("Exif:PhotographicSensitivity"), MAX_ISO) or positive(get("Exif:ISOSpeedRatings"), MAX_ISO)
    taken = exif_datetime(get("Exif:DateTimeOriginal"))
    taken_s = None if taken is None else (taken - datetime(1, 1, 1)).total_seconds() + \
        subseconds(get("Exif:SubsecTimeOriginal"))
    return {"time_s": time_s, "f_number": f_number, "iso": iso or 100.0, "taken_s": taken_s, "iso_recorded": bool(iso),
            "bias_ev": number(get("Exif:ExposureBiasValue"), -MAX_BIAS_EV, MAX_BIAS_EV),
            "manual": (integer(get("Exif:ExposureMode"), 0, 255) == 1
                       or integer(get("Exif:ExposureProgram"), 0, 255) == 1)}


MAX_JSON_DEPTH = 32  # no record PanoLight writes nests deeper
_BRACKETS = re.compile(r"[\[\]{}]")


def json_object(raw, max_bytes: int = 1 << 20) -> dict | None:
    """A JSON object from text or bytes PanoLight wrote (a manifest, a sidecar, an ID property); None when it is
    not one: not text, over ``max_bytes``, not JSON, nested deeper than MAX_JSON_DEPTH, or not an object."""
    if isinstance(raw, (bytes, bytearray)):
        raw = bytes(raw).decode("utf-8", "replace")
    if not isinstance(raw, str) or len(raw) > max_bytes or _depth(raw) > MAX_JSON_DEPTH:
        return None
    try:
        doc = json.loads(raw)
    except (ValueError, RecursionError):
        return None
    return doc if isinstance(doc, dict) else None


def _depth(raw: str) -> int:
    """An upper bound of the nesting depth of JSON text (brackets inside strings counted too: conservative)."""
    depth = top = 0
    for match in _BRACKETS.finditer(raw):
        if match.group() in "[{":
            depth += 1
            top = max(top, depth)
            if top > MAX_JSON_DEPTH:
                break
        else:
            depth -= 1
    return top


def too_deep(raw) -> bool:
    """Whether JSON text nests deeper than MAX_JSON_DEPTH (what a caller refuses by name, not silently)."""
    if isinstance(raw, (bytes, bytearray)):
        raw = bytes(raw).decode("utf-8", "replace")
    return isinstance(raw, str) and _depth(raw) > MAX_JSON_DEPTH
