"""Ship a trained run as the learned estimator's weights: copy model.safetensors into
panolight_core/models/NAME.safetensors and write its model card (NAME.md) from the run's files.

    python -m training.neural.ship runs/small --name small --eval docs/eval/eval.json --train-command "..."

The card holds what a user needs to trust the file: the data it saw (never the public set), the
config, the training time and curve, validation scores and, when given, the public-set evaluation.
"""
from __future__ import annotations

import argparse
import csv
import hashlib
import json
import shutil
from pathlib import Path

MODELS = Path(__file__).resolve().parents[2] / "panolight_core" / "models"


def card(run: Path, name: str, *, evaluation=None, train_command: str = "", data_note: str = "",
         baseline: str = "", real_data: str = "", extra: str = "") -> str:
    """The model card (markdown). real_data: a sentence on the real HDR panoramas it was trained on
    (empty: synthetic data only); extra: markdown appended before the limits (e.g. cross-validation)."""
    cfg = json.loads((run / "config.json").read_text())
    sources_guess = cfg.get("guess", "analytic") == "sources"
    rows = list(csv.DictReader(open(run / "metrics.csv")))
    weights = run / "model.safetensors"
    sha = hashlib.sha256(weights.read_bytes()).hexdigest()
    seconds = sum(float(r["seconds"]) for r in rows)
    out = [f"# PanoLight learned estimator: `{name}`", "",
           "The paper's two networks (Gkitsas et al. 2020): an LDR-to-HDR autoencoder, then a lighting encoder "
           "regressing SH lighting (lmax {lmax}), trained here on CPU. Loaded by `panolight_core.estimators.nn.estimator` with "
           "numpy only (no torch, no pickle).".format(lmax=cfg["lmax"]), "",
           f"- file: `{name}.safetensors`, {weights.stat().st_size / 2 ** 20:.1f} MiB, sha256 `{sha[:16]}...`",
           f"- config: `{json.dumps(cfg)}`",
           f"- training: {len(rows)} epochs, {seconds / 60:.0f} min of training steps on this project's 2-core CPU machine"
           + (f"; command: `{train_command}`" if train_command else ""),
           "- data: " + (f"{real_data} Also " if real_data else "")
           + "procedural HDR environments (CIE skies with a sun, rooms with lamps and windows), Mitsuba-"
           "rendered synthetic panoramas and their relit versions (paper Eq. 5), made by this repository; "
           "never Blender's studio HDRIs (the public evaluation set)." + (f" {data_note}" if data_note else ""),
           f"- input: any 2:1 8-bit panorama, reduced to the network's {cfg['input_height']} x "
           f"{2 * cfg['input_height']} (colour, clipped fraction and "
           + ("the per-source energy model's recovered excess (models/sources.safetensors): the network is a "
              "correction of the default estimator" if sources_guess else "the physical highlight model's guess")
           + ", panolight_core/estimators/nn/inputs.py); "
           "output: SH radiance in the LDR's linear units (1 = clip level), Blender world frame.", "",
           "## Training curve (held-out validation" + ("" if real_data else ", synthetic") + ")", ""] + ([baseline, ""] if baseline else []) + [
           "| epoch | stage | train loss | val loss | val m-RMSE | val irr-RMSE | seconds |",
           "|---:|---|---:|---:|---:|---:|---:|"]
    for r in rows:
        out.append(f"| {r['epoch']} | {r['stage']} | {float(r['train_loss']):.4f} | {float(r['val_loss']):.4f} | "
                   f"{float(r['val_m_rmse']):.3f} | {float(r.get('val_irr_rmse', 'nan')):.3f} | {float(r['seconds']):.0f} |")
    if evaluation is not None:
        res = json.loads(Path(evaluation).read_text())
        out += ["", "## Public set (EVALUATION.md protocol, JPEG q90; never trained on)", "",
                "| estimator | ev | mean m-RMSE | mean irr-RMSE | median ms |", "|---|---:|---:|---:|---:|"]
        for s in res["summary"].values():
            out.append(f"| {s['estimator']} | {s['ev']:+g} | {s['mean_m_rmse']:.3f} | {s['mean_irr_rmse']:.3f} | "
                       f"{s['median_ms']:.1f} |")
    if extra:
        out += ["", extra.rstrip()]
    out += ["", "## Limits", "",
            ("- Real lighting from a few dozen scenes; a kind of scene they lack gets the synthetic prior."
             if real_data else
             "- Trained on synthetic scenes only; real photographs differ (sensor noise, tone curves, lens flare)."),
            "- A clipped light's true intensity is not in the pixels: the network can only learn a prior for it.",
            "- Bands above the model's order come from the autoencoder's HDR map, not the encoder."]
    return "\n".join(out) + "\n"


def ship(run, name: str = "small", **kw) -> tuple[Path, Path]:
    run = Path(run)
    cfg = json.loads((run / "config.json").read_text())
    if cfg.get("source_model"):
        from panolight_core.errors import PanoLightError

        raise PanoLightError(f"{run}: the network corrects the per-source model {cfg['source_model']}, a file that "
                             f"does not ship; train it on the shipped one (a config without \"source_model\")")
    MODELS.mkdir(exist_ok=True)
    weights = MODELS / f"{name}.safetensors"
    shutil.copyfile(run / "model.safetensors", weights)
    md = MODELS / f"{name}.md"
    md.write_text(card(run, name, **kw))
    return weights, md


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m training.neural.ship", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("run", help="run folder of 'panolight train' (model.safetensors, config.json, metrics.csv)")
    ap.add_argument("--name", default="small")
    ap.add_argument("--eval", default=None, help="eval.json of 'panolight eval' to quote in the card")
    ap.add_argument("--train-command", default="")
    ap.add_argument("--data-note", default="")
    ap.add_argument("--baseline", default="", help="a sentence on what the validation numbers compare with")
    ap.add_argument("--real-data", default="", help="a sentence on the real HDR panoramas it was trained on")
    ap.add_argument("--extra", default=None, metavar="MARKDOWN_FILE",
                    help="a markdown file appended to the card before its limits (e.g. the cross-validation)")
    args = ap.parse_args(argv)
    extra = Path(args.extra).read_text(encoding="utf-8") if args.extra else ""
    paths = ship(args.run, args.name, evaluation=args.eval, train_command=args.train_command, data_note=args.data_note,
                 baseline=args.baseline, real_data=args.real_data, extra=extra)
    print("wrote " + ", ".join(map(str, paths)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
