"""How much each key light should carry: the energy rules of ``keylight`` compared over the real HDRs.

For every scene of ../shared/data/hdri with an un-clipped truth, at each ev: the camera JPEG (EVALUATION.md,
q90), the per-source model's regions, mu, sigma and decision, and the key lights ``find_key_lights`` finds.
Each rule then gives every key light an energy, and the recovered work map (the decided fill of each region
less its light, plus the light) is scored as ``panolight estimate`` fits it: m-RMSE and irr-RMSE at lmax 2
(EVALUATION.md, as ratios to the naive map's), and for scenes with a dominant compact source the energy
within 5 degrees of it against the truth's (r; median |log2 r| reported as "within 2^x").

Rules (``ENERGY_RULES``: the shipped one is ``keylight.key_energy``) and the baseline:
- ``sources``: no key light (the default estimator);
- ``decided``: every light carries the energy the decision rule reports for its region;
- ``capped``: the clear-sky fit's energy (or the model's mean) capped at the larger of mean and decided;
- ``physical``: the clear-sky fit's energy where it passes the cloudiness gate, else the model's mean;
- ``hybrid`` (shipped): ``capped`` for a clear-sky sun, ``decided`` for every other light;
- ``sky``: the clear-sky fit's whole energy for a clear-sky sun, ``decided`` for every other light.

The shipped trees saw the scenes they were trained on, which favours all rules alike; ``--fold-models`` scores
each scene with the model of its fold, which never saw it (``training.source_energy.fit ship --hold-out K/5``).
``--gate`` adds a scene-level gate (one feature threshold, chosen on
the other folds' scenes, 5 folds by scene) that turns the key lights on or off; ``--plateaus`` scores the
shipped rule with other plateau extents (``keylight.PARAMS.plateau_extent_deg``: how wide a region may be and still
make a light without a clear-sky sun in it). The summary also lists the clear-sky fits' blueness (the kept
sky's blue/red over the model's; ``sky.MIN_BLUENESS``) for real suns (a dominant source within 10 degrees)
and for every other region it was tried on.

    python -m training.keylight.rules [--evs -2 0 2] [--gate] [--plateaus 15 30 60] [--floors none 30:15]
                                      [--fold-models 'f_{k}.safetensors']
                                      [--curve NAME[:PARAM]] [--out docs/studies/keylight_rules.json]
"""
from __future__ import annotations

import argparse
import math
import statistics
from dataclasses import replace
from pathlib import Path

import numpy as np

from panolight_core import metrics, sh
from panolight_core.camera import auto_exposure, hdr_to_ldr, ldr_to_linear
from panolight_core.camera.color import LUMINANCE_WEIGHTS
from panolight_core.estimators import keylight, sources
from panolight_core.estimators.sources.fill import cap_log_ratios, fill_with_keys
from panolight_core.pipeline import fit_radiance
from training.common.folds import scene_folds
from training.common.real_hdri import clipped_truth, load_hdr, scene_files
from training.common.study import (
    SRGB,
    curve_option,
    fold_models_option,
    nested_table,
    real_hdri_parser,
    save_study,
    scene_models,
)

ENERGY_RULES = ("decided", "capped", "physical", "hybrid", "sky")
SHIPPED_RULE = "hybrid"  # ``keylight.key_energy`` (tested equal to it)
RULES = ("sources",) + ENERGY_RULES
CONE_DEG = metrics.SOURCE_CONE_DEG


def rule_energy(rule: str, physical: float | None, learned: float, decided: float, trusted: bool = False,
                params: keylight.KeyLightParams = keylight.PARAMS) -> float:
    """A key light's energy under one of ENERGY_RULES from its candidates (luminance x sr, camera units): the
    clear-sky fit's (x sky_correction; None where there is none), the per-source model's mean and the decided
    fill's. "decided": the decided fill's; "capped": the fit's (else the mean), capped at the larger of mean and
    decided; "physical": the fit's, else the mean; "hybrid" (shipped, ``keylight.key_energy``): "capped" for a
    clear-sky sun, but never below the low end of the fit's 68 % range where the fit is ``trusted``, "decided"
    otherwise; "sky": the fit's whole energy for a clear-sky sun, "decided" otherwise."""
    if rule not in ENERGY_RULES:
        raise ValueError(f"unknown key-light energy rule {rule!r}: one of {', '.join(ENERGY_RULES)}")
    if rule == "hybrid":
        return keylight.key_energy(physical, learned, decided, trusted, params)
    capped = min(learned if physical is None else physical, max(decided, learned))
    return {"decided": decided, "capped": capped, "physical": learned if physical is None else physical,
            "sky": decided if physical is None else physical}[rule]


def _energies(rule: str, keys: list[dict]) -> list[float]:
    """Each key light's energy under ``rule`` from its candidates (physical, learned, decided, and whether
    ``find_key_lights`` trusted its fit: the shipped floor); none for the baseline ``sources``."""
    if rule == "sources":
        return [0.0] * len(keys)
    return [rule_energy(rule, k["physical"], k["learned"], k["decided"], k["trusted"]) for k in keys]


def find_under(rule: str, maps, regions, prediction, params=keylight.PARAMS, fits=None) -> list:
    """``keylight.find_key_lights`` with the region lights weighed by another energy rule (those it gives no
    energy dropped), then the hidden sun: the key lights a shipped estimator with that rule would find."""
    keys = []
    for k in keylight.region_candidates(maps, regions, prediction, params, fits):
        e = rule_energy(rule, k.physical, k.learned, k.decided, k.trusted, params)
        if e > 0:
            keys.append(replace(k, energy=e))
    return keylight.with_hidden_sun(keys, maps, regions, params, fits)


NO_FLOOR = (-1.0, 91.0)  # a ``physics_trusted`` floor no sun meets: "hybrid" as it was before the floor


def floor_params(floor) -> keylight.KeyLightParams:
    """The shipped key-light parameters with the ``physics_trusted`` floor (extent, elevation), degrees."""
    return replace(keylight.PARAMS, floor_max_extent_deg=floor[0], floor_min_elevation_deg=floor[1])


def floor_label(floor) -> str:
    """A (extent, elevation) floor's label in the rows: "none" for NO_FLOOR."""
    return "none" if tuple(floor) == NO_FLOOR else f"{floor[0]:g}/{floor[1]:g}"


def parse_floor(text: str) -> tuple[float, float]:
    """--floors item "EXTENT:ELEVATION" (degrees) or "none" -> a ``physics_trusted`` floor (extent, elevation)."""
    if text == "none":
        return NO_FLOOR
    try:
        ext, elev = (float(v) for v in text.split(":"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"a floor is EXTENT:ELEVATION in degrees (or none), got {text!r}") from None
    return ext, elev


def score_scene(hdr: np.ndarray, ev: float, model, plateaus=(), curve=SRGB, floors=()) -> dict:
    """One scene at one ev: the key lights' candidates and every rule's scores; for each of ``plateaus``
    (degrees) the shipped rule's scores with that ``find_key_lights`` plateau_deg (the sensitivity check), and
    for each of ``floors`` ((extent, elevation), degrees) with that ``physics_trusted`` floor.
    curve: the camera's tone curve ((name, parameter) of ``camera.TONE_CURVES``; EVALUATION.md's sRGB)."""
    ds = metrics.dominant_source(hdr)
    gt = sh.project(hdr, 2)
    ldr = hdr_to_ldr(hdr, ev, 90, robust=True, curve=curve[0], curve_param=curve[1])
    rad, frac_any, frac_all = maps = sources.work_maps(ldr)
    rec = sources.recover(ldr, model, maps=maps)  # the default's regions, prediction and decision
    reg, mu, sigma, reported = rec.regions, rec.mu, rec.sigma, rec.log_ratio
    naive = sh.project(ldr_to_linear(ldr), 2)
    row = {"ev": ev, "dominant": bool(ds["dominant"]), "naive": [metrics.m_rmse(gt, naive), metrics.irr_rmse(gt, naive)],
           "keys": [], "rules": {}}
    found = []
    fits = {}  # the clear-sky fits, made once for every plateau setting
    found = find_under("physical", maps, reg, (mu, sigma, reported), fits=fits)
    for k in found:
        j, parts = k.region, [k.region, *k.parts]  # the regions the light stands for
        hidden = j < 0  # a sun the photo does not show: no region, every rule gives it the fit's energy
        row["keys"].append({"method": k.method, "physical": k.physical,
                            "learned": k.physical if hidden else reg.added_energy(mu, parts),
                            "decided": k.physical if hidden else reg.added_energy(reported, parts),
                            "extent_deg": 0.0 if hidden else float(reg.extent_deg()[j]),
                            "elevation_deg": sh.elevation_deg(k.direction),
                            "trusted": k.cap is not None,  # a trusted fit bounds the sun: it carries a cap
                            "blueness": k.sky.blueness if k.sky is not None else None,
                            "sky_fits": k.sky is not None and k.sky.luminance_clear,
                            "features": None if hidden else {n: float(v) for n, v in zip(reg.names, reg.features[j])},
                            "angle_deg": metrics.angle_deg(k.direction, ds["direction"]) if ds["dominant"] else None})
    h, w = rad.shape[:2]
    cone = None
    if ds["dominant"]:
        cone = sh.pixel_directions(h, w) @ np.asarray(ds["direction"]) > math.cos(math.radians(CONE_DEG + 90.0 / h))
        truth = float(ds["energy"]) * auto_exposure(hdr, ev, robust=True)
        if curve != SRGB:  # the picture's linear units are not k x the HDR's: scale by the medians (EVALUATION.md's r)
            truth = float(ds["energy"]) * float(np.median(ldr_to_linear(ldr) @ LUMINANCE_WEIGHTS)) / float(
                np.median(hdr @ LUMINANCE_WEIGHTS))

    def scores(keys):
        work = fill_with_keys(rad, reg, cap_log_ratios(reg, reported, keys), keys)[1]
        q = fit_radiance(work, hdr_input=False).project(2)
        got = [metrics.m_rmse(gt, q), metrics.irr_rmse(gt, q)]
        if cone is not None:
            got.append(float(((work @ LUMINANCE_WEIGHTS) * sh.pixel_solid_angles(h, w))[cone].sum()) / truth)
        return got

    for rule in RULES:
        row["rules"][rule] = scores([replace(k, energy=e) for k, e in zip(found, _energies(rule, row["keys"])) if e > 0])
    prediction = (mu, sigma, reported)
    row["plateau"] = {f"{t:g}": scores(keylight.find_key_lights(
        maps, reg, prediction, replace(keylight.PARAMS, plateau_extent_deg=t), fits)) for t in plateaus}
    row["floor"] = {floor_label(f): scores(keylight.find_key_lights(
        maps, reg, prediction, floor_params(f), fits))
        for f in floors}
    return row


def _region_keys(row) -> list[dict]:
    """A row's key lights that stand for a clipped region (a hidden sun has no region features)."""
    return [k for k in row["keys"] if k["features"] is not None]


def _gate_feature(row, name):
    return _region_keys(row)[0]["features"][name]


def gated(rows: list[dict], names: list[str], rule: str = "hybrid") -> dict:
    """Per (scene, ev): the scores of ``rule`` where a one-threshold gate chosen on the other folds' scenes
    turns the key lights on, the baseline's elsewhere; and the gates chosen."""
    scenes = sorted({r["scene"] for r in rows})
    out, chosen = {}, []

    def gain(r):
        return math.log(r["rules"][rule][0] / r["rules"]["sources"][0]) if _region_keys(r) else 0.0

    for fold in scene_folds(len(scenes)):
        test = {scenes[i] for i in fold}
        train = [r for r in rows if r["scene"] not in test and _region_keys(r)]
        best = (0.0, None)
        for n in names:
            for t in sorted({_gate_feature(r, n) for r in train}):
                for side in (1, -1):
                    total = sum(gain(r) for r in train if side * (_gate_feature(r, n) - t) >= 0)
                    if total < best[0]:
                        best = (total, (n, t, side))
        g = best[1]
        chosen.append(g)
        for r in rows:
            if r["scene"] in test:
                on = bool(_region_keys(r)) and g is not None and g[2] * (_gate_feature(r, g[0]) - g[1]) >= 0
                out[(r["scene"], r["ev"])] = r["rules"][rule if on else "sources"]
    return {"scores": out, "gates": chosen}


def floor_cv(rows: list[dict], labels: list[str]) -> dict:
    """Per (scene, ev): the shipped rule's scores with the floor (one of ``labels`` of the rows' "floor") that
    scores best on the other folds' scenes (5 folds by scene; the least sum of log m-RMSE, every ev), and the
    floors chosen."""
    scenes = sorted({r["scene"] for r in rows})
    out, chosen = {}, []
    for fold in scene_folds(len(scenes)):
        test = {scenes[i] for i in fold}
        train = [r for r in rows if r["scene"] not in test]
        best = min(labels, key=lambda f: (sum(math.log(r["floor"][f][0]) for r in train), f != "none"))
        chosen.append(best)
        out.update({(r["scene"], r["ev"]): r["floor"][best] for r in rows if r["scene"] in test})
    return {"scores": out, "floors": chosen}


def summary(rows: list[dict], get) -> dict:
    """The harmed scenes (EVALUATION.md, first), m-RMSE and irr-RMSE over naive (median, mean) and the dominant sources'
    energy (within, worst)."""
    m = [get(r)[0] / r["naive"][0] for r in rows]
    i = [get(r)[1] / r["naive"][1] for r in rows]
    dom = [get(r)[2] for r in rows if r["dominant"]]
    return {"harmed": sum(metrics.harmed(get(r)[0], r["naive"][0]) for r in rows),
            "scenes": len(rows), "m_rmse_median": statistics.median(m), "m_rmse_mean": statistics.mean(m),
            "irr_rmse_mean": statistics.mean(i), "dominant": len(dom),
            "within": metrics.ratio_within(dom),
            "worst_low": min(dom) if dom else None, "worst_high": max(dom) if dom else None}


def blueness(rows: list[dict]) -> dict:
    """The blueness (sorted) of the clear-sky fits that pass the gate's other tests (residual, visible sky), at
    real suns (a dominant source within 10 degrees) and elsewhere."""
    out = {"suns": [], "others": []}
    for r in rows:
        for k in _region_keys(r):
            if k["sky_fits"]:
                sun = k["angle_deg"] is not None and k["angle_deg"] <= 10.0
                out["suns" if sun else "others"].append(round(k["blueness"], 3))
    return {name: sorted(v) for name, v in out.items()}


def table(result: dict) -> list[str]:
    return nested_table(
        ["| ev | rule | harmed | scenes | m-RMSE / naive, median | mean | irr-RMSE / naive, mean | dominant energy "
         "within | worst r |", "|---|---|---:|---:|---:|---:|---:|---:|---|"], result["summary"], lambda ev, rule, s: (
            f"{ev} | `{rule}` | {s.get('harmed', '?')} | {s['scenes']} | {s['m_rmse_median']:.3f} | {s['m_rmse_mean']:.3f} | "
            f"{s['irr_rmse_mean']:.3f} | {s['within']:.2f}x | {s['worst_low']:.3g} / {s['worst_high']:.3g}"))


def main(argv=None) -> int:
    ap = real_hdri_parser("python -m training.keylight.rules", __doc__)
    ap.add_argument("--gate", action="store_true", help="also score a cross-validated one-threshold gate")
    ap.add_argument("--plateaus", type=float, nargs="*", default=[],
                    help="also score the shipped rule with these plateau extents (degrees; keylight.PARAMS.plateau_extent_deg)")
    ap.add_argument("--floors", type=parse_floor, nargs="*", default=[], metavar="EXTENT:ELEVATION",
                    help="also score the shipped rule with these physics_trusted floors (degrees; 'none': no floor), "
                         "and the floor chosen on the other folds' scenes")
    fold_models_option(ap)
    curve_option(ap)
    ap.add_argument("--out", type=Path, default=None, help="write the rows and summary as JSON here")
    args = ap.parse_args(argv)
    files = scene_files(args.hdri)
    clipped = clipped_truth(args.hdri)
    model_of = scene_models(args.fold_models, files)  # the shipped model for every scene, or the one that never saw it
    rows = []
    for i, p in enumerate(files, 1):
        if p.name in clipped:
            continue
        hdr = load_hdr(p)
        for ev in args.evs:
            row = dict(score_scene(hdr, ev, model_of[p], args.plateaus, args.curve, args.floors), scene=p.stem)
            rows.append(row)
            print(f"[{i}/{len(files)}] {p.stem:28s} ev {ev:+g}: " + "  ".join(
                f"{rule} {row['rules'][rule][0]:.3f}" for rule in RULES), flush=True)
    result = {"fold_models": args.fold_models, "curve": list(args.curve), "summary": {}, "gates": None,
              "floors": None, "blueness": blueness(rows)}
    labels = [floor_label(f) for f in args.floors]
    floors = floor_cv(rows, labels) if labels else None
    if floors:
        result["floors"] = floors["floors"]
    gate = None
    if args.gate:
        names = sorted(next((_region_keys(r)[0]["features"] for r in rows if _region_keys(r)), {}))
        gate = gated(rows, names)
        result["gates"] = [list(g) if g else None for g in gate["gates"]]
    for ev in args.evs:
        sel = [r for r in rows if r["ev"] == ev]
        per = {rule: summary(sel, lambda r, rule=rule: r["rules"][rule]) for rule in RULES}
        if gate:
            per["hybrid, gated (CV)"] = summary(sel, lambda r: gate["scores"][(r["scene"], r["ev"])])
        for f in labels:
            per[f"{SHIPPED_RULE}, floor {f}"] = summary(sel, lambda r, f=f: r["floor"][f])
        if floors:
            per[f"{SHIPPED_RULE}, floor chosen by CV"] = summary(sel, lambda r: floors["scores"][(r["scene"], r["ev"])])
        for t in args.plateaus:
            per[f"{SHIPPED_RULE}, plateau {t:g} deg"] = summary(sel, lambda r, t=t: r["plateau"][f"{t:g}"])
        result["summary"][f"{ev:+g}"] = per
    print("\n".join(table(result)))
    for name, v in result["blueness"].items():
        print(f"clear-sky blueness, {name}: {len(v)} fits, " + (f"min {v[0]:.2f}, median {statistics.median(v):.2f}, "
                                                                 f"max {v[-1]:.2f}" if v else "none"))
    save_study(dict(result, rows=rows), args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
