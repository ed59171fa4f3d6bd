"""Experiment: what restoring does to an HDR file that clips, on every scene (issue 45's bars score the scenes with a
dominant compact source alone; docs/studies/captures.md, "Restoring every scene").

For each real HDR of ``../shared/data/hdri`` with an un-clipped truth (or, with ``--public``, the eight HDRIs the bpy
package ships), at the ev-0 camera's exposure (the JPEG's white is 1), clipped per channel at 2^STOPS and
estimated as ``panolight estimate`` does (restored where a plateau is found, by the fold's trees with
``--fold-models``): the whole model's m-RMSE (lmax 2) over the clipped file's own projection (1: as good as taking
the file as it is), the energy the file lost (the truth's luminance energy less the file's, over the truth's), and
what the restoration added over what was lost (1: exactly the missing energy; energies in luminance x sr).

    python -m training.experiments.restore_harm --fold-models 'runs/hdr/all8/sources_{k}.safetensors' \\
        [--stops 2 4 6] [--out docs/studies/restore_harm.json]
    python -m training.experiments.restore_harm --public [--out docs/studies/restore_harm_public.json]

``--rule decided`` gives a plateau's key light the photos' rule instead of its belief (an experiment). ``--ranges``
scores instead the 68 % range the run's note states for a restored key light: how often the truth lies inside it.
"""
from __future__ import annotations

import argparse
import contextlib
import statistics
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from panolight_core import metrics, sh
from panolight_core.camera import auto_exposure
from panolight_core.camera.color import luminance
from panolight_core.pipeline.estimate import estimate_lighting
from panolight_core.pipeline.settings import Settings
from training.common.real_hdri import DEFAULT_HDRI, load_hdr
from training.common.study import (
    public_option,
    restoring_estimators,
    restoring_fold_models_option,
    save_study,
    study_files,
)

LOST_NONE = 1e-6  # a file that lost at most this share of the truth's energy lost none (the float32 copy's rounding)
WORSE = (1.0, 1.5, 3.0)  # the summary counts the restored files this many times worse than the file as it is


def energy(pixels: np.ndarray) -> float:
    """Luminance energy (luminance x sr) of an equirect (H, W, 3) map."""
    return float((luminance(np.asarray(pixels, dtype=np.float64)) * sh.pixel_solid_angles(*pixels.shape[:2])).sum())


RULES = ("belief", "decided", "keys-only")  # what a restored plateau carries: the shipped belief, the photos' rule,
# or the belief with no fill outside the key lights' regions (a plateau that is no sun or lamp kept as the file holds it)


@contextlib.contextmanager
def key_light_rule(rule: str):
    """Within it, a restored HDR's key lights carry ``rule``: "belief" (as shipped: ``KeyLightParams.belief``),
    "decided" (the photos' rule: the decided fill's energy, a clear-sky sun its fit's capped there: the same
    ``keylight.with_key_lights`` without the belief it sets for a plateau), or "keys-only" (the belief, and every
    plateau region no key light stands for keeps the file's values: its decided log ratio 0)."""
    from panolight_core.estimators import keylight

    if rule not in RULES:
        raise ValueError(f"unknown rule {rule!r}: one of {', '.join(RULES)}")
    shipped = keylight.with_key_lights

    def decided(rec, params=keylight.PARAMS):
        if rec.source is None:
            return shipped(rec, params)
        regions = keylight.at_cores(rec.regions, rec.source.core_fraction(rec.regions.labels.shape[0]))
        fits = {}
        keys = keylight.find_key_lights(rec.maps, regions, (rec.mu, rec.sigma, rec.log_ratio), params, fits)
        return rec.with_keys(keys, keylight.sun_search_report(fits, keys, regions, params))

    def keys_only(rec, params=keylight.PARAMS):
        rec = shipped(rec, params)
        if rec.source is None:
            return rec
        lit = {int(i) for k in rec.keys if k.region >= 0 for i in (k.region, *k.parts)}
        kept = np.array([i in lit for i in range(rec.regions.count)], dtype=bool)
        plain = replace(rec, decided=None, log_ratio=np.where(kept, rec.decided, 0.0))
        return plain.with_keys(rec.keys, rec.sun_search)

    if rule != "belief":
        keylight.with_key_lights = decided if rule == "decided" else keys_only
    try:
        yield
    finally:
        keylight.with_key_lights = shipped


def scene_row(path: Path, stops=(2.0, 4.0, 6.0), estimator: str = "auto") -> dict:
    """One scene: whether it has a dominant compact source, and per clip level (keys "+S"): restored or not, the
    file's own m-RMSE, the estimate's over it (None where the file lost nothing: both are 0), the share of the
    truth's energy the file lost, and the energy the estimate added over it (``added_over_lost``; None where the
    file lost none)."""
    hdr = load_hdr(path)
    ds = metrics.dominant_source(hdr)
    truth = hdr * auto_exposure(hdr, 0.0)
    gt, total = sh.project(truth, 2), energy(truth)
    row = {"scene": path.stem, "dominant": bool(ds["dominant"]), "share": float(ds["share"])}
    for s in stops:
        pixels = np.minimum(truth, 2.0 ** s).astype(np.float32)
        res = estimate_lighting(pixels, Settings(estimator=estimator))
        own = metrics.m_rmse(gt, sh.project(pixels, 2))
        held = energy(pixels)
        lost = total - held if total - held > LOST_NONE * total else 0.0  # float32's rounding is no loss
        row[f"+{s:g}"] = {"restored": bool(res.estimate.info.get("restoration", {}).get("restored", False)),
                          "own": own, "over_own": metrics.m_rmse(gt, res.model.project(2)) / own if lost > 0 else None,
                          "lost_share": lost / total,
                          "added_over_lost": (energy(res.hdr_panorama(pixels)) - held) / lost if lost > 0 else None}
    return row


def range_rows(path: Path, stops=(2.0, 4.0, 6.0), estimator: str = "auto") -> list[dict]:
    """The run's note states a restored key light's 68 % range (``keylight.key_light_range``): for a scene
    with a dominant source, at each clip level whose brightest key light stands within metrics.SOURCE_CONE_DEG of
    the truth's, that range's ends over the light's strength and the factor the truth asks (1 / r: the light
    dominates the cone r is measured in)."""
    from panolight_core.estimators.keylight import key_light_range

    hdr = load_hdr(path)
    ds = metrics.dominant_source(hdr)
    if not ds["dominant"]:
        return []
    truth = hdr * auto_exposure(hdr, 0.0)
    rows = []
    for s in stops:
        pixels = np.minimum(truth, 2.0 ** s).astype(np.float32)
        res = estimate_lighting(pixels, Settings(estimator=estimator))
        key = key_light_range(res.document)
        if key is None or metrics.angle_deg(res.document["lights"][key["index"]]["direction"],
                                            ds["direction"]) > metrics.SOURCE_CONE_DEG:
            continue
        r = metrics.source_energy_ratio(truth, res.hdr_panorama(pixels), ds["direction"])
        rows.append({"scene": path.stem, "stops": s, "source": key["source"], "low": key["low"], "high": key["high"],
                     "truth_over_light": 1.0 / r if r > 0 else float("inf")})
    return rows


def range_summary(rows: list[dict]) -> dict:
    """How often the truth lies inside the stated 68 % range, below it and above it, and the ranges' median width
    (high / low), for all the key lights and by kind (a clear-sky sun, a per-source light)."""
    def count(sel):
        return {"lights": len(sel), "inside": sum(r["low"] <= r["truth_over_light"] <= r["high"] for r in sel),
                "below": sum(r["truth_over_light"] < r["low"] for r in sel),
                "above": sum(r["truth_over_light"] > r["high"] for r in sel),
                "median_width": statistics.median(r["high"] / r["low"] for r in sel) if sel else float("nan")}

    kinds = {"clear-sky sun": [r for r in rows if r["source"].startswith("clear-sky")],
             "per-source light": [r for r in rows if not r["source"].startswith("clear-sky")]}
    return {"all": count(rows), **{k: count(v) for k, v in kinds.items()}}


def summary(rows: list[dict], stops) -> dict:
    """Per clip level, for the scenes with and without a dominant source: how many were harmed (EVALUATION.md, first),
    how many were restored, the median m-RMSE
    over the file's own (every scene; 1 where nothing was restored), how many restored files came out worse than
    the file as it is by each of WORSE, the worst (files that lost nothing left out), and the restored files' added energy over the lost ("within" x,
    the median of |log2|)."""
    out = {}
    for s in stops:
        key = f"+{s:g}"
        for dominant in (True, False):
            sel = [r[key] for r in rows if r["dominant"] == dominant and r[key]["over_own"] is not None]
            done = [c for c in sel if c["restored"]]
            ratios = [c["over_own"] for c in sel]
            added = [c["added_over_lost"] for c in done if c["added_over_lost"] and c["added_over_lost"] > 0]
            out[f"{key} {'dominant' if dominant else 'no dominant source'}"] = {
                "harmed": sum(metrics.harmed(c["over_own"] * c["own"], c["own"]) for c in sel),  # EVALUATION.md
                "scenes": len(sel), "restored": len(done),
                "median_over_own": statistics.median(ratios) if ratios else float("nan"),
                **{f"worse_{w:g}x": sum(c["over_own"] > w for c in done) for w in WORSE},
                "worst": max(ratios, default=float("nan")),
                "added_within": metrics.ratio_within(added) if added else float("nan"),
                "added_median": statistics.median(added) if added else float("nan")}
    return out


def table(summ: dict) -> list[str]:
    lines = ["| clip, scenes | harmed | n | restored | m-RMSE / own, median | worse than as it is | over 1.5x | over 3x | "
             "worst | added / lost, median |", "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for name, v in summ.items():
        lines.append(f"| {name} | {v.get('harmed', '?')} | {v['scenes']} | {v['restored']} | {v['median_over_own']:.3f} | "
                     f"{v['worse_1x']} | "
                     f"{v['worse_1.5x']} | {v['worse_3x']} | {v['worst']:.3g} | {v['added_median']:.3g} |")
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m training.experiments.restore_harm", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hdri", type=Path, default=DEFAULT_HDRI, help="folder of real HDR panoramas (default: %(default)s)")
    ap.add_argument("--stops", type=float, nargs="+", default=[2.0, 4.0, 6.0],
                    help="clip at 2^STOPS times the JPEG's white (default: 2 4 6)")
    restoring_fold_models_option(ap)
    public_option(ap)
    ap.add_argument("--rule", choices=RULES, default="belief",
                    help="what a restored plateau carries: belief (as shipped), decided (the photos' rule) or "
                         "keys-only (the belief, no fill outside the key lights' regions); the last two experiments")
    ap.add_argument("--ranges", action="store_true",
                    help="instead: how often the truth lies inside the 68 %% range the run's note states for a restored "
                         "key light (the scenes with a dominant source)")
    ap.add_argument("--out", type=Path, default=None, help="write the rows and summary here (JSON)")
    args = ap.parse_args(argv)
    files, clipped = study_files(ap, args)
    estimator_of = restoring_estimators(args, files)
    if args.ranges:
        rows = [r for path in files if path.name not in clipped for r in range_rows(path, args.stops, estimator_of[path])]
        summ = range_summary(rows)
        for name, v in summ.items():
            print(f"{name}: {v['inside']} of {v['lights']} inside the stated 68 % range, {v['below']} below, "
                  f"{v['above']} above; median width {v['median_width']:.1f}x")
        save_study({"scenes": "public" if args.public else str(args.hdri), "stops": args.stops,
                    "fold_models": args.fold_models, "summary": summ, "rows": rows}, args.out)
        return 0
    rows = []
    for i, path in enumerate(files, 1):
        if path.name in clipped:
            continue  # a truth that clips its own source is a lower bound, never a target
        with key_light_rule(args.rule):
            row = scene_row(path, args.stops, estimator_of[path])
        rows.append(row)
        cells = "  ".join(f"{k} {v['over_own'] or 1.0:6.2f}{'' if v['restored'] else '-'}" for k, v in row.items()
                          if k.startswith("+"))
        print(f"[{i}/{len(files)}] {row['scene']:30s} {'dominant' if row['dominant'] else '        '}  {cells}",
              flush=True)
    summ = summary(rows, args.stops)
    print("\n".join(table(summ)))
    save_study({"scenes": "public" if args.public else str(args.hdri), "stops": args.stops, "rule": args.rule,
                "fold_models": args.fold_models, "hdr_fold_models": args.hdr_fold_models, "summary": summ,
                "rows": rows}, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
