"""training.keylight.copies: the camera JPEG, saved again and halved, scored against the truth at each one's size."""
import numpy as np

from panolight_core import metrics
from training.keylight import copies

from ...panolight_core.estimators.test_keylight import _lamps


def test_a_lamps_copies_keep_its_key_light_and_are_scored_against_the_truth_at_their_size():
    """A lamp in a dim room (512 x 1024): the JPEG as it is, saved again and halved (256 x 512) each get the lamp as
    their key light, on the source. Each r is measured against the truth area-averaged to the copy's size, whose
    cone holds the same energy, so r follows the light's intensity alike in all three copies."""
    hdr = _lamps([(0.2, 0.5, 0.8)], h=512, energy=6.0)
    ds = metrics.dominant_source(hdr)
    assert ds["dominant"]
    rows = copies.score_copies(hdr, ds, 0.0)
    assert [r["copy"] for r in rows] == ["as it is", "JPEG q90", "512 wide, q90"]
    for r in rows:
        assert r["key"] is not None and r["angle_deg"] < 3.0, r
    per_intensity = [r["ratio"] / r["key"]["intensity"] for r in rows]
    assert max(per_intensity) / min(per_intensity) < 1.1, per_intensity
    assert rows[0]["same"] and rows[1]["same"]
    summ = copies.summary([{"scene": "lamp", "ev": 0.0, "copies": rows}])
    assert set(summ["+0"]) == {"as it is", "JPEG q90", "512 wide, q90"}
    assert summ["+0"]["as it is"]["no_key_light"] == 0 and summ["+0"]["as it is"]["same_as_the_jpeg"] == 1
    assert np.isclose(summ["+0"]["JPEG q90"]["within"], 2 ** abs(np.log2(rows[1]["ratio"])))
    assert copies.table(summ)[2].startswith("| +0 | as it is | ")
