"""The evaluation's report: eval.md (per-ev tables, the summary, the dominant source's energy, the sun's
share, the adaptive model), eval.json and the speed/accuracy plot, from ``evaluation.run``'s result.

The plot needs matplotlib (the ``plot`` extra: ``pip install -e '.[plot]'``); without it the report is
written without the picture and says how to get it.
"""
from __future__ import annotations

import json
from pathlib import Path

from .evaluation import BASELINES

PLOT_HINT = "speed_accuracy.png needs matplotlib: pip install -e '.[plot]' (scripts/setup.sh installs it)"


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
    flipped = sorted({r["scene"] for r in result["rows"] if r.get("scale_defined") is False})
    if flipped:
        out += [f"m-RMSE's median scale flips on {', '.join(flipped)}: the truth's radiance at this order has a "
                f"negative median (its source rings), so EVALUATION.md's s = median(G) / median(Q) compares a "
                f"sign-flipped estimate there, naive's too (`metrics.scale_defined`).", ""]
    out += ["## Summary", "", "Baselines (ambient, naive) are projections; other estimators are scored as their whole "
            "model (lights + SH). Harmed (EVALUATION.md, first): scenes whose m-RMSE is over both 2x and + 0.25 "
            "naive's. Wins: scenes whose m-RMSE beats naive's.", "",
            "| estimator | ev | harmed | mean m-RMSE | median m-RMSE | median m-RMSE of hdr.exr | mean irr-RMSE | "
            "median irr-RMSE | wins vs naive | mean sun angle (5 sun scenes) | median ms |",
            "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for m in result["summary"].values():
        wins = "n/a" if m.get("wins_vs_naive") is None else f"{m['wins_vs_naive']}/{len(s['scenes'])}"
        hurt = m.get("harmed")
        hurt = "n/a" if hurt is None else f"{len(hurt)}" + (f" ({', '.join(hurt)})" if hurt else "")
        out.append(f"| {m['estimator']} | {m['ev']:+g} | {hurt} | {m['mean_m_rmse']:.3f} | {m['median_m_rmse']:.3f} | "
                   f"{_fmt(m.get('median_hdri_m_rmse'))} | {m['mean_irr_rmse']:.3f} | {m['median_irr_rmse']:.3f} | {wins} | "
                   f"{_fmt(m['mean_sun_angle_deg'], 1)} | {m['median_ms']:.1f} |")
    out += _markdown_dominant(result) + _markdown_spheres(result)
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


def _markdown_spheres(result: dict) -> list[str]:
    """The three-sphere protocol's medians per estimator and ev (``lighting.spheres``)."""
    rows = [m for m in result["summary"].values() if m.get("spheres")]
    if not rows:
        return []
    out = ["", "## Three spheres (the published tables' protocol)", "",
           "Diffuse, matte-silver and mirror spheres rendered under the estimate (in the HDR's units) and under the "
           "truth; medians over the scenes of the scale-invariant RMSE (over the truth sphere's RMS) and the RGB angular "
           "error in degrees. A different data set from the published ones: the naive rows give the scale.", "",
           "| estimator | ev | diffuse si-RMSE | angular | matte si-RMSE | angular | mirror si-RMSE | angular |",
           "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for m in rows:
        cells = [f"{m['spheres'][n]['si_rmse']:.3f} | {m['spheres'][n]['angular_deg']:.1f}"
                 for n in ("diffuse", "matte", "mirror")]
        out.append(f"| {m['estimator']} | {m['ev']:+g} | " + " | ".join(cells) + " |")
    return out


def _markdown_dominant(result: dict) -> list[str]:
    """Per scene with a dominant source: the energy ratio r of each estimator with an hdr.exr, per ev
    (EVALUATION.md; 1 is exact, 0.02 a vanished sun), then the summary line per estimator and ev."""
    s = result["settings"]
    rows = [r for r in result["rows"] if r.get("dominant") and r.get("energy_ratio") is not None]
    if not rows:
        return []
    names = [n for n in s["estimators"] if any(r["estimator"] == n for r in rows)]
    out = ["", "## The dominant source's energy and shadow (EVALUATION.md; scenes with a dominant compact source)", "",
           "cells: energy ratio r on hdr.exr (1 exact) / shadow contrast C estimated / true (lit over shadow of a "
           "surface facing the true source) / direction error of the brightest explicit light in degrees", "",
           "| scene | ev | " + " | ".join(names) + " |", "|---|---:|" + "---:|" * len(names)]
    for scene in s["scenes"]:
        for ev in s["evs"]:
            cells = [next((f"{r['energy_ratio']:.3g} / {_fmt(r.get('contrast'), 2)} of {_fmt(r.get('true_contrast'), 2)} / "
                           f"{_fmt(r['light_angle_deg'], 1)}" for r in rows
                           if r["scene"] == scene and r["ev"] == ev and r["estimator"] == n), "n/a") for n in names]
            if any(c != "n/a" for c in cells):
                out.append(f"| {scene} | {ev:+g} | " + " | ".join(cells) + " |")
    out += ["", "| estimator | ev | scenes | median direction error | energy within | worst r | contrast within | "
                "worst C / C_true |", "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for m in result["summary"].values():
        if m["estimator"] in names and m.get("dominant_energy_within") is not None:
            out.append(f"| {m['estimator']} | {m['ev']:+g} | {m['dominant_scenes']} | "
                       f"{_fmt(m['dominant_median_angle_deg'], 1)} | {m['dominant_energy_within']:.2f}x | "
                       f"{m['dominant_energy_worst']:.3g} | {_fmt(m.get('dominant_contrast_within'), 2)}x | "
                       f"{_fmt(m.get('dominant_contrast_worst'), 3)} |")
    return out


def plot(result: dict, path) -> bool:
    """Speed/accuracy scatter: median ms per panorama against mean m-RMSE and irr-RMSE, per ev. False (and
    nothing written) when matplotlib is not installed."""
    try:
        import matplotlib
    except ImportError:
        return False

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
    return True


def write(result: dict, out_dir) -> list[Path]:
    """Write eval.md, eval.json and speed_accuracy.png (when matplotlib is there; else eval.md says how to get
    it) into ``out_dir``; returns the paths written."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / "eval.md", out / "eval.json"]
    plotted = plot(result, out / "speed_accuracy.png")
    text = markdown(result) + ("\n" + markdown_adaptive(result["adaptive"]) if result.get("adaptive") else "")
    if not plotted:
        text += f"\n({PLOT_HINT})\n"
    paths[0].write_text(text, encoding="utf-8")
    kept = {**result, "rows": [{k: v for k, v in r.items() if k != "spheres"} for r in result["rows"]]}  # the
    # spheres' medians are in the summary; per row they would double the file
    paths[1].write_text(json.dumps(kept, indent=2) + "\n", encoding="utf-8")
    return paths + ([out / "speed_accuracy.png"] if plotted else [])
