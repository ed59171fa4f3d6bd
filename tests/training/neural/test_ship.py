"""training.neural.ship: the model card says what the network is, and nothing that does not ship is referenced."""
import json

import pytest

from panolight_core.errors import PanoLightError
from training.neural import ship as S


def _run(tmp_path, folder="run", **cfg):
    run = tmp_path / folder
    run.mkdir()
    (run / "config.json").write_text(json.dumps({"name": "x", "input_height": 128, "lmax": 2, **cfg}))
    (run / "metrics.csv").write_text("epoch,stage,train_loss,val_loss,val_m_rmse,val_irr_rmse,seconds\n"
                                     "1,ae,1.2,0.8,0.77,0.43,270\n")
    (run / "model.safetensors").write_bytes(b"weights")
    return run


def test_the_card_names_the_guess_and_the_real_data(tmp_path):
    text = S.card(_run(tmp_path, guess="sources"), "small", real_data="45 real HDRs.", extra="## CV\n\nrows")
    assert "per-source energy model's recovered excess" in text and "45 real HDRs." in text
    assert "Trained on synthetic scenes only" not in text and "## CV" in text and "128 x 256" in text
    plain = S.card(_run(tmp_path, "plain", guess="analytic"), "small")
    assert "physical highlight model's guess" in plain and "Trained on synthetic scenes only" in plain


def test_a_network_correcting_an_unshipped_source_model_is_refused(tmp_path, monkeypatch):
    monkeypatch.setattr(S, "MODELS", tmp_path / "models")
    run = _run(tmp_path, guess="sources", source_model="/somewhere/runs/f1/sources.safetensors")
    with pytest.raises(PanoLightError, match="does not ship"):
        S.ship(run, "small")
    assert not (tmp_path / "models" / "small.safetensors").exists()
