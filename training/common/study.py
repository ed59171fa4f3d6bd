"""What the studies over the real HDRs share: their command line (--hdri, --evs, --curve, --fold-models), the fold
models they score scenes with, and writing their results."""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from panolight_core.camera import TONE_CURVES
from panolight_core.estimators import register_source_model
from training.common.folds import fold_of
from training.common.real_hdri import DEFAULT_HDRI, clipped_truth, scene_files

SRGB = ("srgb", None)  # EVALUATION.md's camera curve (``--curve``)


def save_study(result: dict, out: Path | None) -> None:
    """Write a key-light study's result (summary and rows) as JSON to ``out``, when one is given."""
    if out:
        out.write_text(json.dumps(result, indent=1) + "\n", encoding="utf-8")
        print(f"wrote {out}")


def nested_table(head: list[str], summ: dict, cells) -> list[str]:
    """A markdown table of a study's summary {ev: {label: stats}}: the ``head`` lines (header and alignment), then
    one row per (ev, label), "| " + ``cells(ev, label, stats)`` + " |"."""
    return head + [f"| {cells(ev, label, s)} |" for ev, per in summ.items() for label, s in per.items()]


def real_hdri_parser(prog: str, doc: str) -> argparse.ArgumentParser:
    """The options every key-light study over the real HDRs takes: --hdri and --evs."""
    ap = argparse.ArgumentParser(prog=prog, description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hdri", type=Path, default=DEFAULT_HDRI, help="folder of real HDR panoramas (default: %(default)s)")
    ap.add_argument("--evs", type=float, nargs="+", default=[-2.0, 0.0, 2.0], help="camera exposures (default: -2 0 2)")
    return ap


def parse_curve(text: str) -> tuple:
    """``--curve`` NAME[:PARAM] -> (name, parameter or None), a name of ``camera.TONE_CURVES``."""
    name, _, param = text.partition(":")
    if name not in TONE_CURVES:
        raise argparse.ArgumentTypeError(f"unknown tone curve {name!r}; choose one of {', '.join(TONE_CURVES)}")
    if name == "srgb" and param:
        raise argparse.ArgumentTypeError("the sRGB curve takes no parameter")
    try:
        value = float(param) if param else None
    except ValueError:
        raise argparse.ArgumentTypeError(f"--curve {text!r}: the parameter after ':' must be a number") from None
    if value is not None and not value > 0:
        raise argparse.ArgumentTypeError(f"--curve {text!r}: the parameter must be positive")
    return name, value


def curve_option(ap: argparse.ArgumentParser) -> None:
    """``--curve``: the camera's tone curve for a study's JPEGs (EVALUATION.md's sRGB by default)."""
    ap.add_argument("--curve", type=parse_curve, default=SRGB, metavar="NAME[:PARAM]",
                    help="the camera's tone curve: " + "; ".join(
                        f"'{n}'" + (f" (default {d:g})" if d is not None else "") + f": {what}"
                        for n, (what, d) in TONE_CURVES.items())
                    + ". EVALUATION.md's camera is 'srgb' (the default); e.g. --curve contrast:1.6")


def fold_models_option(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("--fold-models", default=None, metavar="PATTERN",
                    help="score each scene with the per-source model of its fold, PATTERN with {k} = 1..5 "
                         "(made by 'python -m training.source_energy.fit ship --hold-out K/5 --out ...'), "
                         "not the shipped one, which saw the scenes it was trained on")


def restoring_fold_models_option(ap: argparse.ArgumentParser) -> None:
    """--fold-models and --hdr-fold-models, for the studies that restore clipped HDR files (``restoring_estimators``)."""
    fold_models_option(ap)
    ap.add_argument("--hdr-fold-models", default=None, metavar="PATTERN",
                    help="with --fold-models: the fold models that restore the clipped HDR files (models/"
                         "sources_hdr.safetensors' folds: fit ship --hdr-cameras 8 --hold-out K/5; default: "
                         "--fold-models')")


def public_option(ap: argparse.ArgumentParser) -> None:
    """--public: the eight HDRIs the bpy package ships instead of --hdri's scenes (``study_files``)."""
    ap.add_argument("--public", action="store_true",
                    help="score the eight HDRIs the bpy package ships (the public set, never trained or tuned on) "
                         "by the shipped models, instead of --hdri's scenes by their folds")


def study_files(ap: argparse.ArgumentParser, args: argparse.Namespace) -> tuple[list, set]:
    """(scene files, the names of those whose truth clips its own source) a study given --hdri and ``public_option``
    scores: the public set's eight files (none clipped; refused with --fold-models, as no fold saw them), or
    --hdri's scenes."""
    if getattr(args, "public", False):
        if args.fold_models:
            ap.error("--public scores the public set by the shipped models, which never saw it: drop --fold-models")
        from panolight_core.data import STUDIO_HDRIS, studio_hdri

        return [studio_hdri(name) for name in STUDIO_HDRIS], set()
    return scene_files(args.hdri), clipped_truth(args.hdri)


def restoring_estimators(args: argparse.Namespace, files) -> dict:
    """{scene file: estimator name} for a study given ``restoring_fold_models_option``'s options: each scene's fold
    models (``fold_estimators``, the clipped files restored by --hdr-fold-models'), or the shipped "auto" for all."""
    if not args.fold_models:
        return dict.fromkeys(files, "auto")
    return fold_estimators(args.fold_models, files, hdr_pattern=args.hdr_fold_models)


def fold_estimators(pattern: str, files, estimator: str = "keylight", hdr_pattern: str | None = None) -> dict:
    """{scene file: the name of ``estimator`` ("keylight" or "sources") registered with the per-source model of its
    fold} (``fold_model_paths``; the folds of ``training.source_energy.cv``): each scene scored by trees that never
    saw it; ``hdr_pattern``: the fold models that restore a clipped HDR file (default: ``pattern``'s)."""
    hdr = fold_model_paths(hdr_pattern) if hdr_pattern else {}
    label = {k: register_source_model(f"{estimator}-fold{k}", path, key_lights=estimator == "keylight",
                                      hdr_path=hdr.get(k))
             for k, path in fold_model_paths(pattern).items()}
    return {p: label[k] for p, k in fold_of(files).items()}


def scene_models(pattern: str | None, files) -> dict:
    """{scene file: the per-source model to score it by}: the model of its fold (``fold_model_paths``), which never
    saw it, or the shipped model for every scene when ``pattern`` is None."""
    from panolight_core.estimators.sources import load_source_model

    if not pattern:
        return dict.fromkeys(files, load_source_model())
    models = {k: load_source_model(path) for k, path in fold_model_paths(pattern).items()}
    return {p: models[k] for p, k in fold_of(files).items()}


def fold_model_paths(pattern: str, folds: int = 5) -> dict:
    """{K: path} of the fold models ``pattern`` names ({k} = 1..folds); SystemExit naming a missing one."""
    if "{k}" not in pattern:
        raise SystemExit(f"--fold-models {pattern!r}: the pattern needs {{k}} where the fold number goes")
    paths = {k: Path(pattern.format(k=k)) for k in range(1, folds + 1)}
    missing = [str(p) for p in paths.values() if not p.is_file()]
    if missing:
        raise SystemExit(f"--fold-models: no such model file: {', '.join(missing)}")
    return paths
