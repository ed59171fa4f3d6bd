import csv
import os
import subprocess
import sys

import numpy as np
import pytest
import torch

from panolight_core.estimators.nn.model import forward
from panolight_core.io.safetensors_np import load_safetensors
from training.neural import train as T


@pytest.fixture
def data(tiny_synth):
    return tiny_synth


def _cfg():
    from training.neural.models import load_config

    return {**load_config("small"), "input_height": 16, "ae_widths": [8, 8], "encoder_widths": [8] * 7,
            "hidden": 16}


def test_two_stage_training_logs_checkpoints_resumes_and_exports(data, tmp_path):
    out = tmp_path / "run"
    kw = dict(ae_epochs=1, batch_size=2, procedural=6, val_procedural=2, cache=tmp_path / "cache")
    first = []
    res = T.train(_cfg(), data, out, epochs=2, log=first.append, **kw)
    assert any("epoch 2: best validation m-RMSE so far, exported" in m for m in first)  # early stopping
    rows = list(csv.DictReader(open(out / "metrics.csv")))
    assert [r["stage"] for r in rows] == ["ae", "lighting"]
    assert all(np.isfinite(float(r["train_loss"])) and np.isfinite(float(r["val_m_rmse"])) for r in rows)
    state = torch.load(out / "checkpoint.pt", weights_only=True)  # no pickle of arbitrary objects
    assert state["epoch"] == 1
    said = []
    T.train(_cfg(), data, out, epochs=3, log=said.append, **kw)
    assert any("resuming" in s and "epoch 2" in s for s in said)
    assert len(list(csv.DictReader(open(out / "metrics.csv")))) == 3
    weights, meta = load_safetensors(res["weights"])
    net = T.LightingNet(_cfg())
    net.load_state_dict({k: torch.from_numpy(v) for k, v in weights.items()})
    x = torch.rand(1, 7, 16, 32)
    with torch.no_grad():
        ref, _ = net(x)
    np.testing.assert_allclose(forward(weights, _cfg(), x.numpy())[0], ref.numpy(), rtol=1e-4, atol=1e-4)


def test_data_parallel_under_torchrun(data, tmp_path):
    """Two CPU processes (gloo) train both stages data-parallel and write one set of outputs."""
    import json

    cfg = tmp_path / "cfg.json"
    cfg.write_text(json.dumps(_cfg()))
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    r = subprocess.run([sys.executable, "-m", "torch.distributed.run", "--nproc_per_node", "2", "-m", "training.neural.torchrun",
                        str(cfg), "--data", str(data), "--out", str(tmp_path / "ddp"), "--epochs", "2",
                        "--ae-epochs", "1", "--batch-size", "2", "--procedural", "4", "--val-procedural", "2"],
                       capture_output=True, text=True, timeout=600, env=env, cwd=os.getcwd())
    assert r.returncode == 0, r.stderr[-3000:]
    assert (tmp_path / "ddp" / "model.safetensors").is_file()
    assert len(list(csv.DictReader(open(tmp_path / "ddp" / "metrics.csv")))) == 2


def test_the_autoencoder_is_frozen_at_its_best_validation_epoch(data, tmp_path, monkeypatch):
    scores = iter([0.8, 0.5, 0.9])  # untrained, epoch 1, epoch 2: the first epoch is kept
    real = T.validate

    def validate(net, arr, stage, cfg, **kw):
        row = real(net, arr, stage, cfg, **kw)
        return {**row, "val_m_rmse": row["val_m_rmse"], "val_m_rmse_dense": next(scores)}

    monkeypatch.setattr(T, "validate", validate)
    out = tmp_path / "run"
    said = []
    T.train(_cfg(), data, out, epochs=2, ae_epochs=2, batch_size=2, procedural=6, val_procedural=2,
            cache=tmp_path / "cache", log=said.append)
    assert any("best epoch restored (validation m-RMSE 0.500)" in s for s in said)
    state = torch.load(out / "checkpoint.pt", weights_only=True)
    weights, _ = load_safetensors(out / "model.safetensors")
    last = {k[3:]: v for k, v in state["model"].items() if k.startswith("ae.")}
    kept = {k[3:]: v for k, v in weights.items() if k.startswith("ae.")}
    assert set(kept) == set(state["ae_best"]) and state["ae_best_score"] == 0.5
    assert all(np.array_equal(kept[k], state["ae_best"][k].numpy()) for k in kept)  # exported: the best epoch
    assert any(not np.array_equal(kept[k], last[k].numpy()) for k in kept)  # not the last one
    assert any("epoch 0: the autoencoder as it starts, val m-RMSE 0.800" in s for s in said)


def test_malformed_ae_from_weights_get_one_line_naming_the_file(tmp_path, capsys):
    """Issue 23: train --ae-from a malformed file failed with RecursionError / KeyError / a shape error."""
    from panolight_core.apps.cli import main
    from panolight_core.errors import PanoLightError
    from panolight_core.estimators.nn import estimator as E
    from tests.panolight_core.estimators.nn.test_estimator import _malformed_weights
    from training.neural.models import LightingNet

    cfg = E.load_model().config
    said = {"nested": "unreadable header", "missing": None, "nan": "'ae.dec.0.conv.weight' holds NaN or Inf",
            "swapped": "tensor 'ae.enc.1.conv.weight' has shape", "huge": None}
    for key, (path, _) in _malformed_weights(tmp_path).items():
        if said[key] is None:  # the autoencoder is intact (a missing encoder tensor, another input size)
            assert set(T.load_autoencoder(path, LightingNet(cfg))) == set(LightingNet(cfg).ae.state_dict())
            continue
        with pytest.raises(PanoLightError, match=said[key]):
            T.load_autoencoder(path, LightingNet(cfg))
        rc = main(["train", "small", "--ae-from", str(path), "--out", str(tmp_path / key), "-q"])
        err = capsys.readouterr().err
        assert rc == 1 and err.count("\n") == 1 and str(path) in err and said[key] in err, (key, err)
    nested, _ = _malformed_weights(tmp_path)["nested"]
    assert not (tmp_path / "nested" / "metrics.csv").exists()  # refused before any work
