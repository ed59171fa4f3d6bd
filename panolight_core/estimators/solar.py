"""Where the sun stands at a place and time: NOAA's solar position algorithm (the Solar Calculator's, after
Meeus's Astronomical Algorithms), in plain Python so that Blender has it too: within 0.02 degrees of PyEphem
from 1950 to 2050 at any latitude (tests/panolight_core/estimators/test_solar.py), far inside what a camera's
compass heading allows.
"""
from __future__ import annotations

import math
from datetime import datetime, timezone

_J2000 = 2451545.0  # the Julian day of 2000-01-01 12:00 UTC


def julian_day(when: datetime) -> float:
    """The Julian day of an aware datetime (a naive one is refused: a photo's local time is not UTC)."""
    if when.tzinfo is None or when.utcoffset() is None:
        raise ValueError("the time must carry its UTC offset (a naive datetime is a guess)")
    seconds = (when - datetime(2000, 1, 1, 12, tzinfo=timezone.utc)).total_seconds()
    return _J2000 + seconds / 86400.0


def sun_position(latitude_deg: float, longitude_deg: float, when: datetime, refraction: bool = True
                 ) -> tuple[float, float]:
    """(azimuth, elevation) of the sun's centre in degrees: azimuth clockwise from true north (a compass
    bearing), elevation above the horizon, with the atmosphere's refraction (NOAA's model) unless
    ``refraction`` is False. latitude north and longitude east positive; ``when`` an aware datetime."""
    if not (-90.0 <= latitude_deg <= 90.0 and -180.0 <= longitude_deg <= 360.0):
        raise ValueError(f"latitude {latitude_deg} / longitude {longitude_deg} out of range")
    t = (julian_day(when) - _J2000) / 36525.0  # Julian centuries
    mean_long = (280.46646 + t * (36000.76983 + t * 0.0003032)) % 360.0
    anomaly = math.radians(357.52911 + t * (35999.05029 - 0.0001537 * t))
    ecc = 0.016708634 - t * (0.000042037 + 0.0000001267 * t)
    centre = (math.sin(anomaly) * (1.914602 - t * (0.004817 + 0.000014 * t))
              + math.sin(2 * anomaly) * (0.019993 - 0.000101 * t) + math.sin(3 * anomaly) * 0.000289)
    omega = math.radians(125.04 - 1934.136 * t)
    apparent = math.radians(mean_long + centre - 0.00569 - 0.00478 * math.sin(omega))
    obliquity = math.radians(23.0 + (26.0 + (21.448 - t * (46.815 + t * (0.00059 - t * 0.001813))) / 60.0) / 60.0
                             + 0.00256 * math.cos(omega))
    decl = math.asin(math.sin(obliquity) * math.sin(apparent))
    y = math.tan(obliquity / 2.0) ** 2
    l0 = math.radians(mean_long)
    eq_time = 4.0 * math.degrees(y * math.sin(2 * l0) - 2 * ecc * math.sin(anomaly)
                                 + 4 * ecc * y * math.sin(anomaly) * math.cos(2 * l0)
                                 - 0.5 * y * y * math.sin(4 * l0) - 1.25 * ecc * ecc * math.sin(2 * anomaly))  # minutes
    utc = when.astimezone(timezone.utc)
    minutes = utc.hour * 60.0 + utc.minute + (utc.second + utc.microsecond / 1e6) / 60.0
    solar_time = (minutes + eq_time + 4.0 * longitude_deg) % 1440.0
    hour_angle = math.radians(solar_time / 4.0 - 180.0)
    lat = math.radians(latitude_deg)
    cos_zenith = math.sin(lat) * math.sin(decl) + math.cos(lat) * math.cos(decl) * math.cos(hour_angle)
    elevation = 90.0 - math.degrees(math.acos(max(-1.0, min(1.0, cos_zenith))))
    azimuth = (math.degrees(math.atan2(math.sin(hour_angle), math.cos(hour_angle) * math.sin(lat)
                                       - math.tan(decl) * math.cos(lat))) + 180.0) % 360.0
    return azimuth, elevation + (_refraction(elevation) if refraction else 0.0)


def _refraction(elevation: float) -> float:
    """NOAA's approximation of the atmosphere's refraction (degrees) at a true elevation (degrees)."""
    if elevation > 85.0:
        return 0.0
    te = math.tan(math.radians(elevation))
    if elevation > 5.0:
        arcsec = 58.1 / te - 0.07 / te ** 3 + 0.000086 / te ** 5
    elif elevation > -0.575:
        arcsec = 1735.0 + elevation * (-518.2 + elevation * (103.4 + elevation * (-12.79 + elevation * 0.711)))
    else:
        arcsec = -20.772 / te
    return arcsec / 3600.0
