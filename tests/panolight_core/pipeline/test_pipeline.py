"""pipeline: Settings validation, estimate_lighting (the one path from pixels to a lighting document)
and run_estimate (file -> folder)."""
import math

import numpy as np
import pytest

from panolight_core import sh
from panolight_core.errors import PanoLightError
from panolight_core.io import write_image
from panolight_core.io.lighting import read_lighting, validate
from panolight_core.pipeline import OUTPUT_FILES, Settings, estimate_lighting, fit_pixels, run_estimate


@pytest.fixture
def sunny():
    """A small HDR sky with a bright sun, and its 8-bit photo (clipped sun)."""
    h, w = 32, 64
    dirs = sh.pixel_directions(h, w)
    hdr = (0.3 + 0.2 * np.clip(dirs[..., 2:3], 0, 1)) * np.ones((h, w, 3))
    sun = dirs @ np.array([0.6, 0.0, 0.8]) > math.cos(math.radians(6))
    hdr[sun] = 80.0
    ldr = np.round(np.clip(hdr, 0, 1) ** (1 / 2.2) * 255).astype(np.uint8)
    return hdr.astype(np.float32), ldr


@pytest.mark.parametrize("kwargs, message", [
    ({"estimator": "magic"}, "unknown estimator 'magic'"), ({"model": "fancy"}, "model must be one of"),
    ({"lmax": 101}, "lmax must be in 0..100"), ({"lmax": "x"}, "lmax must be an integer"),
    ({"tolerance": float("nan")}, "tolerance must be a number"), ({"tolerance": -1.0}, "tolerance must be"),
    ({"window": "gauss"}, "window must be one of"), ({"window_width": -3.0}, "window_width must be"),
    ({"exposure_ev": 200.0}, "exposure_ev must be"), ({"exposure_ev": "1"}, "exposure_ev must be")])
def test_settings_refuse_bad_values_naming_them(kwargs, message):
    with pytest.raises(PanoLightError, match=message):
        Settings(**kwargs)


def test_settings_order_resolves_the_models_default():
    assert Settings().order == "auto" and Settings(model="sh").order == "2"
    assert Settings(lmax=5).order == "5" and Settings(model="sh", lmax="auto").order == "auto"


def test_estimate_lighting_is_fit_pixels_with_the_requested_window_and_exposure(sunny):
    hdr, _ = sunny
    base = estimate_lighting(hdr, Settings(model="sh", lmax=4))
    fitted, _ = fit_pixels(hdr, lmax=4, model="sh")
    assert np.array_equal(base.model.coeffs, fitted.coeffs)
    windowed = estimate_lighting(hdr, Settings(model="sh", lmax=4, window="hanning", window_width=6.0,
                                               exposure_ev=1.0))
    assert np.allclose(windowed.model.coeffs, 2.0 * sh.window(fitted.coeffs, "hanning", 6.0), rtol=1e-12)
    assert windowed.document["window"] == {"kind": "hanning", "mode": "fixed", "width": 6.0}
    assert windowed.document["exposure_ev"] == 1.0
    auto = estimate_lighting(hdr, Settings(model="sh", lmax=4, window="auto"))
    assert auto.document["window"]["mode"] == "auto"


def test_exposure_scales_lights_sh_and_the_hdri_by_the_same_factor(sunny):
    _, ldr = sunny
    one = estimate_lighting(ldr)
    two = estimate_lighting(ldr, Settings(exposure_ev=-2.0))
    assert one.model.lights, "the clipped sun should become an explicit light"
    assert np.allclose(two.model.coeffs, one.model.coeffs / 4, rtol=1e-12)
    for a, b in zip(one.model.lights, two.model.lights):
        assert math.isclose(b["intensity"], a["intensity"] / 4, rel_tol=1e-12)
    assert np.allclose(two.hdr_panorama(ldr), one.hdr_panorama(ldr) / 4, rtol=1e-6)


def test_a_clipped_source_weighed_in_a_panorama_narrower_than_the_model_learned_from_is_warned_of(sunny):
    """A 256-wide JPEG's sun came back 73x off (median of 43 real scenes; 13x at 1024): the artist is told, once
    the per-source model has weighed a clipped region, and only then (docs/studies/small_inputs.md)."""
    from panolight_core.estimators.sources import TRAINED_MIN_WIDTH

    hdr, ldr = sunny
    said = [w for w in estimate_lighting(ldr).warnings if "pixels" in w]
    assert said == [f"the panorama is only 64 x 32 pixels: its clipped suns and lamps were weighed by a model that "
                    f"learned from panoramas {TRAINED_MIN_WIDTH} or more wide, so their energy is far less certain "
                    f"(use the full-size file if you have it)"]
    clipped_hdr = np.minimum(hdr, 4.0)  # an HDR that clips its own sun, restored: the same model weighs it
    assert any("64 x 32 pixels" in w for w in estimate_lighting(clipped_hdr).warnings)
    wide = np.repeat(np.repeat(ldr, 8, axis=0), 8, axis=1)  # 512 wide: what the model learned from
    assert wide.shape[1] == TRAINED_MIN_WIDTH and estimate_lighting(wide).model.lights
    assert estimate_lighting(wide).warnings == ()
    unclipped = np.round(np.clip(hdr, 0, 0.9) ** (1 / 2.2) * 255).astype(np.uint8)  # nothing for the model to weigh
    assert estimate_lighting(unclipped).warnings == ()
    assert estimate_lighting(clipped_hdr, Settings(restore="none")).warnings == ()  # the file as it is: no weighing
    assert estimate_lighting(ldr, Settings(estimator="naive")).warnings == ()


def test_the_document_is_valid_and_says_its_units(sunny):
    hdr, ldr = sunny
    for px, units in ((hdr, "input radiance units"), (ldr, "relative: 1 = the LDR camera's clip level")):
        doc = estimate_lighting(px).document
        validate(doc)
        assert doc["units"].startswith(units) and doc["estimator"]["name"] == "keylight"
        assert set(doc["timings"]) == {"estimate_s", "model_s"} and "source" not in doc
        assert np.allclose(doc["coefficients"], estimate_lighting(px).model.coeffs)


def test_overflowing_lighting_is_refused(sunny):
    hdr, _ = sunny
    with pytest.raises(PanoLightError, match="would not be finite"):
        estimate_lighting(hdr * np.float32(1e30), Settings(exposure_ev=59.0))


def test_run_estimate_writes_the_document_of_estimate_lighting_with_its_source(tmp_path, sunny):
    _, ldr = sunny
    from panolight_core.io import write_srgb8

    src = write_srgb8(tmp_path / "sky.png", ldr)
    settings = Settings(model="sh", lmax=3, window="sinc4", exposure_ev=0.5)
    doc = run_estimate(src, tmp_path / "out", settings)
    single = tuple(n for n in OUTPUT_FILES if n != "clipped.png")  # clipped.png is a bracket set's
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == sorted(single + (".panolight-files.json",))
    coeffs, written = read_lighting(tmp_path / "out" / "lighting.json")
    assert np.allclose(coeffs, estimate_lighting(ldr, settings).model.coeffs)
    assert written["source"]["width"] == 64 and written["source"]["dynamic_range"] == "ldr-8bit-srgb"
    assert set(written["timings"]) == {"read_s", "estimate_s", "model_s", "write_s"} and written == doc


def test_run_estimate_reports_progress_through_logging_and_prints_nothing(tmp_path, sunny, caplog, capsys):
    import logging

    from panolight_core.io import write_srgb8

    src = write_srgb8(tmp_path / "sky.png", sunny[1])
    with caplog.at_level(logging.INFO, logger="panolight_core"):
        run_estimate(src, tmp_path / "out")
    said = [r.getMessage() for r in caplog.records if r.name == "panolight_core.pipeline.job"]
    assert said[0] == f"reading {src}" and said[-1].startswith("writing ") and len(said) == 5
    assert said[3].startswith("units: relative")  # the scale the files hold (docs/units.md)
    assert capsys.readouterr() == ("", "")  # a library user's terminal stays theirs


def test_run_estimate_says_what_an_artist_should_know_of_the_key_light(tmp_path, caplog):
    """A photo whose sun is retouched out: the run logs where its sky puts a sun (``key_light_note``), how sure, and
    the --sun that places it, in the words of a tool that has no lamps; with --sky-sun it was placed there."""
    import logging

    from panolight_core.io import write_srgb8
    from tests.panolight_core.estimators.test_keylight import _retouched_sky

    src = write_srgb8(tmp_path / "retouched.png", _retouched_sky(paint=1.0)[0])
    with caplog.at_level(logging.INFO, logger="panolight_core"):
        doc = run_estimate(src, tmp_path / "out", outputs=("lighting",))
    said = [r.getMessage() for r in caplog.records if r.name == "panolight_core.pipeline.job"]
    notes = [m for m in said if m.startswith("note: ")]
    assert len(notes) == 1 and notes[0].startswith("note: the photo shows no sun; its sky's gradient suggests one")
    assert f"{doc['estimator']['sun_search']['elevation_deg']:.0f} deg up" in notes[0] and "a sun light" in notes[0]
    caplog.clear()
    with caplog.at_level(logging.INFO, logger="panolight_core"):
        doc = run_estimate(src, tmp_path / "bold", outputs=("lighting",), settings=Settings(sky_sun=True))
    notes = [r.getMessage() for r in caplog.records if r.getMessage().startswith("note: ")]
    assert len(notes) == 1 and notes[0].startswith("note: the photo shows no sun, so one was placed")
    assert f"{doc['estimator']['sun_search']['elevation_deg']:.0f} deg up" in notes[0] and "its light" in notes[0]


def test_run_estimate_refuses_to_replace_its_input(tmp_path, sunny):
    hdr, _ = sunny
    src = write_image(tmp_path / "hdr.exr", hdr)
    with pytest.raises(PanoLightError, match="would overwrite the input"):
        run_estimate(src, tmp_path)


@pytest.mark.parametrize("model, name, kind", [("auto", "sunset.hdr", "rgbe"), ("sh", "sunset.hdr", "rgbe"),
                                               ("auto", "sunset.exr", "file"), ("sh", "sunset.exr", "file")])
def test_a_packed_panorama_gives_the_same_estimate_bit_for_bit(tmp_path, model, name, kind):
    """The CLI holds a large HDR packed (io.read_image's packed_above), or leaves a float32 EXR no code holds in
    its file: every pass reads it by row blocks (the SH projection, the lights' area means and peak directions,
    the float64 SH-only fit, hdr.exr's rows), and every number is the float32 array's. Blender's sunset: a sun
    the lights model takes (as float32 with a little noise, which no half float holds)."""
    from panolight_core.data import load_studio_hdri
    from panolight_core.io import read_image
    from panolight_core.packed import PackedImage

    sunset = load_studio_hdri("sunset") * (1.0 + 1e-5 * np.random.default_rng(0).standard_normal((1, 1024, 1)))
    path = write_image(tmp_path / name, sunset.astype(np.float32))
    plain, packed = read_image(path), read_image(path, packed_above=0.0)
    assert isinstance(packed, PackedImage) and packed.kind == kind
    settings = Settings(model=model, exposure_ev=1.0)
    a, b = estimate_lighting(plain, settings), estimate_lighting(packed, settings)
    assert model == "sh" or a.model.lights
    for doc in (a.document, b.document):
        doc.pop("timings")
        doc["model"].pop("fit_s")
    assert a.document == b.document and a.warnings == b.warnings
    blocks = [(list(a.hdr_blocks(plain)), a.hdr_blocks(plain).peak), (list(b.hdr_blocks(packed)), b.hdr_blocks(packed).peak)]
    assert blocks[0][1] == blocks[1][1]
    for (r0, x), (r1, y) in zip(blocks[0][0], blocks[1][0], strict=True):
        assert r0 == r1 and np.array_equal(x.view(np.int32), y.view(np.int32))


def _capture_for(direction):
    """(lat, lon, UTC time, heading) whose sun (``solar.sun_position``) stands at unit ``direction`` of the
    panorama: the time found by bisection on the morning's rising sun, the heading turning its azimuth there."""
    from datetime import datetime, timedelta, timezone

    from panolight_core.estimators.solar import sun_position

    lat, lon = 48.8584, 2.2945
    target = math.degrees(math.asin(direction[2]))
    lo, hi = datetime(2024, 6, 21, 4, tzinfo=timezone.utc), datetime(2024, 6, 21, 11, tzinfo=timezone.utc)
    for _ in range(60):
        mid = lo + (hi - lo) / 2
        lo, hi = (mid, hi) if sun_position(lat, lon, mid)[1] < target else (lo, mid)
    when = lo.replace(microsecond=0) + timedelta(seconds=round(lo.microsecond / 1e6))
    azimuth = sun_position(lat, lon, when)[0]
    relative = math.degrees(math.atan2(-direction[1], direction[0]))  # settings.direction_from_az_el's azimuth
    return lat, lon, when, (azimuth - relative) % 360.0


def test_a_hidden_sun_is_placed_from_the_photo_s_metadata_and_a_visible_one_keeps_its_place(tmp_path):
    """Issue 46: a photo whose sun a building hides, with its GPS position, UTC time and heading: the sun stands
    where the metadata puts it (within 0.5 degrees of the truth: the solar position, not a guess), weighed by the
    clear sky with the sun fixed there; lighting.json says where the direction came from, and the note asks the
    artist to check it. --no-sun-metadata (sun_metadata False) leaves the photo's own estimate; a photo showing its
    sun in a compact patch keeps its own sun over a metadata heading 20 degrees off."""
    from datetime import datetime, timezone

    from panolight_core import metrics
    from panolight_core.estimators.keylight import key_light_note
    from tests.panolight_core.estimators.test_keylight import _clear_sky_with_pole, _retouched_sky
    from tests.panolight_core.io.test_capture import write_photo

    ldr, s, _ = _retouched_sky(paint=0.02)
    lat, lon, when, heading = _capture_for(s)
    photo = write_photo(tmp_path / "hidden.jpg", ldr, gps=(lat, lon), gps_time=when, heading=round(heading, 4))
    doc = run_estimate(photo, tmp_path / "out", outputs=("lighting",))
    said = doc["estimator"]["pointed_sun"]
    assert said["from"].startswith("the photo's metadata (GPS 48.8584 N 2.2945 E, 2024-06-21")
    key = max(doc["lights"], key=lambda light: light["intensity"])
    assert metrics.angle_deg(key["direction"], s) < 0.5 and key["source"].startswith("the artist's direction")
    assert key_light_note(doc).startswith("the sun was placed from the photo's metadata")
    plain = run_estimate(photo, tmp_path / "plain", Settings(sun_metadata=False), outputs=("lighting",))
    assert "pointed_sun" not in plain["estimator"] and "sun_metadata" not in plain["estimator"]
    night = datetime(2024, 6, 21, 22, 30, tzinfo=timezone.utc)  # the sun below Paris's horizon: nothing added
    photo = write_photo(tmp_path / "night.jpg", ldr, gps=(lat, lon), gps_time=night, heading=round(heading, 4))
    doc = run_estimate(photo, tmp_path / "night", outputs=("lighting",))
    assert "pointed_sun" not in doc["estimator"] and doc["estimator"]["sun_metadata"]["used"] is False
    assert doc["estimator"]["sun_metadata"]["why"] == "no clear sky weighs a sun there: it is below the horizon"
    assert [light.get("source") for light in doc["lights"]] == [light.get("source") for light in plain["lights"]]
    np.testing.assert_allclose([light["intensity"] for light in doc["lights"]],
                               [light["intensity"] for light in plain["lights"]], rtol=1e-12)  # two runs: last bits

    ldr, s = _clear_sky_with_pole(pole_deg=0.0)
    lat, lon, when, heading = _capture_for(s)
    photo = write_photo(tmp_path / "shown.jpg", ldr, gps=(lat, lon), gps_time=when, heading=round(heading + 20.0, 4))
    doc = run_estimate(photo, tmp_path / "shown", outputs=("lighting",))
    assert "pointed_sun" not in doc["estimator"]
    assert doc["estimator"]["sun_metadata"]["used"] is False
    assert doc["estimator"]["sun_metadata"]["why"].startswith("the photo shows its sun")
    key = max(doc["lights"], key=lambda light: light["intensity"])
    assert metrics.angle_deg(key["direction"], s) < 2.0
