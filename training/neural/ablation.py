"""The paper's ablation (its Table 1) as runnable configurations: {full, only photo, no photo, only
dense} x {prior, no prior} (training/neural/configs/ablation/*.json).

The variants differ only in the lighting stage (loss weights, spectral prior), so they share one trained
autoencoder (``--ae``, a model.safetensors) and each trains its lighting encoder for the same budget.
Each is then scored on the held-out synthetic validation set and on the public set (ev 0, EVALUATION.md
protocol), and the table is written beside the paper's numbers (Laval test set; not comparable in value,
only in trend).

    python -m training.neural.ablation --ae runs/small/model.safetensors --data data/synth --cache data/cache \\
        --epochs 4 --out runs/ablation --table docs/ablation.md
"""
from __future__ import annotations

import argparse
import csv
import json
import sys
from pathlib import Path

from training.common.folds import parse_fold

VARIANTS = ("full", "only-photo", "no-photo", "only-dense")
PAPER = {("full", False): 0.0229, ("only-photo", False): 0.0297, ("no-photo", False): 0.0334,
         ("only-dense", False): 0.0423, ("full", True): 0.0101, ("only-photo", True): 0.0116,
         ("no-photo", True): 0.0156, ("only-dense", True): 0.0162}


def names() -> list[str]:
    return [f"{v}-{p}" for p in ("prior", "noprior") for v in VARIANTS]


def run(ae, out, *, data=None, cache=None, epochs: int = 4, procedural: int = 4000, val_procedural: int = 400,
        only=None, hdr=None, hdr_copies: int = 0, hold_out=None, log=print) -> list[dict]:
    """Train (or resume) every variant under ``out``; returns one row per variant with its validation
    scores (last epoch) and weights path. hdr, hdr_copies, hold_out: real HDR training data as ``train``
    takes it (the issue's real-lighting ablation: train with --hold-out, then score the variants on
    the held-out scenes with training.neural.cv)."""
    from training.neural.train import train

    rows = []
    for name in only or names():
        run_dir = Path(out) / name
        log(f"== {name}")
        train(f"ablation/{name}", data, run_dir, epochs=epochs, ae_epochs=0, procedural=procedural,
              val_procedural=val_procedural, cache=cache, ae_from=ae, hdr=hdr, hdr_copies=hdr_copies,
              hold_out=hold_out, log=log)
        last = list(csv.DictReader(open(run_dir / "metrics.csv")))[-1]
        rows.append({"variant": name, "weights": str(run_dir / "model.safetensors"),
                     **{k: float(last[k]) for k in ("val_m_rmse", "val_irr_rmse", "seconds")}})
    return rows


def score_public(rows: list[dict]) -> dict:
    """Add public-set means (ev 0) to each row; returns the evaluation result (rows for every variant)."""
    from panolight_core.apps import evaluation
    from panolight_core.estimators import register_model

    labels = [register_model(r["variant"], r["weights"]) for r in rows]
    result = evaluation.run(evs=(0.0,), estimators=["naive", "analytic", *labels], repeats=3)
    for r in rows:
        s = result["summary"][f"{r['variant']}@+0"]
        r["public_m_rmse"], r["public_irr_rmse"], r["median_ms"] = s["mean_m_rmse"], s["mean_irr_rmse"], s["median_ms"]
    return result


def markdown(rows: list[dict], result: dict | None = None) -> str:
    out = ["| variant | prior | validation m-RMSE (last epoch) | irr-RMSE | public set m-RMSE (ev 0) | irr-RMSE | "
           "paper (Laval, m-RMSE without /mean) |", "|---|---|---:|---:|---:|---:|---:|"]
    for r in rows:
        v, p = r["variant"].rsplit("-", 1)
        prior = p == "prior"
        pub = (f"{r['public_m_rmse']:.3f} | {r['public_irr_rmse']:.3f}" if "public_m_rmse" in r else "n/a | n/a")
        out.append(f"| {v} | {'yes' if prior else 'no'} | {r['val_m_rmse']:.3f} | {r['val_irr_rmse']:.3f} | {pub} | "
                   f"{PAPER[(v, prior)]:.4f} |")
    if result is not None:
        for base in ("naive", "analytic"):
            s = result["summary"][f"{base}@+0"]
            out.append(f"| *{base} baseline* | | | | {s['mean_m_rmse']:.3f} | {s['mean_irr_rmse']:.3f} | |")
    return "\n".join(out) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m training.neural.ablation", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ae", required=True, help="model.safetensors whose autoencoder every variant starts from")
    ap.add_argument("--out", required=True, help="folder of the variant runs")
    ap.add_argument("--data", default=None, help="synthetic dataset folder (panolight synth)")
    ap.add_argument("--cache", default=None, help="prepared-array cache folder")
    ap.add_argument("--epochs", type=int, default=4, help="lighting-stage epochs per variant (default 4)")
    ap.add_argument("--procedural", type=int, default=4000)
    ap.add_argument("--val-procedural", type=int, default=400)
    ap.add_argument("--hdr", default=None, metavar="DIR", help="real HDR panoramas added as training examples")
    ap.add_argument("--hdr-copies", type=int, default=0, metavar="N", help="augmented views of each (see train)")
    ap.add_argument("--hold-out", type=parse_fold, default=None, metavar="K/N",
                    help="leave fold K of N of the --hdr scenes out (score them with training.neural.cv)")
    ap.add_argument("--only", nargs="+", choices=names(), default=None, help="train only these variants")
    ap.add_argument("--table", default=None, help="write the markdown table (and .json beside it) here")
    ap.add_argument("--no-public", action="store_true", help="skip the public-set scores")
    args = ap.parse_args(argv)
    rows = run(args.ae, args.out, data=args.data, cache=args.cache, epochs=args.epochs, procedural=args.procedural,
               val_procedural=args.val_procedural, only=args.only, hdr=args.hdr, hdr_copies=args.hdr_copies,
               hold_out=args.hold_out, log=lambda m: print(m, file=sys.stderr, flush=True))
    result = None if args.no_public else score_public(rows)
    table = markdown(rows, result)
    print(table)
    if args.table:
        Path(args.table).parent.mkdir(parents=True, exist_ok=True)
        Path(args.table).write_text(table)
        Path(args.table).with_suffix(".json").write_text(json.dumps({"rows": rows, "epochs": args.epochs}, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
