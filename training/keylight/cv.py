"""The key light over the real HDRs: the dominant source's direction and energy (EVALUATION.md), and the
clear-sky energy correction, cross-validated by scene.

For every scene of ../shared/data/hdri with a dominant compact source, at each ev: the camera JPEG
(EVALUATION.md, q90), the estimate (``estimate_lighting``, estimator ``keylight`` unless --estimator)
and its ``hdr.exr`` panorama, scored by
the direction of its brightest light, the energy ratio r within 5 degrees of the true source and the shadow
contrast C (lit over shadow of a surface facing the true source; per scene C_est and C_true). Scenes
whose HDR clips its own source (MANIFEST ``sun``: "clipped" or "lower bound") are reported apart.

SKY_CORRECTION (``panolight_core.estimators.keylight``) is the one number fitted here: the median of
log(true / physical) of the clear-sky suns. Its cross-validated check: each fold's scenes are scored with
the median of the OTHER folds' scenes (5 folds by scene, the assignment of ``training.source_energy.cv``); the
table then shows how far that lands from the shipped all-scene value.

    python -m training.keylight.cv [--evs -2 0 2] [--out docs/studies/keylight.json]
    python -m training.keylight.cv --fold-models 'runs/folds/sources_{k}.safetensors'   # by scene, out of sample
    python -m training.keylight.cv --curve contrast:1.6     # through another camera's tone curve

``--fold-models`` scores each scene with the per-source model of its fold (``training.source_energy.fit ship
--hold-out K/5``), which never saw it: a cross-validation of the estimator, not only of SKY_CORRECTION.
"""
from __future__ import annotations

import json
import math
import statistics
from pathlib import Path

import numpy as np

from panolight_core import metrics, sh
from panolight_core.camera import auto_exposure, hdr_to_ldr
from panolight_core.estimators import keylight, naive, register_source_model
from panolight_core.pipeline.estimate import estimate_lighting
from panolight_core.pipeline.settings import Settings
from training.common.folds import fold_of, scene_folds
from training.common.real_hdri import clipped_truth, load_hdr, scene_files
from training.common.study import (
    SRGB,
    curve_option,
    fold_estimators,
    fold_model_paths,
    fold_models_option,
    real_hdri_parser,
    save_study,
)


def estimate_scene(hdr, ds: dict, ev: float, estimator: str, curve=SRGB):
    """The camera JPEG (q90) of ``hdr`` at ``ev`` through ``curve``, its estimate, the estimate's brightest light
    (None without one), that light's angle to the dominant source ``ds`` (``metrics.dominant_source``; 180 degrees
    without a light) and the source's energy ratio r from the estimate's ``hdr.exr``:
    (ldr, result, key, angle_deg, r)."""
    ldr = hdr_to_ldr(hdr, ev, 90, curve=curve[0], curve_param=curve[1])
    res = estimate_lighting(ldr, Settings(estimator=estimator))
    key = metrics.brightest_light(res.model.lights)
    angle = metrics.angle_deg(ds["direction"], key["peak_direction"]) if key else 180.0
    return ldr, res, key, angle, metrics.source_energy_ratio(hdr, res.hdr_panorama(ldr), ds["direction"])


def score_scene(path: Path, evs, clipped: bool, estimator: str = "keylight", curve=SRGB) -> list[dict]:
    """The dominant source's rows of one scene (none without one), one per ev, through the camera ``curve``
    ((name, parameter) of ``camera.TONE_CURVES``; EVALUATION.md's sRGB by default)."""
    hdr = load_hdr(path)
    ds = metrics.dominant_source(hdr)
    if not ds["dominant"]:
        return []
    true_contrast = metrics.true_shadow_contrast(hdr, ds["direction"])
    truth = sh.project(hdr, 2)
    rows = []
    for ev in evs:
        ldr, res, key, angle, ratio = estimate_scene(hdr, ds, ev, estimator, curve)
        rec = res.estimate.recovery
        sky_key = next((k for k in (rec.keys if rec is not None else []) if k.method.startswith("clear-sky")), None)
        physical = None
        # the physical energy in camera units against the truth's: only through EVALUATION.md's sRGB curve
        if sky_key is not None and curve == SRGB and metrics.angle_deg(sky_key.direction, ds["direction"]) <= 10.0:
            k = auto_exposure(hdr, ev)
            physical = sky_key.physical / keylight.PARAMS.sky_correction / (ds["energy"] * k)
        rows.append({"scene": path.stem, "ev": ev, "clipped_truth": clipped, "share": round(ds["share"], 4),
                     "angle_deg": round(angle, 3), "ratio": ratio,
                     "contrast": metrics.model_shadow_contrast(res.model, ds["direction"]), "true_contrast": true_contrast,
                     # EVALUATION.md's m-RMSE of the whole model (lights + SH at lmax 2), and naive's
                     "m_rmse": metrics.m_rmse(truth, res.model.project(2)),
                     "naive_m_rmse": metrics.m_rmse(truth, naive(ldr, 2).coeffs),
                     "lights": len(res.model.lights), "key_method": key.get("source") if key else None,
                     "direction_68_deg": key.get("direction_68_deg") if key else None,
                     "physical_over_true": physical})
    return rows


def summary(rows, ev) -> dict:
    sel = [r for r in rows if r["ev"] == ev and not r["clipped_truth"]]
    if not sel:
        return {}
    lr = [abs(math.log2(max(r["ratio"], 1e-12))) for r in sel]
    return {"harmed": sum(metrics.harmed(r["m_rmse"], r["naive_m_rmse"]) for r in sel),  # EVALUATION.md: first
            "scenes": len(sel), "median_angle_deg": statistics.median(r["angle_deg"] for r in sel),
            "median_abs_log2_ratio": statistics.median(lr), "within": 2 ** statistics.median(lr),
            "worst_low": min(r["ratio"] for r in sel), "worst_high": max(r["ratio"] for r in sel),
            # the shadow an artist sees (EVALUATION.md): C_est / C_true of a surface facing the true source
            "contrast_within": metrics.ratio_within(r["contrast"] / r["true_contrast"] for r in sel),
            "contrast_worst": max((r["contrast"] / r["true_contrast"] for r in sel), key=lambda v: abs(math.log2(v))),
            "m_rmse_over_naive_median": statistics.median(r["m_rmse"] / r["naive_m_rmse"] for r in sel),
            "m_rmse_over_naive_mean": statistics.fmean(r["m_rmse"] / r["naive_m_rmse"] for r in sel),
            # EVALUATION.md's harm (a blinding light): above both 2x naive and naive + 0.25
            "blinding": sorted(r["scene"] for r in sel if metrics.harmed(r["m_rmse"], r["naive_m_rmse"])),
            "no_light": sum(r["lights"] == 0 for r in sel),
            # how often the brightest light's direction is within the 68 % radius it reports (calibrated: 0.68)
            "direction_68_covers": _share([r["angle_deg"] <= r["direction_68_deg"] for r in sel
                                           if r.get("direction_68_deg") is not None])}


def _share(flags: list) -> float | None:
    return sum(flags) / len(flags) if flags else None


def correction_cv(rows, files) -> dict:
    """SKY_CORRECTION by folds: each fold's suns corrected by the median of the others'."""
    logs = {(r["scene"], r["ev"]): math.log(r["physical_over_true"]) for r in rows
            if r["physical_over_true"] and not r["clipped_truth"]}
    if not logs:
        return {}
    names = [p.stem for p in files]
    out = {"all_scenes": math.exp(-statistics.median(logs.values())), "folds": [], "cv_abs_log2": []}
    for fold in scene_folds(len(files)):
        held = {names[i] for i in fold}
        train = [v for (s, _), v in logs.items() if s not in held]
        test = [v for (s, _), v in logs.items() if s in held]
        if not train:
            continue
        c = -statistics.median(train)
        out["folds"].append(math.exp(c))
        out["cv_abs_log2"] += [abs(v + c) / math.log(2) for v in test]
    out["cv_within"] = 2 ** statistics.median(out["cv_abs_log2"]) if out["cv_abs_log2"] else None
    out["suns"] = len(logs)
    return out


PICTURE_CURVES = (SRGB, ("gamma", 2.2), ("shoulder", 4.0), ("contrast", 1.6))


def curve_picture(path: Path, out: Path, ev: float = 0.0, curves=PICTURE_CURVES, estimator: str = "keylight",
                  width: int = 640) -> list[dict]:
    """One real HDR with a dominant source through each camera curve, drawn: per curve the camera JPEG's sky
    around the source (upper hemisphere, 180 degrees of azimuth centred on it, ``width`` wide), its clipped pixels
    tinted red, the true source (yellow ring) and the estimate's brightest light (cyan cross), with the
    direction error and the energy ratio r. Returns the rows drawn (curve, angle_deg, ratio)."""
    from PIL import Image, ImageDraw

    hdr = load_hdr(path)
    ds = metrics.dominant_source(hdr)
    if not ds["dominant"]:
        raise SystemExit(f"{path}: no dominant compact source (EVALUATION.md) to draw")
    H, W = hdr.shape[:2]
    ty, tx = sh.grid.pixel_at(ds["direction"], H, W)
    cols = (tx + np.arange(-W // 4, W // 4)) % W  # 180 degrees of azimuth around the source
    scale = width / cols.size

    def at(direction):  # a direction's (x, y) in a panel
        y, x = sh.grid.pixel_at(direction, H, W)
        return ((x - cols[0]) % W + 0.5) * scale, (y + 0.5) * scale

    panels, rows = [], []
    for curve in curves:
        ldr, _, key, angle, ratio = estimate_scene(hdr, ds, ev, estimator, curve)
        sky = ldr[: H // 2][:, cols].astype(np.float64)
        white = ldr[: H // 2][:, cols].min(axis=-1) >= 254
        sky[white] = 0.55 * sky[white] + 0.45 * np.array([255.0, 0.0, 0.0])
        img = Image.fromarray(sky.astype(np.uint8)).resize((width, round(sky.shape[0] * scale)), Image.BILINEAR)
        draw = ImageDraw.Draw(img)
        x, y = at(ds["direction"])
        r = 5.0 / 180.0 * H * scale  # the metric's 5-degree cone
        draw.ellipse([x - r, y - r, x + r, y + r], outline=(255, 230, 0), width=2)
        if key is not None and key["peak_direction"][2] > 0:
            x, y = at(key["peak_direction"])
            draw.line([x - 7, y, x + 7, y], fill=(0, 255, 255), width=2)
            draw.line([x, y - 7, x, y + 7], fill=(0, 255, 255), width=2)
        name = curve[0] + (f" {curve[1]:g}" if curve[1] is not None else "")
        label = f"{name}: key light {angle:.1f} deg off, r {ratio:.2g}" if key else f"{name}: no light, r {ratio:.2g}"
        draw.rectangle([0, 0, width, 15], fill=(0, 0, 0))
        draw.text((4, 2), label, fill=(255, 255, 255))
        panels.append(img)
        rows.append({"curve": list(curve), "angle_deg": round(angle, 3), "ratio": ratio})
    canvas = Image.new("RGB", (width, sum(p.height for p in panels)))
    y0 = 0
    for p in panels:
        canvas.paste(p, (0, y0))
        y0 += p.height
    out.parent.mkdir(parents=True, exist_ok=True)
    canvas.save(out, **({"quality": 88} if out.suffix.lower() in (".jpg", ".jpeg") else {}))
    return rows


def main(argv=None) -> int:
    ap = real_hdri_parser("python -m training.keylight.cv", __doc__)
    ap.add_argument("--estimator", default="keylight", help="estimator to score (default: %(default)s; "
                    "'sources' gives the baseline)")
    fold_models_option(ap)
    curve_option(ap)
    ap.add_argument("--out", type=Path, default=None, help="write the rows and summary as JSON here")
    ap.add_argument("--picture", nargs=2, type=Path, metavar=("HDR", "IMAGE"), default=None,
                    help="instead: draw one real HDR's sky around its dominant source through each camera curve "
                         "(sRGB, gamma 2.2, shoulder 4, contrast 1.6) at the first --evs value, with the clipped "
                         "pixels, the true source and the estimate's key light (e.g. docs/tone_curves.jpg)")
    args = ap.parse_args(argv)
    if args.picture:
        estimator = args.estimator
        if args.fold_models:  # the trees of the scene's fold, which never saw it
            files = scene_files(args.hdri)
            k = fold_of(files).get(next((p for p in files if p.name == args.picture[0].name), None))
            if k is None:
                raise SystemExit(f"--picture with --fold-models: {args.picture[0].name} is not a scene of {args.hdri}")
            estimator = register_source_model(f"{args.estimator}-fold{k}", fold_model_paths(args.fold_models)[k],
                                              key_lights=args.estimator == "keylight")
        for row in curve_picture(args.picture[0], args.picture[1], args.evs[0], estimator=estimator):
            print(f"{row['curve'][0]} {row['curve'][1] or ''}: angle {row['angle_deg']:.1f} deg, r {row['ratio']:.3g}")
        print(f"wrote {args.picture[1]}")
        return 0
    files = scene_files(args.hdri)
    clipped = clipped_truth(args.hdri)
    estimator_of = {p: args.estimator for p in files}
    if args.fold_models:
        if args.estimator not in ("keylight", "sources"):
            raise SystemExit("--fold-models scores 'keylight' or 'sources' (the per-source model's estimators)")
        estimator_of = fold_estimators(args.fold_models, files, args.estimator)
    rows = []
    for i, p in enumerate(files, 1):
        got = score_scene(p, args.evs, p.name in clipped, estimator_of[p], args.curve)
        rows += got
        for r in got:
            print(f"[{i}/{len(files)}] {r['scene']:28s} ev {r['ev']:+g}{' (clipped truth)' if r['clipped_truth'] else ''}: "
                  f"angle {r['angle_deg']:6.1f}  r {r['ratio']:7.3f}  C {r['contrast']:5.2f} of {r['true_contrast']:5.2f}  "
                  f"lights {r['lights']}  {r['key_method'] or '-'}",
                  flush=True)
    result = {"estimator": args.estimator, "fold_models": args.fold_models, "curve": list(args.curve),
              "summary": {f"{ev:+g}": summary(rows, ev) for ev in args.evs},
              "sky_correction": correction_cv(rows, files), "shipped_sky_correction": keylight.PARAMS.sky_correction,
              "rows": rows}
    print(json.dumps({k: v for k, v in result.items() if k != "rows"}, indent=1))
    save_study(result, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
