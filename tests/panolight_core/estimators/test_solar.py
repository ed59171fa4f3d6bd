"""NOAA's solar position against PyEphem (an independent ephemeris, VSOP87), and its own identities."""
from datetime import datetime, timedelta, timezone

import numpy as np
import pytest

from panolight_core.estimators.solar import julian_day, sun_position


def _ephem(lat, lon, when, refraction):
    ephem = pytest.importorskip("ephem")
    obs = ephem.Observer()
    obs.lat, obs.lon = str(lat), str(lon)
    obs.date = when.astimezone(timezone.utc).replace(tzinfo=None)
    obs.pressure = 1010.0 if refraction else 0.0  # 0: no refraction
    obs.temp = 10.0
    sun = ephem.Sun(obs)
    return np.degrees(float(sun.az)), np.degrees(float(sun.alt))


def test_julian_day_of_known_dates_and_naive_times_refused():
    assert julian_day(datetime(2000, 1, 1, 12, tzinfo=timezone.utc)) == 2451545.0
    assert julian_day(datetime(1987, 1, 27, 0, tzinfo=timezone.utc)) == pytest.approx(2446822.5)  # Meeus, ex. 7.a
    with pytest.raises(ValueError, match="UTC offset"):
        julian_day(datetime(2024, 6, 21, 12))


@pytest.mark.parametrize("refraction", [False, True])
def test_the_sun_stands_where_an_ephemeris_puts_it(rng, refraction):
    """300 random places and times from 1950 to 2050, the sun above 2 degrees (where refraction models agree):
    azimuth and elevation within 0.05 degrees of PyEphem's."""
    start = datetime(1950, 1, 1, tzinfo=timezone.utc)
    checked = 0
    while checked < 300:
        lat, lon = rng.uniform(-75, 75), rng.uniform(-180, 180)
        when = start + timedelta(seconds=float(rng.uniform(0, 100 * 365.25 * 86400)))
        az, el = sun_position(lat, lon, when, refraction)
        ref_az, ref_el = _ephem(lat, lon, when, refraction)
        if ref_el < 2.0:
            continue
        checked += 1
        assert el == pytest.approx(ref_el, abs=0.05)
        assert abs((az - ref_az + 180.0) % 360.0 - 180.0) * np.cos(np.radians(el)) < 0.05, (lat, lon, when)


def test_noon_at_the_equinox_and_the_time_zone_changes_nothing():
    """At the March equinox's noon on the Greenwich meridian the sun is due south of Paris at 90 - 48.85 - ~0 up;
    the same instant given in another time zone is the same sun."""
    when = datetime(2024, 3, 20, 12, 7, tzinfo=timezone.utc)  # the equation of time: apparent noon at 12:07
    az, el = sun_position(48.85, 0.0, when, refraction=False)
    assert az == pytest.approx(180.0, abs=0.3) and el == pytest.approx(90.0 - 48.85, abs=0.3)
    local = when.astimezone(timezone(timedelta(hours=5, minutes=30)))
    assert sun_position(48.85, 0.0, local) == sun_position(48.85, 0.0, when)
    with pytest.raises(ValueError, match="out of range"):
        sun_position(95.0, 0.0, when)
