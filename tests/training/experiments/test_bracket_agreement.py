"""training.experiments.bracket_agreement: right sets pass the check, reversed and mixed-scene ones are refused."""

from panolight_core.camera.resample import area_downsample
from panolight_core.data import load_studio_hdri
from training.experiments import bracket_agreement


def test_right_pairs_pass_and_reversed_or_mixed_ones_are_refused():
    city = area_downsample(load_studio_hdri("city"), 256)
    forest = area_downsample(load_studio_hdri("forest"), 256)
    rows = bracket_agreement.scene_rows(city, forest, "city")
    by = {case: [r for r in rows if r["case"] == case] for case in {r["case"] for r in rows}}
    assert len(by["right"]) == 4 * 4 and len(by["another scene"]) == 4 * 2  # 4 pairs (2 for another) x 4 curves
    assert not any(map(bracket_agreement.refused, by["right"]))
    assert all(map(bracket_agreement.refused, by["reversed"]))
    assert sum(map(bracket_agreement.refused, by["another scene"])) >= 7  # the shoulder camera's -2/0 pair: 0.47
    assert not any(map(bracket_agreement.refused, by["steps halved"] + by["one stop off"]))  # not caught: the docstring
    assert all(map(bracket_agreement.refused, by["one exposure listed as two"]))  # a step the camera undid
    srgb = [r for r in by["steps halved"] if r["curve"] == "srgb"]
    assert all(abs(r["stops_off"] + 1.0) < 0.1 for r in srgb)  # a 1-stop set told 2 reads 1 stop short through sRGB
    kept = bracket_agreement.evidence(rows, bracket_agreement.summary(rows))
    passed = [(r["case"], r["curve"]) for r in kept["wrong_passed"]]
    assert passed == [("another scene", "shoulder 4")] and len(kept["right_least_alike"]) == 10
    assert kept["table"][2].startswith("| right | srgb | 4 | 0 (0) |")  # refused now (by the rank alone)


def test_a_set_with_one_frame_of_another_scene_leaves_out_that_frame():
    """--sets: the city's {-4 .. +4} set is kept whole as shot; with the forest's 0 EV frame amid it, that frame is
    left out (through the S-curve, where the forest's frame ranks too like its neighbours, the set is refused), and
    never is a right frame left out in its place."""
    city = area_downsample(load_studio_hdri("city"), 256)
    forest = area_downsample(load_studio_hdri("forest"), 256)
    rows = bracket_agreement.set_rows(city, forest, "city")
    assert len(rows) == 2 * 6 and all(r["outcome"] == "kept whole" for r in rows if r["wrong"] is None)
    mid = [r["outcome"] for r in rows if r["wrong"] == 2]  # through sRGB left out; through the S-curve refused
    assert mid == ["left out the wrong frame", "refused"]
    assert not any(r["outcome"] == "left out a right frame" for r in rows)
    assert bracket_agreement.set_summary(rows)[2].startswith("| as shot | 2 | 2 | 0 | 0 | 0 |")
