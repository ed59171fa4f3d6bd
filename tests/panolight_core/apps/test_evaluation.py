import json

from panolight_core.apps import eval_report, evaluation
from panolight_core.apps.cli import main


def test_protocol_reproduces_baselines_and_writes_reports(tmp_path):
    result = evaluation.run(scenes=("city", "sunset"), evs=(0.0,), repeats=1)
    rows = {(r["scene"], r["estimator"]): r for r in result["rows"]}
    assert round(rows[("city", "naive")]["m_rmse"], 2) == 0.61
    assert round(rows[("sunset", "ambient")]["m_rmse"], 2) == 0.99
    assert rows[("city", "ambient")]["light_angle_deg"] is None
    assert rows[("city", "analytic")]["ms"] > 0
    paths = eval_report.write(result, tmp_path)
    md = (tmp_path / "eval.md").read_text()
    assert "| city |" in md and "## Summary" in md
    assert json.loads((tmp_path / "eval.json").read_text())["settings"]["evs"] == [0.0]
    assert (tmp_path / "speed_accuracy.png").stat().st_size > 1000 and len(paths) == 3
    # EVALUATION.md's dominant source: city has one (its sun), sunset none; r on hdr.exr where there is one
    assert rows[("city", "sources")]["dominant"] and not rows[("sunset", "sources")]["dominant"]
    r = rows[("city", "keylight")]["energy_ratio"]
    assert 0 < r < 10 and rows[("city", "naive")]["energy_ratio"] is None  # naive writes no hdr.exr
    m = result["summary"]["keylight@+0"]
    assert m["dominant_scenes"] == 1 and abs(m["dominant_energy_within"] - 2 ** abs(__import__("math").log2(r))) < 1e-9
    assert "## The dominant source's energy" in md and "| city | +0 |" in md


def test_eval_cli_subset(tmp_path, capsys):
    assert main(["eval", "-o", str(tmp_path), "--evs", "0", "--estimators", "naive", "--repeats", "1", "-q"]) == 0
    out = capsys.readouterr().out
    assert "| naive | +0 | 0 | 1.123 |" in out  # mean of the eight EVALUATION.md naive numbers
    assert "m-RMSE's median scale flips on sunrise:" in out  # its truth's lmax-2 median is negative


def test_eval_scores_trained_variants_by_label_and_names_bad_ones(tmp_path, capsys):
    from panolight_core.estimators.nn.estimator import DEFAULT_WEIGHTS

    assert main(["eval", "-o", str(tmp_path), "--evs", "0", "--estimators", "naive", "--repeats", "1", "-q",
                 "--no-adaptive", "--weights", f"mine={DEFAULT_WEIGHTS}"]) == 0
    out = capsys.readouterr().out
    assert out.count("| mine | +0 |") == 2 and "| naive | +0 | 0 | 1.123 |" in out  # the summary and the three spheres
    assert "## Three spheres (the published tables' protocol)" in out
    assert main(["eval", "-o", str(tmp_path), "--weights", f"naive={DEFAULT_WEIGHTS}"]) == 1
    assert "built-in" in capsys.readouterr().err
    assert main(["eval", "-o", str(tmp_path), "--weights", "nolabel"]) == 1
    assert "LABEL=PATH" in capsys.readouterr().err
    assert main(["eval", "-o", str(tmp_path), "--weights", f"x={tmp_path / 'gone.safetensors'}"]) == 1
    assert "gone.safetensors: no model weights" in capsys.readouterr().err


def test_summary_has_medians_wins_and_the_hdri_score():
    result = evaluation.run(scenes=("city", "sunset", "interior"), evs=(0.0,), estimators=["naive", "sources"],
                            repeats=1)
    s = result["summary"]["sources@+0"]
    rows = [r for r in result["rows"] if r["estimator"] == "sources"]
    naive = {r["scene"]: r["m_rmse"] for r in result["rows"] if r["estimator"] == "naive"}
    assert s["median_m_rmse"] == sorted(r["m_rmse"] for r in rows)[1]
    assert s["wins_vs_naive"] == sum(r["m_rmse"] < naive[r["scene"]] for r in rows)
    for r in rows:  # hdr.exr agrees with the whole model it was made with
        assert abs(r["hdri_m_rmse"] - r["m_rmse"]) <= 0.02 * r["m_rmse"] + 0.01
    city = next(r for r in rows if r["scene"] == "city")
    assert 0.0 <= city["true_sun_share"] <= 1.0 and city["light_angle_deg"] is not None
    assert "| sources | +0 |" in eval_report.markdown(result)


def test_the_report_without_matplotlib_says_how_to_get_the_plot(tmp_path, monkeypatch):
    import builtins

    real = builtins.__import__

    def no_matplotlib(name, *args, **kwargs):
        if name.split(".")[0] == "matplotlib":
            raise ImportError("No module named 'matplotlib'")
        return real(name, *args, **kwargs)

    result = evaluation.run(scenes=("city",), evs=(0.0,), estimators=["naive"], repeats=1)
    monkeypatch.setattr(builtins, "__import__", no_matplotlib)
    paths = eval_report.write(result, tmp_path)
    assert [p.name for p in paths] == ["eval.md", "eval.json"] and not (tmp_path / "speed_accuracy.png").exists()
    assert "pip install -e '.[plot]'" in (tmp_path / "eval.md").read_text()
