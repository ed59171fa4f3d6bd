"""Leave-scenes-out test of trained networks beside the per-source model, on the real HDRs a run held out.

A run trained with ``panolight train ... --hdr DIR --hold-out K/N`` never saw fold K's scenes (its
held_out.json names them). Each is scored as EVALUATION.md says (ev -2/0/+2, JPEG q90; whole model,
lights + SH, projected to lmax 2, exactly as ``source_energy cv`` scores the per-source model), beside
naive and beside the per-source model's own cross-validated rows for the same scenes (from
docs/studies/source_energy_cv.json: a model that did not see them either).

    python -m training.neural.cv --weights real=runs/real/model.safetensors [--weights other=...]
           [--cv docs/studies/source_energy_cv.json] [--out docs/studies/neural_cv.json]
    python -m training.neural.cv --merge runs/f1/cv.json ... runs/f5/cv.json --out docs/studies/neural_cv.json

``--merge`` joins the folds' results (each scene scored once, by the run that never saw it) into one
cross-validation table over every scene; it also joins an earlier merged table with a new run's folds
(the baselines they share must agree exactly).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from panolight_core.errors import PanoLightError

CV_LABEL = "sources (cross-validated)"


def _weights(text: str) -> tuple[str, Path]:
    name, sep, path = text.partition("=")
    if not sep or not name or not path:
        raise argparse.ArgumentTypeError(f"--weights takes NAME=PATH, got {text!r}")
    return name, Path(path)


def held_out(weights: Path) -> dict:
    """The run's held_out.json (beside its model.safetensors)."""
    path = weights.parent / "held_out.json"
    if not path.is_file():
        raise PanoLightError(f"{weights}: no held_out.json beside it; train with --hdr DIR --hold-out K/N")
    return json.loads(path.read_text(encoding="utf-8"))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--merge", nargs="+", default=None, metavar="JSON",
                    help="join the results of several folds (written by this command) instead of scoring")
    ap.add_argument("--weights", type=_weights, action="append", default=[], metavar="NAME=PATH",
                    help="a run trained with --hdr DIR --hold-out K/N (its held_out.json names the scenes)")
    ap.add_argument("--also", type=_weights, action="append", default=[], metavar="NAME=PATH",
                    help="a model trained on no real HDR at all (the shipped one), scored on the same scenes")
    ap.add_argument("--cv", default="docs/studies/source_energy_cv.json",
                    help="the per-source model's cross-validation rows (python -m training.source_energy.fit cv)")
    ap.add_argument("--out", default="docs/studies/neural_cv.json")
    args = ap.parse_args(argv)
    if args.merge:
        return _merge(args)
    if not args.weights:
        ap.error("give --weights NAME=PATH (a run trained with --hold-out), or --merge")

    from panolight_core.estimators import neural_estimator
    from training.common.folds import fold_files
    from training.common.real_hdri import load_hdr, scene_files
    from training.source_energy.cv import score_scene

    runs = [(name, path, held_out(path)) for name, path in args.weights]
    scenes, hdr = runs[0][2]["scenes"], Path(runs[0][2]["hdr"])
    for _name, path, info in runs[1:]:
        if info["scenes"] != scenes:
            raise PanoLightError(f"{path}: held out other scenes than {runs[0][1]}; compare runs of one fold")
    variants = {"naive": None}
    for name, path in [(n, p) for n, p, _ in runs] + args.also:
        run = neural_estimator(path, name)
        variants[name] = lambda ldr, run=run: run(ldr, 2).radiance
    files = fold_files(scene_files(hdr), tuple(runs[0][2]["fold"]))
    if sorted(f.stem for f in files) != sorted(scenes):
        raise PanoLightError(f"{hdr}: its scenes have changed since {runs[0][1]} was trained (its held-out "
                             f"fold is now other scenes)")
    rows, t0 = [], time.perf_counter()
    for i, f in enumerate(files, 1):
        rows += [dict(r, scene=f.stem) for r in score_scene(load_hdr(f), variants)]
        print(f"{i}/{len(files)} {f.stem} ({time.perf_counter() - t0:.0f} s)", file=sys.stderr)
    return _report(args, rows, scenes, {"fold": runs[0][2]["fold"],
                                        "runs": {name: str(path) for name, path, _ in runs},
                                        "also": {name: str(path) for name, path in args.also}})


def _report(args, rows, scenes, meta) -> int:
    """Add the per-source model's cross-validated rows for ``scenes``, print the table, write --out."""
    from training.source_energy.cv import DECIDED, EVS
    from training.source_energy.report import table

    rows = [r for r in rows if r["estimator"] != CV_LABEL]
    cv_path = Path(args.cv)
    if cv_path.is_file():
        cv = json.loads(cv_path.read_text(encoding="utf-8"))
        rows += [dict(r, estimator=CV_LABEL) for r in cv["rows"]
                 if r["scene"] in scenes and r["estimator"] == DECIDED]
    names = list(dict.fromkeys(r["estimator"] for r in rows))
    print("\n".join(table(rows, names, EVS)))
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"rows": rows, "scenes": scenes, **meta}, indent=1) + "\n", encoding="utf-8")
    print(f"wrote {out}", file=sys.stderr)
    return 0


def _merge(args) -> int:
    """Join fold files, or merged files of other runs on the same scenes (more estimators): a (scene,
    estimator, ev) scored by two files must have the same scores (the baselines are), or it is refused."""
    rows, scenes, folds, seen = [], [], [], {}
    for path in args.merge:
        doc = json.loads(Path(path).read_text(encoding="utf-8"))
        for r in doc["rows"]:
            if r["estimator"] == CV_LABEL:
                continue
            key = (r["scene"], r["estimator"], r["ev"])
            if key in seen:
                if (seen[key]["m_rmse"], seen[key]["irr_rmse"]) != (r["m_rmse"], r["irr_rmse"]):
                    raise PanoLightError(f"{path}: {r['scene']} ({r['estimator']}, ev {r['ev']:+g}) already scored "
                                         f"differently by another file")
                continue
            seen[key] = r
            rows.append(r)
        scenes += [s for s in doc["scenes"] if s not in scenes]
        folds += doc["folds"] if "folds" in doc else [{"fold": doc.get("fold"), "runs": doc.get("runs", {}),
                                                       "also": doc.get("also", {})}]
    return _report(args, rows, scenes, {"folds": folds})


if __name__ == "__main__":
    raise SystemExit(main())
