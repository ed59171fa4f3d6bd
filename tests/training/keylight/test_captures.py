"""training.keylight.captures: an HDR that clips its own sun, against one JPEG."""
import numpy as np
import pytest

from training.keylight import captures

from .test_hidden_sun import _sky_hdr, _write_hdr


def test_a_clipped_hdr_is_scored_as_today_s_estimate_takes_it(tmp_path):
    """A clear sky with its sun: the JPEG (whose clipped sun the key light weighs) and the HDR clipped at +2 and
    +6 stops (taken as it is: its exact projection). The more the file clips, the less of the sun it holds; its
    estimate is its own projection; the summary has a row per capture."""
    hdr, _ = _sky_hdr(with_sun=True)
    rows = captures.scene_rows(_write_hdr(tmp_path, hdr), [2.0, 6.0])
    assert [r["capture"] for r in rows] == ["JPEG", "HDR clipped at +2 stops", "HDR clipped at +6 stops"]
    jpeg, low, high = rows
    assert low["ratio"] < high["ratio"] <= 1.0 + 1e-6 and low["contrast"] <= high["contrast"]
    assert low["m_rmse_over_own"] == pytest.approx(1.0, abs=0.02) and jpeg["m_rmse_over_naive"] < 1.0
    summ = captures.summary(rows)
    assert set(summ) == {r["capture"] for r in rows} and all(s["scenes"] == 1 for s in summ.values())
    assert captures.table(summ)[2].startswith("| JPEG | 1 |")


def test_a_clipped_hdr_through_the_ldr_path_gets_back_its_sun(tmp_path):
    """--as-ldr: the file clipped at +2 stops made an 8-bit picture whose white is its ceiling, estimated as a
    photo and scaled back: the per-source recovery weighs the sun the plateau cut, which the file taken as it is
    lacks."""
    hdr, _ = _sky_hdr(with_sun=True)
    rows = {r["capture"]: r for r in captures.scene_rows(_write_hdr(tmp_path, hdr), [2.0], as_ldr=True)}
    raw, ldr = rows["HDR clipped at +2 stops"], rows["HDR clipped at +2 stops, as an 8-bit picture"]
    assert abs(np.log2(ldr["ratio"])) < abs(np.log2(raw["ratio"])) and ldr["m_rmse"] < raw["m_rmse"]
