"""The EVALUATION.md protocol on the eight Blender studio HDRIs, for every available estimator.

For each scene and ev: ground truth = exact projection of the HDR (lmax 2); input = the camera model's
8-bit LDR, JPEG q90 by default (EVALUATION.md's reference numbers reproduce to two decimals only with
JPEG inputs: without it sunset's naive m-RMSE is 0.3447, not 0.35). The baselines (ambient, naive) are
scored as EVALUATION.md defines them (a projection); every other estimator as what ``panolight
estimate`` writes by default, the whole model (explicit lights as disks + the auto-order SH, projected
to lmax; ``adaptive.LightingModel.project``). Each row has m-RMSE, irr-RMSE, the dominant-light angle
and the sun's share of the irradiance facing it (true and estimated; sun scenes), and the estimator's
time (median of ``repeats`` runs on the in-memory LDR, decode excluded: the decode-inclusive figure is
in training/benchmarks/bench_estimate.py). The estimated light direction is the first light's peak
direction, else the brightest direction of the model's radiance (256 x 128 grid); a constant estimate
(ambient) has none.
"""
from __future__ import annotations

import json
import math
import statistics
import time
from pathlib import Path

import numpy as np

from .. import metrics, sh
from ..camera import hdr_to_ldr
from ..camera.color import LUMINANCE_WEIGHTS
from ..data import STUDIO_HDRIS, load_studio_hdri
from ..estimators import available, estimate
from ..pipeline import fit_estimate

SUN_SCENES = ("city", "courtyard", "forest", "sunrise", "sunset")
BASELINES = ("ambient", "naive")
SUN_CONE_DEG = 3.0  # the true sun: pixels within this angle of the dominant direction, above their ring


def true_sun_share(hdr: np.ndarray, direction) -> float:
    """Share of the irradiance facing ``direction`` that comes from the source there: the pixels within
    SUN_CONE_DEG, less the median of the ring out to twice that (HDR ground truth)."""
    h, w = hdr.shape[:2]
    dirs = sh.pixel_directions(h, w)
    omega = sh.pixel_solid_angles(h, w)
    d = np.asarray(direction, dtype=np.float64)
    cos = dirs @ d
    ang = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    lum = np.asarray(hdr, dtype=np.float64) @ LUMINANCE_WEIGHTS
    ring = (ang > SUN_CONE_DEG) & (ang < 2 * SUN_CONE_DEG)
    bg = float(np.median(lum[ring])) if ring.any() else 0.0
    core = ang <= SUN_CONE_DEG
    sun = float((np.maximum(lum[core] - bg, 0.0) * omega[core] * np.maximum(cos[core], 0.0)).sum())
    total = float((lum * omega * np.maximum(cos, 0.0)).sum())
    return sun / total if total > 0 else 0.0


def model_sun_share(model, direction) -> float | None:
    """Share of the model's irradiance facing ``direction`` carried by its first (brightest) light."""
    if not model.lights:
        return 0.0
    from ..lighting.lights import light_irradiance

    n = np.asarray(direction, dtype=np.float64)[None]
    sun = float(light_irradiance(model.lights[:1], n)[0] @ LUMINANCE_WEIGHTS)
    total = float(model.irradiance(n)[0] @ LUMINANCE_WEIGHTS)
    return sun / total if total > 0 else None




def estimated_direction(coeffs: np.ndarray):
    """Brightest direction of the SH radiance on a 256 x 128 grid; None for a constant map."""
    c = np.asarray(coeffs, dtype=np.float64)
    if not np.any(c[1:]):
        return None
    lum = sh.reconstruct(c, metrics.GRID_H, metrics.GRID_W) @ LUMINANCE_WEIGHTS
    iy, ix = np.unravel_index(np.argmax(lum), lum.shape)
    return sh.pixel_directions(metrics.GRID_H, metrics.GRID_W)[iy, ix]


def run(scenes=STUDIO_HDRIS, evs=(-2.0, 0.0, 2.0), estimators=None, lmax: int = 2, jpeg_quality=90,
        repeats: int = 3, log=None) -> dict:
    """Evaluate; returns {"rows": [...], "summary": {...}, "settings": {...}}."""
    log = log or (lambda msg: None)
    estimators = list(estimators or available())
    rows = []
    for scene in scenes:
        hdr = load_studio_hdri(scene)
        gt = sh.project(hdr, lmax)
        true_dir = metrics.dominant_light_direction(hdr)
        true_share = true_sun_share(hdr, true_dir)
        dominant = metrics.dominant_source(hdr)["dominant"]  # EVALUATION.md: >= 15 % within 5 degrees
        for ev in evs:
            ldr = hdr_to_ldr(hdr, ev, jpeg_quality)
            for name in estimators:
                times = []
                for _ in range(max(1, repeats)):
                    t = time.perf_counter()
                    est = estimate(ldr, lmax, name)
                    if name not in BASELINES:  # what panolight estimate writes by default
                        model = fit_estimate(est, hdr_input=False)
                    times.append(time.perf_counter() - t)
                if name in BASELINES:
                    coeffs, share, d = est.coeffs, None, estimated_direction(est.coeffs)
                else:
                    coeffs = model.project(lmax)
                    share = model_sun_share(model, true_dir) if scene in SUN_SCENES else None
                    d = np.asarray(model.lights[0]["peak_direction"]) if model.lights else estimated_direction(coeffs)
                hdri_m = ratio = None
                if getattr(est, "recovery", None) is not None:  # hdr.exr, scored by its own exact projection
                    from ..pipeline.hdri import hdr_panorama

                    pano = hdr_panorama(ldr, est)
                    hdri_m = metrics.m_rmse(gt, sh.project(pano, lmax))
                    if dominant:  # the dominant source's energy ratio, on hdr.exr at the truth's resolution
                        ratio = metrics.source_energy_ratio(hdr, pano, true_dir)
                rows.append({"scene": scene, "ev": ev, "estimator": name, "hdri_m_rmse": hdri_m,
                             "m_rmse": metrics.m_rmse(gt, coeffs), "irr_rmse": metrics.irr_rmse(gt, coeffs),
                             "light_angle_deg": None if d is None else metrics.angle_deg(true_dir, d),
                             "sun_share": share, "true_sun_share": true_share if scene in SUN_SCENES else None,
                             "dominant": bool(dominant), "energy_ratio": ratio,
                             "ms": 1e3 * statistics.median(times)})
            log(f"{scene} ev {ev:+g}: " + ", ".join(
                f"{r['estimator']} {r['m_rmse']:.3f}" for r in rows if r["scene"] == scene and r["ev"] == ev))
    summary = {}
    for name in estimators:
        for ev in evs:
            sel = [r for r in rows if r["estimator"] == name and r["ev"] == ev]
            angles = [r["light_angle_deg"] for r in sel if r["light_angle_deg"] is not None and r["scene"] in SUN_SCENES]
            naive = {r["scene"]: r for r in rows if r["estimator"] == "naive" and r["ev"] == ev}
            summary[f"{name}@{ev:+g}"] = {
                "estimator": name, "ev": ev,
                "mean_m_rmse": float(np.mean([r["m_rmse"] for r in sel])),
                "median_m_rmse": float(np.median([r["m_rmse"] for r in sel])),
                "mean_irr_rmse": float(np.mean([r["irr_rmse"] for r in sel])),
                "median_irr_rmse": float(np.median([r["irr_rmse"] for r in sel])),
                "median_hdri_m_rmse": (float(np.median([r["hdri_m_rmse"] for r in sel]))
                                       if sel and all(r.get("hdri_m_rmse") is not None for r in sel) else None),
                "wins_vs_naive": (sum(r["m_rmse"] < naive[r["scene"]]["m_rmse"] for r in sel if r["scene"] in naive)
                                  if naive else None),
                "mean_sun_angle_deg": float(np.mean(angles)) if angles else None,
                **_dominant_summary(sel),
                "median_ms": float(statistics.median([r["ms"] for r in sel]))}
    return {"rows": rows, "summary": summary,
            "settings": {"scenes": list(scenes), "evs": list(evs), "estimators": estimators, "lmax": lmax,
                         "jpeg_quality": jpeg_quality, "repeats": repeats}}


def _dominant_summary(rows: list[dict]) -> dict:
    """EVALUATION.md's dominant-source figures over the rows of scenes with one: the median direction
    error, the energy ratio's median |log2 r| as "within 2^x", and the worst r (furthest from 1)."""
    dom = [r for r in rows if r.get("dominant")]
    ratios = [r["energy_ratio"] for r in dom if r.get("energy_ratio") is not None and r["energy_ratio"] > 0]
    angles = [r["light_angle_deg"] for r in dom if r.get("light_angle_deg") is not None]
    logs = [abs(math.log2(v)) for v in ratios]
    return {"dominant_scenes": len(dom),
            "dominant_median_angle_deg": float(np.median(angles)) if angles else None,
            "dominant_energy_within": float(2 ** np.median(logs)) if logs else None,
            "dominant_energy_worst": max(ratios, key=lambda v: abs(math.log2(v))) if ratios else None}


EXACT_ORDER = 24  # "exact" irradiance: A_l at l = 24 is 2e-4 of A_0, far below the errors compared


def score_lighting(hdr: np.ndarray, coeffs: np.ndarray, lights, ldr_linear: np.ndarray) -> dict:
    """Diffuse relighting error (irr-RMSE, metrics.GRID) of a lighting model (SH coeffs + lights) against
    the HDR's exact irradiance, beside the naive lmax 2 projection of the linearised LDR it came from."""
    from ..lighting.adaptive import LightingModel

    grid = (metrics.GRID_H, metrics.GRID_W)
    truth = sh.irradiance_map(sh.project(hdr, EXACT_ORDER), *grid)
    ours = LightingModel(lights, coeffs).irradiance_map(*grid)
    naive = sh.irradiance_map(sh.project(ldr_linear, 2), *grid)
    return {"irr_rmse": metrics.irr_rmse_maps(truth, ours), "naive_irr_rmse": metrics.irr_rmse_maps(truth, naive)}


def run_adaptive(scenes=STUDIO_HDRIS, log=None) -> list[dict]:
    """The adaptive model (lights + auto order) against a fixed lmax 2, on the HDR inputs.

    Both are scored with irr-RMSE against the exact irradiance of the HDR (its SH irradiance at order
    EXACT_ORDER; lights render analytically, so an lmax-2 ground truth would understate them). Reports
    the lights found, the order and deringing chosen and why, the sun direction (the peak of the first
    light: lights are found brightest peak first) against EVALUATION.md's dominant direction, parameter
    counts and evaluation time.
    """
    from ..lighting.adaptive import fit_model

    log = log or (lambda msg: None)
    rows = []
    normals = sh.pixel_directions(256, 512).reshape(-1, 3)
    for scene in scenes:
        hdr = load_studio_hdri(scene)
        truth = sh.irradiance_map(sh.project(hdr, EXACT_ORDER), metrics.GRID_H, metrics.GRID_W)
        true_dir = metrics.dominant_light_direction(hdr)
        t = time.perf_counter()
        model = fit_model(hdr)
        fit_s = time.perf_counter() - t
        fixed = fit_model(hdr, lights=False, lmax=2, deringing="none")
        times = {}
        for name, m in (("adaptive", model), ("fixed", fixed)):
            m.irradiance(normals)
            t = time.perf_counter()
            m.irradiance(normals)
            times[name] = time.perf_counter() - t
        strongest = model.lights[0] if model.lights else None  # lights come brightest peak first
        rows.append({
            "scene": scene, "sun_scene": scene in SUN_SCENES,
            "lights": [{"type": l["type"], "angle_deg": float(np.degrees(l["angle"])), "intensity": l["intensity"],
                        "direction": l["direction"], "peak_direction": l["peak_direction"]} for l in model.lights],
            "n_lights": len(model.lights), "light_types": [l["type"] for l in model.lights],
            "energy_fraction_in_lights": model.info["lights"]["energy_fraction"],
            "why_no_light": model.info["lights"].get("why_none"),
            "lmax": model.info["order"]["lmax"], "deringed": model.info["ringing"]["window"] is not None,
            "sun_angle_deg": None if strongest is None else metrics.angle_deg(true_dir, strongest["peak_direction"]),
            "irr_rmse_adaptive": metrics.irr_rmse_maps(truth, model.irradiance_map(metrics.GRID_H, metrics.GRID_W)),
            "irr_rmse_fixed_lmax2": metrics.irr_rmse_maps(truth, fixed.irradiance_map(metrics.GRID_H, metrics.GRID_W)),
            "params_adaptive": model.parameter_count, "params_fixed_lmax2": fixed.parameter_count,
            "eval_ms_adaptive": 1e3 * times["adaptive"], "eval_ms_fixed_lmax2": 1e3 * times["fixed"],
            "fit_ms": 1e3 * fit_s})
        r = rows[-1]
        log(f"adaptive {scene}: {r['n_lights']} light(s), lmax {r['lmax']}, irr-RMSE {r['irr_rmse_adaptive']:.4f} "
            f"(fixed lmax 2: {r['irr_rmse_fixed_lmax2']:.4f})")
    return rows


def markdown_adaptive(rows: list[dict]) -> str:
    out = ["## Adaptive model (HDR inputs): lights + the order each scene needs, against fixed lmax 2", "",
           "irr-RMSE against the exact irradiance (SH order 24); eval ms = irradiance at 131072 normals; "
           "sun angle = the peak of the first (brightest-peaked) light against EVALUATION.md's dominant direction.", "",
           "| scene | lights (types) | energy in lights | lmax | deringed | sun angle | irr-RMSE adaptive | "
           "irr-RMSE fixed lmax 2 | params | eval ms | fit ms |",
           "|---|---|---:|---:|---|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        lights = ", ".join(r["light_types"]) if r["light_types"] else f"none ({r['why_no_light']})"
        out.append(f"| {r['scene']}{' (sun)' if r['sun_scene'] else ''} | {lights} | {r['energy_fraction_in_lights']:.0%} | "
                   f"{r['lmax']} | {'yes' if r['deringed'] else 'no'} | {_fmt(r['sun_angle_deg'], 2)} | "
                   f"{r['irr_rmse_adaptive']:.4f} | {r['irr_rmse_fixed_lmax2']:.4f} | {r['params_adaptive']} vs "
                   f"{r['params_fixed_lmax2']} | {r['eval_ms_adaptive']:.1f} vs {r['eval_ms_fixed_lmax2']:.1f} | "
                   f"{r['fit_ms']:.0f} |")
    return "\n".join(out) + "\n"


def _fmt(v, digits=3):
    return "n/a" if v is None else f"{v:.{digits}f}"


def markdown(result: dict) -> str:
    """Per-ev tables (scene x estimator, m-RMSE / irr-RMSE / light angle) plus a summary table."""
    s = result["settings"]
    out = [f"# PanoLight evaluation (lmax {s['lmax']}, {'JPEG q' + str(s['jpeg_quality']) if s['jpeg_quality'] else '8-bit PNG-like'} "
           f"inputs, EVALUATION.md protocol)", ""]
    for ev in s["evs"]:
        out += [f"## ev {ev:+g}", "", "| scene | " + " | ".join(s["estimators"]) + " |",
                "|---|" + "---:|" * len(s["estimators"])]
        for scene in s["scenes"]:
            cells = []
            for name in s["estimators"]:
                r = next(r for r in result["rows"] if r["scene"] == scene and r["ev"] == ev and r["estimator"] == name)
                cells.append(f"{r['m_rmse']:.2f} / {r['irr_rmse']:.2f} / {_fmt(r['light_angle_deg'], 1)}")
            out.append(f"| {scene} | " + " | ".join(cells) + " |")
        means = [result["summary"][f"{n}@{ev:+g}"] for n in s["estimators"]]
        out.append("| **mean** | " + " | ".join(f"**{m['mean_m_rmse']:.3f} / {m['mean_irr_rmse']:.3f}**" for m in means) + " |")
        out += ["", "cells: m-RMSE / irr-RMSE / dominant-light angle in degrees (lower is better)", ""]
    out += ["## Summary", "", "Baselines (ambient, naive) are projections; other estimators are scored as their whole "
            "model (lights + SH). Wins: scenes whose m-RMSE beats naive's.", "",
            "| estimator | ev | mean m-RMSE | median m-RMSE | median m-RMSE of hdr.exr | mean irr-RMSE | "
            "median irr-RMSE | wins vs naive | mean sun angle (5 sun scenes) | median ms |",
            "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for m in result["summary"].values():
        wins = "n/a" if m.get("wins_vs_naive") is None else f"{m['wins_vs_naive']}/{len(s['scenes'])}"
        out.append(f"| {m['estimator']} | {m['ev']:+g} | {m['mean_m_rmse']:.3f} | {m['median_m_rmse']:.3f} | "
                   f"{_fmt(m.get('median_hdri_m_rmse'))} | {m['mean_irr_rmse']:.3f} | {m['median_irr_rmse']:.3f} | {wins} | "
                   f"{_fmt(m['mean_sun_angle_deg'], 1)} | {m['median_ms']:.1f} |")
    out += _markdown_dominant(result)
    shares = [r for r in result["rows"] if r.get("true_sun_share") is not None and r.get("sun_share") is not None]
    if shares:
        out += ["", "## The sun's share of the irradiance facing it (sun scenes; true / estimated)", "",
                "| scene | ev | " + " | ".join(n for n in s["estimators"] if n not in BASELINES) + " |",
                "|---|---:|" + "---:|" * len([n for n in s["estimators"] if n not in BASELINES])]
        for scene in s["scenes"]:
            for ev in s["evs"]:
                cells = [next((f"{r['true_sun_share']:.0%} / {r['sun_share']:.0%}" for r in shares
                               if r["scene"] == scene and r["ev"] == ev and r["estimator"] == n), "n/a")
                         for n in s["estimators"] if n not in BASELINES]
                if any(c != "n/a" for c in cells):
                    out.append(f"| {scene} | {ev:+g} | " + " | ".join(cells) + " |")
    return "\n".join(out) + "\n"


def _markdown_dominant(result: dict) -> list[str]:
    """Per scene with a dominant source: the energy ratio r of each estimator with an hdr.exr, per ev
    (EVALUATION.md; 1 is exact, 0.02 a vanished sun), then the summary line per estimator and ev."""
    s = result["settings"]
    rows = [r for r in result["rows"] if r.get("dominant") and r.get("energy_ratio") is not None]
    if not rows:
        return []
    names = [n for n in s["estimators"] if any(r["estimator"] == n for r in rows)]
    out = ["", "## The dominant source's energy (EVALUATION.md: r = 1 exact; scenes with a dominant compact source)", "",
           "cells: energy ratio r on hdr.exr / direction error of the brightest explicit light in degrees", "",
           "| scene | ev | " + " | ".join(names) + " |", "|---|---:|" + "---:|" * len(names)]
    for scene in s["scenes"]:
        for ev in s["evs"]:
            cells = [next((f"{r['energy_ratio']:.3g} / {_fmt(r['light_angle_deg'], 1)}" for r in rows
                           if r["scene"] == scene and r["ev"] == ev and r["estimator"] == n), "n/a") for n in names]
            if any(c != "n/a" for c in cells):
                out.append(f"| {scene} | {ev:+g} | " + " | ".join(cells) + " |")
    out += ["", "| estimator | ev | scenes | median direction error | energy within | worst r |", "|---|---:|---:|---:|---:|---:|"]
    for m in result["summary"].values():
        if m["estimator"] in names and m.get("dominant_energy_within") is not None:
            out.append(f"| {m['estimator']} | {m['ev']:+g} | {m['dominant_scenes']} | "
                       f"{_fmt(m['dominant_median_angle_deg'], 1)} | {m['dominant_energy_within']:.2f}x | "
                       f"{m['dominant_energy_worst']:.3g} |")
    return out


def plot(result: dict, path) -> None:
    """Speed/accuracy scatter: median ms per panorama against mean m-RMSE and irr-RMSE, per ev."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = result["settings"]["estimators"]
    many = len(names) > 10  # the learned variants: a 20-colour map keeps every estimator distinct
    fig, axes = plt.subplots(1, 2, figsize=(12 if many else 10, 4.5 if many else 4), dpi=110)
    markers = {-2.0: "v", 0.0: "o", 2.0: "^"}
    for ax, key, label in ((axes[0], "mean_m_rmse", "mean m-RMSE"), (axes[1], "mean_irr_rmse", "mean irr-RMSE")):
        for i, name in enumerate(names):
            color = plt.get_cmap("tab20")(i % 20) if many else f"C{i}"
            for ev in result["settings"]["evs"]:
                m = result["summary"][f"{name}@{ev:+g}"]
                ax.scatter(m["median_ms"], m[key], color=color, marker=markers.get(ev, "s"), s=50,
                           label=f"{name}" if ev == result["settings"]["evs"][0] else None)
        ax.set_xscale("log")
        ax.set_xlabel("median ms per panorama (1024 x 512, in memory)")
        ax.set_ylabel(label + " (lower is better)")
        ax.grid(True, which="both", alpha=0.3)
    if many:
        axes[1].legend(title="estimator (v ev-2, o ev0, ^ ev+2)", fontsize=7, loc="center left", bbox_to_anchor=(1.02, 0.5))
    else:
        axes[0].legend(title="estimator (v ev-2, o ev0, ^ ev+2)", fontsize=8)
    fig.suptitle("Speed against accuracy on the eight Blender studio HDRIs")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def write(result: dict, out_dir) -> list[Path]:
    """Write eval.md, eval.json and speed_accuracy.png into ``out_dir``; returns their paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    text = markdown(result) + ("\n" + markdown_adaptive(result["adaptive"]) if result.get("adaptive") else "")
    (out / "eval.md").write_text(text, encoding="utf-8")
    (out / "eval.json").write_text(json.dumps(result, indent=2) + "\n", encoding="utf-8")
    plot(result, out / "speed_accuracy.png")
    return [out / "eval.md", out / "eval.json", out / "speed_accuracy.png"]
