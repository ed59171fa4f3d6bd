"""training.neural.cv: a run that held a fold out is scored on exactly those scenes."""
import json

import numpy as np
import pytest

from panolight_core.errors import PanoLightError
from panolight_core.io import write_image
from panolight_core.synthetic import environment
from training.neural import cv as neural_cv
from training.neural import train as T


def test_a_held_out_run_is_scored_on_its_scenes_beside_naive(tmp_path):
    from training.neural.models import load_config

    folder = tmp_path / "real"
    folder.mkdir()
    for i in range(10):
        write_image(folder / f"scene{i}.exr", environment(300 + i, 32)[0].astype(np.float32))
    cfg = {**load_config("small"), "input_height": 16, "ae_widths": [8, 8], "encoder_widths": [8] * 7, "hidden": 16}
    run = tmp_path / "run"
    T.train(cfg, None, run, epochs=2, ae_epochs=1, batch_size=2, procedural=4, val_procedural=0,
            cache=tmp_path / "cache", hdr=folder, hdr_copies=2, hold_out=(3, 5), log=lambda m: None)
    held = json.loads((run / "held_out.json").read_text())
    assert held["scenes"] == T.held_out_scenes(folder, (3, 5)) and held["fold"] == [3, 5]
    out = tmp_path / "cv.json"
    assert neural_cv.main(["--weights", f"mine={run / 'model.safetensors'}", "--cv", str(tmp_path / "none.json"),
                           "--out", str(out)]) == 0
    rows = json.loads(out.read_text())["rows"]
    assert {r["scene"] for r in rows} == set(held["scenes"])
    assert sorted({(r["estimator"], r["ev"]) for r in rows}) == sorted(
        (e, ev) for e in ("mine", "naive") for ev in (-2.0, 0.0, 2.0))
    assert all(np.isfinite(r["m_rmse"]) and r["m_rmse"] >= 0 for r in rows)
    merged = tmp_path / "merged.json"
    assert neural_cv.main(["--merge", str(out), "--cv", str(tmp_path / "none.json"), "--out", str(merged)]) == 0
    assert json.loads(merged.read_text())["rows"] == rows
    # the same file twice adds nothing (identical scores); a run scored differently is refused
    assert neural_cv.main(["--merge", str(out), str(out), "--cv", str(tmp_path / "none.json"), "--out",
                           str(merged)]) == 0
    assert json.loads(merged.read_text())["rows"] == rows
    other = json.loads(out.read_text())
    other["rows"][0]["m_rmse"] += 0.5
    (tmp_path / "other.json").write_text(json.dumps(other))
    with pytest.raises(PanoLightError, match="already scored differently"):
        neural_cv.main(["--merge", str(out), str(tmp_path / "other.json"), "--out", str(merged)])
    with pytest.raises(PanoLightError, match="no held_out.json"):
        neural_cv.main(["--weights", "x=panolight_core/models/small.safetensors", "--out", str(out)])
