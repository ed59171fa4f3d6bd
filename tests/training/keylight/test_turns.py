"""training.keylight.turns: a turned photo keeps its key light, turned with it."""
import numpy as np

from panolight_core import metrics, sh
from panolight_core.camera import hdr_to_ldr
from training.keylight import turns

from ...panolight_core.estimators.test_keylight import _lamps


def test_a_direction_turned_back_is_where_the_unrolled_panorama_shows_it():
    d = sh.pixel_directions(64, 128)
    for shift in (0, 5, 32, 77):
        rolled = np.roll(d, shift, axis=1)  # what the rolled panorama's pixel shows, in the unrolled frame ...
        ours = sh.pixel_directions(64, 128)  # ... and where the rolled panorama's own frame says it looks
        back = np.stack([turns.turned_back(v, shift, 128) for v in ours[10, ::9]])
        np.testing.assert_allclose(back, rolled[10, ::9], atol=1e-12)


def test_a_lamp_keeps_its_key_light_at_every_turn_and_a_quarter_turn_exactly():
    """Two lamps in a dim room (h 128): the key light found at each turn, turned back, is the unturned one; a
    quarter turn (a whole number of work cells) gives it to the last digit."""
    ldr = hdr_to_ldr(_lamps([(0.2, 0.5, 0.8)], h=128), 0.0)
    rows = turns.turns_of(ldr, (0, 64, 13, 101))
    assert all(r["key"] is not None and r["same"] for r in rows)
    first, quarter = rows[0]["key"], rows[1]["key"]
    assert metrics.angle_deg(first["direction"], quarter["direction"]) < 1e-3
    assert abs(quarter["intensity"] / first["intensity"] - 1.0) < 1e-9
    lines = turns.table({"lamp.jpg": rows})
    assert lines[-1] == f"| lamp.jpg | per-source model, {first['intensity']:.3g} | 3 of 3 turns | 4 of 4 |"


def test_copies_of_a_photo_are_its_re_encoded_and_downsized_versions_each_judged_against_it():
    """A lamp in a dim room (512 x 1024): the photo as it is, saved again at JPEG q90 and downsized to 512 wide (a
    width larger than the photo is skipped; 512 is the narrowest the per-source trees were trained on: at 256 wide
    the lamp splits in two regions that the trees trained on all 111 scenes weigh under a key light's share); the
    lamp is a key light in each, where the photo shows it, and the table marks a copy whose light is not the
    photo's."""
    ldr = hdr_to_ldr(_lamps([(0.2, 0.5, 0.8)], h=512, energy=6.0), 0.0)
    rows = turns.copies_of(ldr, widths=(2048, 512))
    assert [r["copy"] for r in rows] == ["as it is", "JPEG q90", "512 wide, q90"]
    lamp = np.array([0.2, 0.5, 0.8]) / np.linalg.norm([0.2, 0.5, 0.8])
    for r in rows:
        assert r["key"] is not None and metrics.angle_deg(r["key"]["direction"], lamp) < 3.0, r
    assert rows[1]["same"]
    rows[2]["same"] = False  # as if the small copy had lost it
    line = turns.copies_table({"lamp.jpg": rows})[-1]
    assert line.startswith("| lamp.jpg | per-source model, ") and line.endswith(" (another) |")
    assert line.count("(another)") == 1
