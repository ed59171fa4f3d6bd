"""The paper's ablation as configurations: eight variants that differ only in the lighting stage."""
import pytest

from panolight_core.errors import PanoLightError
from training.neural import ablation
from training.neural.models import load_config


def test_the_eight_variants_are_the_papers_grid():
    names = ablation.names()
    assert len(names) == 8 == len(set(names))
    small = load_config("small")
    for name in names:
        cfg = load_config(f"ablation/{name}")
        variant, prior = name.rsplit("-", 1)
        assert cfg["prior"] is (prior == "prior")
        w = cfg["loss_weights"]
        assert {"full": w == {"sh": 0.01, "rc": 0.3, "rl": 0.7}, "only-photo": w["rl"] > 0 == w["sh"] == w["rc"],
                "no-photo": w["rl"] == 0 < w["sh"] and w["rc"] > 0, "only-dense": w["rc"] > 0 == w["sh"] == w["rl"]}[variant]
        # everything else is the shipped small network, so one trained autoencoder serves them all
        assert {k: v for k, v in cfg.items() if k not in ("name", "prior", "loss_weights")} == \
            {k: v for k, v in small.items() if k not in ("name", "prior", "loss_weights")}


def test_table_puts_the_papers_numbers_beside_ours():
    rows = [{"variant": n, "val_m_rmse": 1.0, "val_irr_rmse": 0.5} for n in ablation.names()]
    table = ablation.markdown(rows)
    assert table.count("\n") == 2 + 8 and "0.0101" in table and "0.0423" in table


def test_unknown_config_names_the_known_ones():
    with pytest.raises(PanoLightError, match="ablation/full-prior"):
        load_config("ablation/fast")
