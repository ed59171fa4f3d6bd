"""training.experiments.restore_harm: what restoring does to a clipped HDR file, on every scene."""
import numpy as np
import pytest

from training.experiments import restore_harm

from ..keylight.test_hidden_sun import _write_hdr


def test_a_clipped_sun_is_restored_nearer_the_truth_and_the_energies_add_up(tmp_path):
    """A clear day's sun clipped at +2 and +6 stops: restored both times, the whole model nearer the truth than the
    file as it is; the file lost more at +2; a copy clipped above its peak (+20 stops) loses nothing and is taken
    as it is."""
    from tests.panolight_core.estimators.sources.test_restore import _clear_day

    hdr, _, _ = _clear_day()
    row = restore_harm.scene_row(_write_hdr(tmp_path, hdr), stops=(2.0, 6.0, 20.0))
    assert row["dominant"] and row["share"] > 0.1
    low, high, none = row["+2"], row["+6"], row["+20"]
    assert low["restored"] and high["restored"] and not none["restored"]
    assert low["over_own"] < 1.0 and high["over_own"] < 1.0
    assert 0.0 < high["lost_share"] < low["lost_share"] < 1.0
    assert none["lost_share"] == 0.0 and none["added_over_lost"] is None and none["over_own"] is None  # exact: 0/0
    assert 0.1 < low["added_over_lost"] < 10.0


def test_the_energy_of_a_map_is_its_luminance_over_the_sphere():
    assert restore_harm.energy(np.full((64, 128, 3), 2.0)) == pytest.approx(8.0 * np.pi)


def test_the_summary_counts_the_restored_files_made_worse_and_splits_by_dominance():
    def cell(over, restored=True, added=1.0):
        return {"restored": restored, "own": 0.1, "over_own": over, "lost_share": 0.1, "added_over_lost": added}

    rows = [{"scene": "a", "dominant": True, "+4": cell(0.5, added=2.0)},
            {"scene": "b", "dominant": False, "+4": cell(4.0, added=8.0)},
            {"scene": "c", "dominant": False, "+4": cell(1.2)},
            {"scene": "d", "dominant": False, "+4": cell(1.0, restored=False, added=None)}]
    summ = restore_harm.summary(rows, [4.0])
    dom, rest = summ["+4 dominant"], summ["+4 no dominant source"]
    assert dom["scenes"] == 1 and dom["worse_1x"] == 0 and dom["added_median"] == pytest.approx(2.0)
    assert rest["scenes"] == 3 and rest["restored"] == 2 and rest["median_over_own"] == pytest.approx(1.2)
    assert (rest["worse_1x"], rest["worse_1.5x"], rest["worse_3x"], rest["worst"]) == (2, 1, 1, 4.0)
    assert rest["added_median"] == pytest.approx(4.5) and rest["added_within"] == pytest.approx(2.0 ** 1.5)
    # harm first (EVALUATION.md): b's 0.4 is over both 2x and + 0.25 its file's own 0.1; c's 0.12 is not
    assert (dom["harmed"], rest["harmed"]) == (0, 1)
    assert restore_harm.table(summ)[3].startswith("| +4 no dominant source | 1 | 3 | 2 | 1.200 | 2 | 1 | 1 | 4 |")


def test_the_decided_rule_weighs_a_plateau_s_key_light_otherwise_and_puts_the_shipped_rule_back(tmp_path):
    from panolight_core.estimators import keylight
    from tests.panolight_core.estimators.sources.test_restore import _clear_day

    path = _write_hdr(tmp_path, _clear_day()[0])
    shipped = keylight.with_key_lights
    belief = restore_harm.scene_row(path, stops=(4.0,))["+4"]
    with restore_harm.key_light_rule("decided"):
        assert keylight.with_key_lights is not shipped
        decided = restore_harm.scene_row(path, stops=(4.0,))["+4"]
    assert keylight.with_key_lights is shipped
    assert decided["restored"] and decided["added_over_lost"] != pytest.approx(belief["added_over_lost"], rel=1e-3)
    with pytest.raises(ValueError, match="unknown rule"):
        with restore_harm.key_light_rule("blinding"):
            pass


def test_the_stated_range_of_a_restored_sun_is_read_against_the_truth_and_counted(tmp_path):
    """--ranges: a clear day's restored sun states its 68 % range; the truth's factor is read beside it; the counts
    split inside / below / above."""
    from tests.panolight_core.estimators.sources.test_restore import _clear_day

    rows = restore_harm.range_rows(_write_hdr(tmp_path, _clear_day()[0]), stops=(4.0,))
    assert len(rows) == 1 and rows[0]["source"].startswith("clear-sky")
    assert rows[0]["low"] < 1.0 < rows[0]["high"] and rows[0]["truth_over_light"] > 0
    made = [dict(rows[0], truth_over_light=v) for v in (rows[0]["low"] / 2, 1.0, rows[0]["high"] * 2)]
    summ = restore_harm.range_summary(made + [dict(made[1], source="per-source model")])
    assert (summ["all"]["inside"], summ["all"]["below"], summ["all"]["above"]) == (2, 1, 1)
    assert summ["clear-sky sun"]["lights"] == 3 and summ["per-source light"]["inside"] == 1
    assert summ["all"]["median_width"] == pytest.approx(rows[0]["high"] / rows[0]["low"])


def test_keys_only_changes_nothing_where_the_one_plateau_is_the_sun(tmp_path):
    """A clear day's one plateau is its sun's key light: with no other region to leave as the file holds it, the
    keys-only rule restores as the shipped one does."""
    from tests.panolight_core.estimators.sources.test_restore import _clear_day

    path = _write_hdr(tmp_path, _clear_day()[0])
    belief = restore_harm.scene_row(path, stops=(4.0,))["+4"]
    with restore_harm.key_light_rule("keys-only"):
        kept = restore_harm.scene_row(path, stops=(4.0,))["+4"]
    assert kept["over_own"] == pytest.approx(belief["over_own"], rel=1e-6)
    assert kept["added_over_lost"] == pytest.approx(belief["added_over_lost"], rel=1e-6)


def test_keys_only_leaves_a_plateau_that_is_no_sun_as_the_file_holds_it(tmp_path):
    """The clear day with a small patch of ground just over the +4-stop ceiling (a sunlit white sign), too weak to
    make a key light: the shipped rule fills it as a clipped source, the keys-only rule keeps it as the file holds
    it and adds less."""
    from panolight_core import sh
    from panolight_core.camera import auto_exposure
    from tests.panolight_core.estimators.sources.test_restore import _clear_day

    hdr = _clear_day()[0].astype(np.float64)
    k = auto_exposure(hdr, 0.0)
    d = sh.pixel_directions(*hdr.shape[:2])
    wall = (d @ np.array([0.0, -0.94, -0.34])) > np.cos(np.radians(2.0))  # 2 deg round a point 20 deg down
    hdr[wall] = 1.1 * 16.0 / k  # 10 % over the ceiling of the file clipped at +4 stops
    path = _write_hdr(tmp_path, hdr.astype(np.float32))
    belief = restore_harm.scene_row(path, stops=(4.0,))["+4"]
    with restore_harm.key_light_rule("keys-only"):
        kept = restore_harm.scene_row(path, stops=(4.0,))["+4"]
    assert belief["restored"] and kept["restored"]
    assert kept["added_over_lost"] < belief["added_over_lost"]
