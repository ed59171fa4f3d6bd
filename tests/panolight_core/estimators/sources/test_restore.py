"""An HDR file that clips its own sun: the plateau is found, weighed and filled; every other pixel is kept to the
bit, and an un-clipped file is what it always was."""
import math

import numpy as np
import pytest

from panolight_core import metrics, sh
from panolight_core.camera.color import LUMINANCE_WEIGHTS
from panolight_core.estimators import sky
from panolight_core.packed import PackedImage, RowFile
from panolight_core.pipeline.estimate import estimate_lighting
from panolight_core.pipeline.settings import Settings


def _clear_day(h=256, elev_deg=40.0):
    """The tabulated clear sky with its sun spread over a peaked 1-degree disk (the 0.53 degree sun as a lens blurs
    it: a real 1K panorama's clipped sun is 3 pixels or more), over a grey ground lit by both, exposed so its median
    luminance is 0.18 (the ev-0 JPEG's white is then 1): (float32 HDR, sun direction, the sun's luminance
    energy)."""
    t = sky.load_sky_table()
    j = int(np.argmin(abs(t.turbidities - 3.0)))
    e, az = math.radians(elev_deg), 1.0
    s = np.array([math.cos(e) * math.cos(az), math.cos(e) * math.sin(az), math.sin(e)])
    d = sh.pixel_directions(h, 2 * h)
    om = sh.pixel_solid_angles(h, 2 * h)
    img = t.sky_radiance(d.reshape(-1, 3), s)[j].reshape(h, 2 * h, 3)
    sun_rgb = t.sun_energy(elev_deg)[j]
    ang = np.degrees(np.arccos(np.clip(d @ s, -1.0, 1.0)))
    core = ang <= 1.0
    shape = 1.0 - 0.5 * ang[core] ** 2  # brightest at its centre, as a blurred disk is: no two pixels tie
    img[core] += sun_rgb * (shape / (shape * om[core]).sum())[:, None]
    ground = d[..., 2] < 0
    irradiance = (img[~ground] * (om[~ground] * np.maximum(d[~ground] @ np.array([0, 0, 1.0]), 0))[:, None]).sum(0)
    img[ground] = 0.3 * irradiance / math.pi
    k = 0.18 / float(np.median(img @ LUMINANCE_WEIGHTS))
    return (img * k).astype(np.float32), s, float(sun_rgb @ LUMINANCE_WEIGHTS) * k


@pytest.fixture(scope="module")
def day():
    return _clear_day()


def test_an_unclipped_hdr_is_projected_exactly_as_before(day):
    truth, _, _ = day
    auto = estimate_lighting(truth)
    none = estimate_lighting(truth, Settings(restore="none"))
    assert "restoration" not in auto.document["estimator"]
    assert auto.model.coeffs.tobytes() == none.model.coeffs.tobytes()
    assert auto.model.lights == none.model.lights
    assert auto.hdr_panorama(truth).tobytes() == truth.tobytes()


def test_a_clipped_sun_is_restored_on_its_plateau_alone(day):
    truth, s, sun_energy = day
    clipped = np.minimum(truth, np.float32(16.0))  # 4 stops over the JPEG's white
    plateau = (clipped >= 16.0).sum(axis=-1) >= 2
    assert 3 <= plateau.sum() < 200
    res = estimate_lighting(clipped)
    info = res.document["estimator"]["restoration"]
    assert info["restored"] and info["ceiling"] == [16.0, 16.0, 16.0] and info["plateau_pixels"] == plateau.sum()
    out = res.hdr_panorama(clipped)
    assert out[~plateau].tobytes() == clipped[~plateau].tobytes()  # every other pixel to the bit
    assert (out[plateau] >= clipped[plateau]).all()
    key = metrics.brightest_light(res.model.lights)
    assert metrics.angle_deg(key["peak_direction"], s) < 1.0
    held = metrics.cone_energy(clipped, s)
    restored = metrics.cone_energy(out, s)
    true = metrics.cone_energy(truth, s)
    assert restored > 5 * held  # the clipped file held a small part of it
    assert 0.25 < restored / true < 4.0
    assert metrics.model_shadow_contrast(res.model, s) > 1.5  # the restored sun casts a shadow
    # the estimate's own SH holds what hdr.exr holds (one account of the energy)
    assert res.estimate.coeffs[0] == pytest.approx(sh.project(out.astype(np.float64), 0)[0], rel=1e-3)
    assert true > sun_energy * 0.9  # the truth's cone holds its sun


def test_restore_none_takes_the_file_as_it_is_and_says_so(day):
    truth, _, _ = day
    clipped = np.minimum(truth, np.float32(16.0))
    res = estimate_lighting(clipped, Settings(restore="none"))
    info = res.document["estimator"]["restoration"]
    assert not info["restored"] and "--restore none" in info["why"]
    assert res.hdr_panorama(clipped).tobytes() == clipped.tobytes()
    assert np.array_equal(res.estimate.coeffs, sh.project(clipped, res.estimate.lmax).astype(np.float64))


def test_an_estimator_that_cannot_restore_says_it_took_the_file_as_it_is(day):
    truth, _, _ = day
    res = estimate_lighting(np.minimum(truth, np.float32(16.0)), Settings(estimator="naive"))
    info = res.document["estimator"]["restoration"]
    assert not info["restored"] and "naive" in info["why"]


def test_a_file_read_by_rows_is_restored_as_the_array_is(day):
    truth, _, _ = day
    clipped = np.minimum(truth, np.float32(16.0))
    packed = PackedImage(RowFile(lambda r0, r1: clipped[r0:r1], *clipped.shape[:2]), "file")
    a, b = estimate_lighting(clipped), estimate_lighting(packed)
    assert np.allclose(a.model.coeffs, b.model.coeffs, rtol=1e-9, atol=1e-12)
    assert a.hdr_panorama(clipped).tobytes() == b.hdr_panorama(packed).tobytes()


def test_sun_strength_scales_the_restored_sun(day):
    truth, s, _ = day
    clipped = np.minimum(truth, np.float32(16.0))
    one = estimate_lighting(clipped)
    two = estimate_lighting(clipped, Settings(sun_strength=2.0))
    k1, k2 = metrics.brightest_light(one.model.lights), metrics.brightest_light(two.model.lights)
    assert k2["intensity"] == pytest.approx(2.0 * k1["intensity"], rel=1e-9)
    assert metrics.cone_energy(two.hdr_panorama(clipped), s) > metrics.cone_energy(one.hdr_panorama(clipped), s)


def test_a_bad_restore_setting_is_refused():
    from panolight_core.errors import PanoLightError

    with pytest.raises(PanoLightError, match="restore must be one of auto, none"):
        Settings(restore="always")


def test_a_warm_sun_s_light_stands_at_its_plateau_s_core_not_its_aureole(day, monkeypatch):
    """A sunset's glow leans 5 degrees to one side of the sun and clips red and green, not blue, at the file's
    ceiling: the plateau of two channels is mostly glow, and its centroid about 4 degrees off the sun. The key light
    stands at the core every channel clips (the sun's disk), and the glow makes no second light beside it."""
    from panolight_core.estimators import keylight

    truth, s, _ = day
    h, w = truth.shape[:2]
    d = sh.pixel_directions(h, w)
    side = np.cross(s, [0.0, 0.0, 1.0])
    side /= np.linalg.norm(side)
    glow_at = math.cos(math.radians(5.0)) * s + math.sin(math.radians(5.0)) * side
    t = np.degrees(np.arccos(np.clip(d @ glow_at, -1.0, 1.0)))
    warm = truth + (np.exp(-0.5 * (t / 3.0) ** 2)[..., None] * np.array([20.0, 12.0, 0.5])).astype(np.float32)
    clipped = np.minimum(warm, np.float32(4.0))  # 2 stops over the JPEG's white
    plateau = (clipped >= 4.0).sum(axis=-1) >= 2
    om = sh.pixel_solid_angles(h, w)
    centroid = (d[plateau] * om[plateau, None]).sum(0)
    assert metrics.angle_deg(centroid / np.linalg.norm(centroid), s) > 3.0  # the plateau is mostly glow
    res = estimate_lighting(clipped)
    key = metrics.brightest_light(res.model.lights)
    assert metrics.angle_deg(key["peak_direction"], s) < 1.0
    assert not [light for light in res.model.lights if light is not key
                and metrics.angle_deg(light["direction"], s) < 15.0]
    monkeypatch.setattr(keylight.find, "at_cores", lambda regions, core: regions)  # at the plateau's centroid instead
    off = metrics.brightest_light(estimate_lighting(clipped).model.lights)
    assert metrics.angle_deg(off["peak_direction"], s) > 2.0


def test_the_artist_s_click_restores_a_sun_whose_plateau_lost_its_ties(day):
    """A file resampled after its merge keeps its clipped sun as a bump with no exact ties: nothing is restored,
    and it casts no shadow. Clicked a degree off, the sun is restored there: a key light on the click that casts a
    shadow, hdr.exr holding its energy, every pixel under half the bump's peak kept to the bit (but the sun's own,
    on the click), and lighting.json
    saying what was declared. ``--restore none`` keeps the file as it is; a click on plain sky, or on the un-clipped
    file's own sun, says why nothing changed."""
    truth, s, _ = day
    rng = np.random.default_rng(5)
    untied = (np.minimum(truth, np.float32(16.0)) * (1 + 1e-3 * rng.uniform(-1, 1, truth.shape))).astype(np.float32)
    as_is = estimate_lighting(untied)
    assert "restoration" not in as_is.document["estimator"]
    assert metrics.model_shadow_contrast(as_is.model, s) < 1.2
    side = np.cross(s, [0.0, 0.0, 1.0])
    click = math.cos(math.radians(1.0)) * s + math.sin(math.radians(1.0)) * side / np.linalg.norm(side)
    res = estimate_lighting(untied, Settings(sun_direction=tuple(click)))
    info = res.document["estimator"]["restoration"]
    assert info["restored"] and "the artist's sun points at a bright patch" in info["declared"]
    assert info["why"].startswith("the artist's sun points at") and not res.warnings
    key = metrics.brightest_light(res.model.lights)
    assert metrics.angle_deg(key["direction"], click) < 1e-6 and "the artist's direction" in key["source"]
    assert metrics.model_shadow_contrast(res.model, s) > 1.5
    out = res.hdr_panorama(untied)
    peak = float((untied @ LUMINANCE_WEIGHTS.astype(np.float32)).max())
    on_click = sh.pixel_directions(*untied.shape[:2]) @ click > math.cos(math.radians(1.0))  # the sun, put there
    kept = ((untied @ LUMINANCE_WEIGHTS.astype(np.float32)) < 0.4 * peak) & ~on_click
    assert out[kept].tobytes() == untied[kept].tobytes()
    assert metrics.cone_energy(out, s) > 5 * metrics.cone_energy(untied, s)
    none = estimate_lighting(untied, Settings(sun_direction=tuple(click), restore="none"))
    assert none.model.coeffs.tobytes() == as_is.model.coeffs.tobytes()
    assert any("changes nothing" in w for w in none.warnings)
    sky = estimate_lighting(untied, Settings(sun_direction=tuple(-s)))
    assert sky.model.coeffs.tobytes() == as_is.model.coeffs.tobytes()
    assert any("there is no bright patch within 10 deg" in w for w in sky.warnings)
    whole = estimate_lighting(truth, Settings(sun_direction=tuple(click)))  # the un-clipped file: its sun is its own
    assert whole.model.coeffs.tobytes() == estimate_lighting(truth).model.coeffs.tobytes()
    assert any("a source the file holds whole" in w for w in whole.warnings)


def test_a_plateau_beyond_any_real_radiance_is_taken_as_it_is_not_restored(day):
    """Trust round 4: an EXR with a 10 x 10 patch at float32's largest value raised "zero-size array" in the
    restoration's decision (its expected errors overflowed). Such a plateau is an overflow or a sentinel: the file
    is taken as it is, and its info says why; a patch at 1e11 (a bright but real unit) is still restored."""
    truth, _, _ = day
    infos = {}
    for level in (np.finfo(np.float32).max, 1e11):
        img = truth.copy()
        img[50:60, 100:110] = np.float32(level)
        res = estimate_lighting(img)
        infos[level] = res.document["estimator"]["restoration"]
        assert np.isfinite(res.model.coeffs).all()
    flt_max, bright = infos.values()
    assert not flt_max["restored"] and "beyond any real radiance" in flt_max["why"]
    assert bright["restored"]


def test_sun_strength_zero_is_the_limit_of_small_strengths(day):
    """Trust round 4: --sun-strength 0 on a restored HDR dropped the key light, and the lighting model then took
    the patch's fill as a new 0.46 light, while 0.001 gave a light of a thousandth. Now 0 keeps the light at zero
    energy in its place, and no other light is taken there."""
    truth, s, _ = day
    clipped = np.minimum(truth, np.float32(16.0))
    one, small, zero = (estimate_lighting(clipped, Settings(sun_strength=k)) for k in (1.0, 1e-3, 0.0))

    def at_sun(res):  # the lights within 5 degrees of the sun
        return [light["intensity"] for light in res.model.lights if metrics.angle_deg(light["direction"], s) < 5.0]

    assert len(zero.model.lights) == len(small.model.lights) == len(one.model.lights)
    assert len(at_sun(one)) == 1 and at_sun(zero) == [0.0]
    assert at_sun(small) == [pytest.approx(1e-3 * at_sun(one)[0], rel=1e-6)]
    assert zero.model.coeffs[0] == pytest.approx(small.model.coeffs[0], rel=0.05)
