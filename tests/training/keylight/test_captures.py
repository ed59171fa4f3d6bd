"""training.keylight.captures: an HDR that clips its own sun, against one JPEG."""
import numpy as np
import pytest

from training.keylight import captures

from .test_hidden_sun import _sky_hdr, _write_hdr


def test_a_clipped_hdr_is_scored_as_it_is_and_restored(tmp_path):
    """A clear day with its sun (a 1-degree disk, as a lens blurs it): the JPEG and the HDR clipped at +2 and +6 stops, taken as it is (its exact projection: the more the file clips,
    the less of the sun it holds) and restored (its plateau weighed: nearer the truth); the summary has a row per
    capture, and draws."""
    from tests.panolight_core.estimators.sources.test_restore import _clear_day

    hdr, _, _ = _clear_day()
    rows = captures.scene_rows(_write_hdr(tmp_path, hdr), [2.0, 6.0])
    assert [r["capture"] for r in rows] == ["JPEG", "HDR clipped at +2 stops, as it is", "HDR clipped at +2 stops, "
                                            "restored", "HDR clipped at +6 stops, as it is",
                                            "HDR clipped at +6 stops, restored"]
    jpeg, low, low_restored, high, high_restored = rows
    assert low["ratio"] < high["ratio"] <= 1.0 + 1e-6 and low["contrast"] <= high["contrast"]
    assert low["m_rmse_over_own"] == pytest.approx(1.0, abs=0.02)
    # at 512 wide the JPEG clips no patch the work map holds, and only its sky suggests the sun: nothing is added
    # (issue 58), so it scores as naive
    assert jpeg["m_rmse_over_naive"] == pytest.approx(1.0, abs=1e-4)
    for as_is, restored in ((low, low_restored), (high, high_restored)):
        assert abs(np.log2(restored["ratio"])) < abs(np.log2(as_is["ratio"]))
        assert restored["m_rmse_over_own"] < 1.0
    summ = captures.summary(rows)
    assert set(summ) == {r["capture"] for r in rows} and all(s["scenes"] == 1 for s in summ.values())
    assert captures.table(summ)[2].startswith("| JPEG | 0 | 1 |")  # harmed first (EVALUATION.md), then scenes
    assert captures.plot(summ, tmp_path / "c.png").stat().st_size > 1000


def test_a_clipped_hdr_through_the_ldr_path_gets_back_its_sun(tmp_path):
    """--as-ldr: the file clipped at +2 stops made an 8-bit picture whose white is its ceiling, estimated as a
    photo and scaled back: the per-source recovery weighs the sun the plateau cut, which the file taken as it is
    lacks."""
    hdr, _ = _sky_hdr(with_sun=True)
    rows = {r["capture"]: r for r in captures.scene_rows(_write_hdr(tmp_path, hdr), [2.0], as_ldr=True)}
    raw, ldr = rows["HDR clipped at +2 stops, as it is"], rows["HDR clipped at +2 stops, as an 8-bit picture"]
    assert abs(np.log2(ldr["ratio"])) < abs(np.log2(raw["ratio"])) and ldr["m_rmse"] < raw["m_rmse"]


def test_a_camera_raw_is_scored_in_the_truth_s_units(tmp_path):
    """--raw 2: the truth as a noisy DNG whose white is 2 stops over the JPEG's, read through LibRaw: its sun clips
    at the sensor's white (1), the rest holds the truth / 4 (to the noise); restored, it scores as the HDR clipped at
    +2 stops does (both nearer the truth than that file as it is)."""
    from tests.panolight_core.estimators.sources.test_restore import _clear_day

    hdr, _, _ = _clear_day()
    px = captures.raw_capture(hdr, 2.0, seed=1)
    assert px.max() == 1.0 and ((px == 1.0).sum(axis=-1) >= 2).sum() >= 3  # a plateau (camera.ceiling)
    held = hdr.max(axis=-1) < 2.0
    assert np.median(4 * px[held] / hdr[held]) == pytest.approx(1.0, abs=0.01)  # the units, through the noise
    rows = {r["capture"]: r for r in captures.scene_rows(_write_hdr(tmp_path, hdr), [2.0], raws=[2.0])}
    raw, clipped = rows["RAW, white at +2 stops, restored"], rows["HDR clipped at +2 stops, restored"]
    as_is = rows["HDR clipped at +2 stops, as it is"]
    assert abs(np.log2(raw["ratio"])) < abs(np.log2(as_is["ratio"])) and raw["angle_deg"] < 2.0
    assert raw["m_rmse"] < as_is["m_rmse"] and raw["m_rmse"] < 1.5 * clipped["m_rmse"]


def test_a_file_that_lost_its_ties_is_found_by_the_click(tmp_path):
    """--pointed 4: the clear day clipped at +4 stops, its plateau's ties broken (camera.ceiling finds nothing), taken
    as it is and with the artist's click a degree off the sun: the click restores it (the sun's energy and shadow
    nearer the truth), and the click lands CLICK_DEG from the truth."""
    from panolight_core import metrics
    from panolight_core.camera.ceiling import find_ceiling
    from tests.panolight_core.estimators.sources.test_restore import _clear_day

    hdr, s, _ = _clear_day()
    assert find_ceiling(captures.untied(np.minimum(hdr, 16.0), seed=1)) is None
    assert metrics.angle_deg(captures.clicked(s, seed=1), s) == pytest.approx(captures.CLICK_DEG, abs=1e-9)
    rows = {r["capture"]: r for r in captures.scene_rows(_write_hdr(tmp_path, hdr), [4.0], pointed=[4.0])}
    as_is, click = rows["HDR clipped at +4 stops, ties lost, as it is"], rows["HDR clipped at +4 stops, ties lost, " 
                                                                                "the sun clicked"]
    assert "refused" not in click and click["angle_deg"] == pytest.approx(captures.CLICK_DEG, abs=0.2)
    assert abs(np.log2(click["ratio"])) < abs(np.log2(as_is["ratio"])) and click["contrast"] > as_is["contrast"]
    assert click["m_rmse"] < as_is["m_rmse"]


def test_public_scores_the_bpy_package_s_hdris_by_the_shipped_models_and_refuses_fold_models(tmp_path, capsys):
    """--public: the eight HDRIs the bpy package ships, never trained or tuned on, by the shipped models (their
    folds would be no better: none saw them); only the scenes with a dominant source make rows."""
    import json

    from panolight_core.data import STUDIO_HDRIS

    out = tmp_path / "public.json"
    assert captures.main(["--public", "--stops", "4", "--brackets=", "--out", str(out)]) == 0
    got = json.loads(out.read_text())
    assert got["scenes"] == "public" and {r["scene"] for r in got["rows"]} <= set(STUDIO_HDRIS)
    assert {"city", "sunrise"} <= {r["scene"] for r in got["rows"]}
    restored = {r["scene"]: r for r in got["rows"] if r["capture"] == "HDR clipped at +4 stops, restored"}
    assert restored["city"]["angle_deg"] < 1.0  # its sun restored where it is
    with pytest.raises(SystemExit):
        captures.main(["--public", "--fold-models", "runs/x_{k}.safetensors"])
    assert "drop --fold-models" in capsys.readouterr().err
