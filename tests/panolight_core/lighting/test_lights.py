import math
import tracemalloc

import numpy as np
import pytest

from panolight_core import metrics, sh
from panolight_core.camera.color import LUMINANCE_WEIGHTS
from panolight_core.estimators.keylight import key_light_note, key_light_range
from panolight_core.lighting.lights import extract_lights, light_irradiance, sun_lamp


def _map(h=128, bg=0.1):
    return np.full((h, 2 * h, 3), bg)


def test_single_1e6_pixel_becomes_one_sun_with_its_energy():
    img = _map()
    img[40, 77] = 1e6
    lights, residual, info = extract_lights(img)
    assert len(lights) == 1 and lights[0]["type"] == "sun"
    assert metrics.angle_deg(lights[0]["direction"], sh.pixel_directions(128, 256)[40, 77]) < 0.01
    pixel_energy = (1e6 - 0.1) * sh.pixel_solid_angles(128, 256)[40, 77]
    assert lights[0]["intensity"] == pytest.approx(pixel_energy, rel=1e-9)
    np.testing.assert_allclose(residual, 0.1, rtol=1e-12)
    assert np.all(np.isfinite(residual)) and info["energy_fraction_in_lights"] > 0.99


def test_energy_is_conserved(rng):
    img = rng.random((128, 256, 3)) + _map()
    img[30:33, 100:103] = [500.0, 400.0, 300.0]
    lights, residual, _ = extract_lights(img)
    omega = sh.pixel_solid_angles(128, 256)[..., None]
    light_rgb = sum(np.array(l["color"]) * l["intensity"] for l in lights)
    np.testing.assert_allclose((residual * omega).sum((0, 1)) + light_rgb, (img * omega).sum((0, 1)), rtol=1e-12)
    assert abs(np.array(lights[0]["color"]) @ LUMINANCE_WEIGHTS - 1) < 1e-12


def test_sun_at_the_zenith_and_on_the_seam():
    zen = _map()
    zen[0, :] = 2000.0  # the whole top row: a disk around +Z
    lights, _, _ = extract_lights(zen)
    assert len(lights) == 1 and metrics.angle_deg(lights[0]["direction"], [0, 0, 1]) < 0.1
    seam = _map()
    seam[60:68, -3:] = seam[60:68, :3] = 3000.0  # straddles u = 0 (the -X direction)
    lights, _, _ = extract_lights(seam)
    assert len(lights) == 1, "a sun across the seam must stay one light"
    assert metrics.angle_deg(lights[0]["direction"], [-1, 0, 0]) < 1.0


def test_two_suns_of_equal_power():
    img = _map()
    img[40, 60] = img[80, 190] = 5e4
    lights, _, _ = extract_lights(img)
    assert len(lights) == 2
    assert lights[0]["intensity"] == pytest.approx(lights[1]["intensity"], rel=0.2)
    dirs = sh.pixel_directions(128, 256)
    found = sorted(min(metrics.angle_deg(l["direction"], dirs[p]) for p in ((40, 60), (80, 190))) for l in lights)
    assert found[-1] < 0.5


def test_black_and_flat_maps_have_no_light_and_say_why():
    lights, residual, info = extract_lights(np.zeros((64, 128, 3)))
    assert lights == [] and "black" in info["reason"] and np.all(residual == 0)
    lights, _, info = extract_lights(np.ones((64, 128, 3)))
    assert lights == [] and "brighter than 50" in info["reason"]
    flat = _map(64)
    flat[10:40, :] = 20.0  # a huge bright band: not a compact source
    lights, _, info = extract_lights(flat)
    assert lights == [] and "flat" in info["reason"]
    with pytest.raises(ValueError, match="NaN"):
        extract_lights(np.full((8, 16, 3), np.nan))


def test_weak_regions_are_passed_over_with_the_lights_and_residual_of_weighing_them(rng, monkeypatch):
    """A region whose own energy cannot make a light is not weighed (its threshold search skipped): the lights
    and residual are bitwise those of weighing every region, and the reason counts the regions passed over."""
    from panolight_core.lighting import lights as module

    img = _map() + 0.01 * rng.random((128, 256, 3))
    img[40:42, 60:62] = 2e4  # a compact source: a light
    img[70:100, 150:200] = 30.0  # a wide flat bright wall: weighed, and refused as flat
    for k in range(4):  # strips over 10 degrees wide with a peak, each far below a light's share
        img[20 + 25 * k:22 + 25 * k, 100:190] = 5.5
        img[20 + 25 * k, 140] = 20.0
    calls = []
    real = module.component_at
    monkeypatch.setattr(module, "component_at", lambda *a: calls.append(1) or real(*a))
    fast = extract_lights(img, max_lights=2)
    n_fast = len(calls)
    monkeypatch.setattr(module, "_energy_bound", lambda energy, cells: math.inf)  # weigh every region
    slow = extract_lights(img, max_lights=2)
    assert len(calls) - n_fast > n_fast, "passing over the strips must save their threshold searches"
    assert len(fast[0]) == 1 and fast[0] == slow[0] and np.array_equal(fast[1], slow[1])
    assert fast[2]["energy_fraction_in_lights"] == slow[2]["energy_fraction_in_lights"]
    monkeypatch.undo()
    glints = _map()
    glints[30, 7::40] = 12.0  # 7 glints of 1.5 % each: together over a light's 5 %, each alone far under
    lights, _, info = extract_lights(glints)
    assert lights == [] and info["reason"] == ("4 bright regions add at most 1.5% each; the other bright pixels add "
                                               "at most 4.6% together (a light needs 5%)")


def test_light_irradiance_is_the_clamped_cosine():
    light = {"direction": [0, 0, 1.0], "color": [1.0, 0.5, 0.25], "intensity": 2.0}
    n = np.array([[0, 0, 1.0], [1.0, 0, 0], [0, 0, -1.0], [0, math.sqrt(0.5), math.sqrt(0.5)]])
    np.testing.assert_allclose(light_irradiance([light], n)[:, 0], [2.0, 0.0, 0.0, 2.0 * math.sqrt(0.5)])
    np.testing.assert_allclose(light_irradiance([light], n)[0], [2.0, 1.0, 0.5])


def test_large_panorama_is_processed_in_bounded_memory():
    img = np.full((2048, 4096, 3), 0.2, np.float32)  # 100 MB
    img[500:504, 1000:1004] = 1e5
    tracemalloc.start()
    lights, _, _ = extract_lights(img)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert len(lights) == 1 and peak < 40 * 2 ** 20, f"{peak / 2 ** 20:.0f} MB"


@pytest.mark.parametrize("rotation", [0.0, 0.7, -2.5])
def test_a_sun_lamp_turns_with_the_lighting_and_keeps_the_lights_energy(rotation):
    light = {"direction": [0.3, -0.5, 0.81], "color": [1.6, 0.8, 0.2], "intensity": 2.5, "angle": 0.01}
    lamp = sun_lamp(light, strength=1.5, rotation=rotation)
    c, s = math.cos(rotation), math.sin(rotation)
    mapping = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])  # a Mapping node's Z rotation
    d = np.array(light["direction"]) / np.linalg.norm(light["direction"])
    np.testing.assert_allclose(mapping @ lamp["direction"], d, atol=1e-12)  # the texture lookup lands on the light
    assert lamp["color"].max() == 1.0 and lamp["angle"] == 0.01
    np.testing.assert_allclose(lamp["energy"] * lamp["color"], 1.5 * 2.5 * np.array(light["color"]), rtol=1e-12)


def test_the_key_light_range_is_the_brightest_key_lights_68_percent_over_its_strength():
    sun = {"type": "sun", "direction": [0.0, 0.6, 0.8], "intensity": 0.5, "source": "clear-sky fit (turbidity 6.5)",
           "energy_68": [1.2, 4.8]}
    lamp = {"type": "area", "direction": [1.0, 0.0, 0.0], "intensity": 0.3, "source": "per-source model",
            "energy_68": [0.2, 0.9]}
    adaptive = {"type": "area", "direction": [0.0, 0.0, 1.0], "intensity": 9.0}  # no source: no key light
    key = key_light_range({"lights": [adaptive, lamp, sun]})
    assert key["index"] == 2 and key["source"].startswith("clear-sky")
    assert key["low"] == pytest.approx(2.4) and key["high"] == pytest.approx(9.6)
    assert key["elevation_deg"] == pytest.approx(math.degrees(math.asin(0.8)))
    assert key_light_range({"lights": [adaptive]}) is None and key_light_range({}) is None
    assert key_light_range({"lights": [dict(sun, intensity=0.0)]}) is None  # nothing to scale


def test_the_key_light_note_says_what_an_artist_should_know():
    """A sun placed from the sky (where, how sure), no key light at all (why the sky search found none either), a
    key light given less than its evidence (its 68 % range and what raises it), and nothing otherwise."""
    hidden = {"estimator": {"sun_search": {"searched": True, "hidden_sun": True, "refused": [], "elevation_deg": 23.75,
                                           "direction_68_deg": 27.2}}, "lights": []}
    assert key_light_note(hidden) == ("the photo shows no sun, so one was placed where its clear sky puts it (24 deg "
                                      "up, within 27 deg for 68 %): check its light against the photo's shadows")
    assert "check its lamp" in key_light_note(hidden, light="lamp")
    why = "no position stands out (best score 0.68 of the median's > 0.65)"
    overcast = {"estimator": {"sun_search": {"searched": True, "hidden_sun": False, "refused": [why]}},
                "lights": [{"type": "area", "intensity": 1.0}]}  # the adaptive model's light is no key light
    note = key_light_note(overcast)
    assert note.startswith("no sun or lamp was weighed as a key light, and no sun was placed from the sky (")
    assert why in note
    assert "the 1 explicit light(s) are the brightest spots" in note
    assert "nothing will cast a hard shadow" in key_light_note(dict(overcast, lights=[]))
    # a sun the sky places well but too near the horizon to weigh: the note says where to put it by hand
    low = {"estimator": {"sun_search": {"searched": True, "hidden_sun": False,
                                        "refused": ["at the horizon (3.8 deg < 5.0)"],
                                        "direction": [0.997859, 0.0, 0.065403], "elevation_deg": 3.75,
                                        "direction_68_deg": 13.73}}, "lights": []}
    assert key_light_note(low).endswith("add a sun light by hand toward (1.00, 0.00, 0.07), where the sky puts it "
                                        "(4 deg up, within 14 deg for 68 %)")
    hazy = {"estimator": {"sun_search": dict(low["estimator"]["sun_search"], refused=[
        "at the horizon (3.8 deg < 5.0)", "the sky is not clear (residual 0.44 > 0.35)"])}, "lights": []}
    assert key_light_note(hazy).endswith("add a sun light by hand")  # a position the sky does not vouch for
    lamp = {"type": "area", "direction": [0.0, 0.0, 1.0], "intensity": 2.0, "source": "per-source model"}
    assert key_light_note(dict(overcast, lights=[lamp])) == ""  # a lamp from the photo's clipped region
    assert key_light_note({"estimator": {"sun_search": {"searched": False, "why": "a clipped region holds a "
                                                                           "clear-sky sun"}}}) == ""
    assert key_light_note({}) == ""
    capped = {"lights": [{"type": "sun", "direction": [0.74, 0.67, 0.09], "intensity": 0.49,
                          "source": "clear-sky fit (turbidity 8)", "energy_68": [1.19, 4.76]}]}
    note = key_light_note(capped, raise_with="Sun lamp strength")
    assert note.startswith("the key light (5 deg up) has the strength the estimate is sure of")
    assert "2.4-9.7x that (68 %; under 10 deg the sky fit is unreliable" in note and "12x too strong" in note
    assert note.endswith("raise Sun lamp strength toward that (a sun strength of 2.4 reaches its low end)")
    assert "raise --sun-strength" in key_light_note(capped)  # the CLI's own setting by default
    # after --sun-strength 1.5 the range is over the raised light, and the advice still names the absolute setting
    raised = {"sun_strength": 1.5, "lights": [dict(capped["lights"][0], intensity=0.49 * 1.5)]}
    note = key_light_note(raised)
    assert note.startswith("the key light (5 deg up) has 1.5x the strength the estimate is sure of")
    assert "1.6-6.5x that (68 %;" in note and note.endswith("(a sun strength of 2.4 reaches its low end)")
    high = {"lights": [dict(capped["lights"][0], direction=[0.6, 0.0, 0.8])]}  # 53 deg up: checked there
    assert "2.4-9.7x that (68 %). If" in key_light_note(high)
    assert key_light_note({"lights": [dict(capped["lights"][0], intensity=2.38)]}) == ""  # given its evidence
    assert key_light_note({"lights": [dict(capped["lights"][0], intensity=1.19 / 1.2)]}) == ""  # under KEPT_BELOW


def test_the_note_of_a_restored_hdr_says_where_its_plateau_went_how_sure_and_how_to_undo_it():
    restoration = {"restored": True, "ceiling": [16.0, 16.0, 15.5], "plateau_pixels": 31}
    sun = {"type": "sun", "direction": [0.6, 0.0, 0.8], "intensity": 2.0, "source": "clear-sky fit (turbidity 6.5)",
           "energy_68": [1.0, 5.0]}
    doc = {"estimator": {"restoration": restoration}, "lights": [sun]}
    note = key_light_note(doc)
    assert note.startswith("the file clips its own source (31 pixel(s) at its ceiling, 16): restored as a sun light "
                           "53 deg up, its strength sure within 0.5-2.5x (68 %)")
    assert note.endswith("set --sun-strength (Blender: Sun lamp strength; or its intensity in lighting.json); "
                         "--restore none takes the file as it is")
    blender = key_light_note(doc, light="lamp", raise_with="Sun lamp strength", as_is="Restore a clipped sun unticked")
    assert "restored as a sun lamp" in blender and blender.endswith("set Sun lamp strength; Restore a clipped sun "
                                                                    "unticked takes the file as it is")
    no_key = key_light_note({"estimator": {"restoration": restoration}, "lights": []})
    assert "its energy was restored into the map, with no key light; a patch that is no compact" in no_key
    assert no_key.endswith("can come out too bright (--restore none takes the file as it is)")
    merged = key_light_note(dict(doc, source={"dynamic_range": "hdr-merged-brackets"}))
    assert merged.startswith("the bracket set clips its source in every frame (31 pixel(s) at its ceiling, 16)")
    # what the set could not capture: a 0.53-degree sun of intensity 2 is 2 / 6.7e-5 sr over a ceiling of 16
    sun_disk = dict(sun, angle=math.radians(0.53), color=[1.0, 0.9, 0.8])
    held = key_light_note({"estimator": {"restoration": restoration}, "lights": [sun_disk],
                           "source": {"dynamic_range": "hdr-merged-brackets", "brackets": {"stops": [-2, 0, 2]}}})
    want = math.log2(2.0 / (2 * math.pi * (1 - math.cos(math.radians(0.53) / 2))) / 16.0)
    assert held.endswith(f". The source clips even the darkest frame (-2 stops): about {want:.0f} more stops, or an "
                         f"ND filter, would hold it") and round(want) == 11
    assert "darkest frame" not in key_light_note(dict(doc, lights=[sun_disk]))  # an HDR file has no frames
    assert key_light_note(dict(doc, source={"dynamic_range": "raw-linear"})).startswith("the sensor clips its source")
    # a range that starts under a tenth is printed as it is, never as 0.0x (a bracket set's weak evidence)
    wide = key_light_note(dict(doc, lights=[dict(sun, energy_68=[0.08, 9.0])]))
    assert "sure within 0.04-4.5x (68 %)" in wide
    # a set too bright to weigh what it clipped in every frame (a 0, +2 pair): no light, and the note says so
    pair = {"source": {"dynamic_range": "hdr-merged-brackets", "brackets": {"stops": [0.0, 2.0],
                                                                           "clipped_in_every_frame": 0.082}},
            "estimator": {}, "lights": []}
    assert key_light_note(pair).startswith("the bracket set clips 8.2 % of its pixels in every frame, its darkest "
                                           "(+0 stops) too, and too little above the scene")
    assert key_light_note(dict(pair, lights=[sun])) == "" and key_light_note(
        dict(pair, estimator={"restoration": dict(restoration, restored=False)})) == ""
    # the file as it is, or a plateau refused: nothing restored, no note
    assert key_light_note({"estimator": {"restoration": dict(restoration, restored=False)}, "lights": [sun]}) == ""
    # a key light kept below its evidence says that first
    kept = key_light_note({"estimator": {"restoration": restoration}, "lights": [dict(sun, intensity=0.5)]})
    assert kept.startswith("the key light (53 deg up) has the strength the estimate is sure of")
