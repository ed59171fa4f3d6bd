"""estimators.sun_search: a sun located and weighed from the clear sky alone, and the tests that refuse one."""
import math

import numpy as np
import pytest

from panolight_core import metrics, sh
from panolight_core.camera.color import LUMINANCE_WEIGHTS, linear_to_srgb
from panolight_core.estimators import sky, sources, sun_search

from .test_sky import _clear_sky_ldr, _sun


def test_sun_candidates_cover_the_sky_and_a_neighbourhood():
    everywhere = sun_search.sun_candidates(7.5)
    assert (everywhere[:, 2] > 0).all()
    np.testing.assert_allclose(np.linalg.norm(everywhere, axis=1), 1.0)
    rng = np.random.default_rng(2)  # no point of the sky is far from a candidate
    v = rng.normal(size=(500, 3))
    v[:, 2] = np.abs(v[:, 2])
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    v = v[v[:, 2] > math.sin(math.radians(4.0))]
    assert np.degrees(np.arccos(np.clip(v @ everywhere.T, -1, 1)).min(axis=1)).max() < 7.5
    c = _sun(40.0, 1.0)
    near = sun_search.sun_candidates(2.5, c, 10.0)
    ang = np.degrees(np.arccos(np.clip(near @ c, -1, 1)))
    assert ang.max() <= 10.0 + 1e-6 and ang.min() < 1e-6 and len(near) > 20


def _hidden_sun_maps(mask_deg=20.0, elev=40.0, turbidity=3.0):
    """Work maps of ``_clear_sky_ldr`` with every cell within ``mask_deg`` of the sun hidden from the search."""
    ldr, s, k, energy, t = _clear_sky_ldr(elev=elev, turbidity=turbidity)
    rad, fa, fall = sources.work_maps(ldr)
    near = sh.pixel_directions(*fa.shape) @ s > math.cos(math.radians(mask_deg))
    return rad, (fa == 0) & ~near, (fall > 0.5) & ~near, s, energy


@pytest.mark.parametrize("elev, turbidity", [(25.0, 2.5), (55.0, 4.0)])
def test_the_sky_alone_locates_and_weighs_a_hidden_sun(elev, turbidity):
    """The sun and the 20 degrees around it hidden: the clear sky's own falloff puts it back."""
    rad, usable, clipped, s, energy = _hidden_sun_maps(elev=elev, turbidity=turbidity)
    found = sun_search.search_sun(rad, usable, clipped)
    assert isinstance(found, sun_search.SunSearch) and found.found
    assert metrics.angle_deg(found.direction, s) <= sun_search.REFINE_STEP_DEG  # the refinement's grid step
    assert found.fit.sun_energy == pytest.approx(energy, rel=0.25)
    assert found.contrast < 0.5


def test_an_overcast_sky_puts_no_sun_anywhere():
    """A blue-tinted overcast sky (CIE overcast: brighter toward the zenith, no sun): no position is singled out."""
    t = sky.load_sky_table()
    h = 128
    d = sh.pixel_directions(h, 2 * h)
    blue = t.sky_radiance(np.array([[0.0, 0.0, 1.0]]), _sun(45.0))[3, 0]  # a clear sky's zenith colour
    rad = ((1 + 2 * np.clip(d[..., 2], 0, 1)) / 3)[..., None] * blue / float(blue @ LUMINANCE_WEIGHTS) * 0.5
    rad[d[..., 2] <= 0] = 0.05
    ldr = np.round(linear_to_srgb(np.clip(rad, 0, 1)) * 255).astype(np.uint8)
    w, fa, fall = sources.work_maps(ldr)
    found = sun_search.search_sun(w, fa == 0, fall > 0.5)
    assert not found.found
    (why,) = found.refusals()  # the search stops early, and says why in the words lighting.json carries
    assert why.startswith("no position stands out (best score ")


def test_a_search_with_too_little_sky_says_so():
    """Most of the sky clipped (an over-exposed photo): the search stops before fitting and names the reason
    with its numbers; with no unclipped sky at all, even a study's search (no early stop) says there is none."""
    rad, usable, clipped, s, _ = _hidden_sun_maps(mask_deg=0.0)
    d = sh.pixel_directions(*usable.shape)
    up = d[..., 2]
    behind = np.degrees(np.arccos(np.clip(-(d[..., :2] @ s[:2]) / np.maximum(np.linalg.norm(d[..., :2], axis=-1), 1e-9)
                                          / np.linalg.norm(s[:2]), -1, 1)))
    wedge = usable & (behind < 30.0)  # only a 60-degree wedge of sky, opposite the sun, is left (about 1 sr)
    found = sun_search.search_sun(rad, wedge, clipped)
    assert isinstance(found, sun_search.NoSun) and not found.found
    (why,) = found.refusals()
    sr = float(why.split("(")[1].split(" sr")[0])
    assert why.startswith("too little sky (") and 0.3 < sr < sun_search.HIDDEN_MIN_SKY_SR
    none = sun_search.search_sun(rad, usable & (up < 0), clipped, max_contrast=None)
    assert none.refusals() == [sun_search.NO_SKY]


def test_a_sun_behind_an_occluder_is_not_seen():
    rad, usable, clipped, s, _ = _hidden_sun_maps(mask_deg=0.0)
    dark = sh.pixel_directions(*usable.shape) @ s > math.cos(math.radians(15.0))
    rad = np.where(dark[..., None], 0.01, rad)  # a building in front of the sun
    found = sun_search.search_sun(rad, usable | dark, clipped & ~dark)
    assert isinstance(found, sun_search.SunSearch) and metrics.angle_deg(found.direction, s) < 10.0
    assert not found.seen


def test_a_sky_whose_colour_runs_against_a_clear_skys_puts_no_sun():
    """The luminance of a clear sky with its blue/red mirrored (redder where a sky is bluer): a lit wall or
    ceiling can follow a sky's falloff, not the way its colour varies. Only the colour test refuses it."""
    rad, usable, clipped, s, _ = _hidden_sun_maps()
    found = sun_search.search_sun(rad, usable, clipped)
    assert found.found and found.colour_match > 0.9
    y, g = rad @ LUMINANCE_WEIGHTS, rad[..., 1]
    q = np.log(np.maximum(rad[..., 2], 1e-6) / np.maximum(rad[..., 0], 1e-6))
    sky_cells = usable & (rad.min(axis=-1) > 1e-4) & (sh.pixel_directions(*usable.shape)[..., 2] > 0)
    q = np.exp(2 * np.median(q[sky_cells]) - q)  # mirrored about its median
    r = (y - LUMINANCE_WEIGHTS[1] * g) / (LUMINANCE_WEIGHTS[0] + LUMINANCE_WEIGHTS[2] * q)
    wall = np.where(sky_cells[..., None], np.stack([r, g, q * r], axis=-1), rad)
    # as blue overall as the sky was (blue/red of the solid-angle weighted sums), so the cloudiness gate's
    # colour test passes
    om = sh.pixel_solid_angles(*usable.shape)[sky_cells][:, None]
    a, b = (rad[sky_cells] * om).sum(axis=0), (wall[sky_cells] * om).sum(axis=0)
    wall[..., 2] *= (a[2] / a[0]) / (b[2] / b[0])
    mirrored = sun_search.search_sun(wall, usable, clipped)
    assert isinstance(mirrored, sun_search.SunSearch) and mirrored.colour_match < 0 and not mirrored.found
    assert mirrored.fit.clear and mirrored.contrast <= sun_search.HIDDEN_MAX_CONTRAST  # every other test passes
    (why,) = mirrored.refusals()
    assert why.startswith("the sky's colour does not vary as a clear sky's")
