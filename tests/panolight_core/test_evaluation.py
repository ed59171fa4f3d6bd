import json

from panolight_core import evaluation
from panolight_core.cli import main


def test_protocol_reproduces_baselines_and_writes_reports(tmp_path):
    result = evaluation.run(scenes=("city", "sunset"), evs=(0.0,), repeats=1)
    rows = {(r["scene"], r["estimator"]): r for r in result["rows"]}
    assert round(rows[("city", "naive")]["m_rmse"], 2) == 0.61
    assert round(rows[("sunset", "ambient")]["m_rmse"], 2) == 0.99
    assert rows[("city", "ambient")]["light_angle_deg"] is None
    assert rows[("city", "analytic")]["ms"] > 0
    paths = evaluation.write(result, tmp_path)
    md = (tmp_path / "eval.md").read_text()
    assert "| city |" in md and "## Summary" in md
    assert json.loads((tmp_path / "eval.json").read_text())["settings"]["evs"] == [0.0]
    assert (tmp_path / "speed_accuracy.png").stat().st_size > 1000 and len(paths) == 3


def test_eval_cli_subset(tmp_path, capsys):
    assert main(["eval", "-o", str(tmp_path), "--evs", "0", "--estimators", "naive", "--repeats", "1", "-q"]) == 0
    out = capsys.readouterr().out
    assert "| naive | +0 | 1.123 |" in out  # mean of the eight EVALUATION.md naive numbers


def test_eval_scores_trained_variants_by_label_and_names_bad_ones(tmp_path, capsys):
    from panolight_core.nn.estimator import DEFAULT_WEIGHTS

    assert main(["eval", "-o", str(tmp_path), "--evs", "0", "--estimators", "naive", "--repeats", "1", "-q",
                 "--no-adaptive", "--weights", f"mine={DEFAULT_WEIGHTS}"]) == 0
    out = capsys.readouterr().out
    assert out.count("| mine | +0 |") == 1 and "| naive | +0 | 1.123 |" in out
    assert main(["eval", "-o", str(tmp_path), "--weights", f"naive={DEFAULT_WEIGHTS}"]) == 1
    assert "built-in" in capsys.readouterr().err
    assert main(["eval", "-o", str(tmp_path), "--weights", "nolabel"]) == 1
    assert "LABEL=PATH" in capsys.readouterr().err
    assert main(["eval", "-o", str(tmp_path), "--weights", f"x={tmp_path / 'gone.safetensors'}"]) == 1
    assert "gone.safetensors: no model weights" in capsys.readouterr().err
