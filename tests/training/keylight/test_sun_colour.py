"""training.keylight.sun_colour: the truth's sun colour, the model's at the true direction, and the white point."""
import math

import numpy as np
import pytest

from panolight_core import sh
from panolight_core.camera.color import LUMINANCE_WEIGHTS
from panolight_core.estimators import keylight
from panolight_core.estimators import sky as clear_sky
from training.keylight import sun_colour


def model_sky_with_sun(elev=35.0, sun_colour=None, h=256):
    """The tabulated clear sky over a dark ground with its solar disk painted in, in the model's colour or in
    ``sun_colour`` (luminance 1, the model's energy): (hdr, sun direction, the model's sun RGB energy)."""
    t = clear_sky.load_sky_table()
    j = int(np.argmin(abs(t.turbidities - 3.0)))
    e = math.radians(elev)
    s = np.array([math.cos(e) * math.cos(1.0), math.cos(e) * math.sin(1.0), math.sin(e)])
    d = sh.pixel_directions(h, 2 * h)
    hdr = t.sky_radiance(d.reshape(-1, 3), s)[j].reshape(h, 2 * h, 3)
    hdr[d[..., 2] <= 0] = 0.02 * float(np.median(hdr[d[..., 2] > 0] @ LUMINANCE_WEIGHTS))
    disk = d @ s > math.cos(math.radians(0.6))
    rgb = t.sun_energy(elev)[j]
    paint = rgb if sun_colour is None else float(rgb @ LUMINANCE_WEIGHTS) * np.asarray(sun_colour)
    hdr[disk] += paint / sh.pixel_solid_angles(h, 2 * h)[disk].sum()
    return hdr, s, rgb


def test_the_true_colour_is_the_disk_s_over_its_sky_and_none_without_a_source():
    hdr, s, rgb = model_sky_with_sun()
    got = sun_colour.true_sun_colour(hdr, s)
    assert float(got @ LUMINANCE_WEIGHTS) == pytest.approx(1.0)
    assert sun_colour.colour_error(got, rgb) < 0.05  # the disk's own colour, not the blue sky's
    flat = np.full((64, 128, 3), 0.5)
    assert sun_colour.true_sun_colour(flat, s) is None


def test_a_sun_painted_white_gives_the_model_s_colour_as_the_white_point():
    """A scene whose sun is white where the model's is orange: the fit at the true direction reports the model's
    colour, the white point is that colour, and balancing by it brings the sun back to white."""
    hdr, s, rgb = model_sky_with_sun(sun_colour=(1.0, 1.0, 1.0))
    rows = [dict(r, scene="x") for r in sun_colour.score_scene(hdr, [0.0])]
    (row,) = rows
    assert row["clear"] and sun_colour.colour_error(row["true"], (1.0, 1.0, 1.0)) < 0.05
    assert sun_colour.colour_error(row["model"], rgb) < 0.02
    white = sun_colour.white_point(rows)
    assert sun_colour.colour_error(white, rgb) < 0.05
    back = keylight.camera_colour(row["model"], row["elevation_deg"], sun_colour.with_white(white))
    assert sun_colour.colour_error(back, (1.0, 1.0, 1.0)) < 0.05


def test_colour_error_is_the_worst_channel_in_octaves():
    assert sun_colour.colour_error((1.0, 1.0, 1.0), (1.0, 1.0, 1.0)) == pytest.approx(0.0, abs=1e-12)
    assert sun_colour.colour_error((2.0, 2.0, 4.0), (1.0, 1.0, 1.0)) > 0.5
    assert sun_colour.colour_error((3.0, 3.0, 3.0), (1.0, 1.0, 1.0)) == pytest.approx(0.0, abs=1e-12)  # scale-free
