"""docs/accuracy.md and docs/accuracy.png: real-photograph accuracy, from the two runs that measure it.

Inputs (regenerate them first):
    .venv/bin/panolight eval -o docs/eval                                   # public set -> docs/eval/eval.json
    .venv/bin/python -m training.source_energy.fit cv --out docs/studies/source_energy_cv.json   # 5-fold CV over the real HDRs
Then:
    .venv/bin/python -m training.source_energy.report [--estimator sources]

Every figure is a ratio to naive computed from the same rows, against issue 12's bars: median m-RMSE
<= 0.65x naive, mean <= 0.85x, mean irr-RMSE <= 0.75x, at least 6 of 8 public scenes better than naive,
and at ev -2/+2 a mean no worse than naive.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

BARS = {"median_m": 0.65, "mean_m": 0.85, "mean_irr": 0.75}


def ratios(rows, name, ev, key="m_rmse"):
    """(mean ratio, median ratio, wins, n) of estimator ``name`` against naive over the scenes of ``rows``."""
    mine = {r["scene"]: r[key] for r in rows if r["estimator"] == name and r["ev"] == ev}
    naive = {r["scene"]: r[key] for r in rows if r["estimator"] == "naive" and r["ev"] == ev}
    scenes = sorted(set(mine) & set(naive))
    a = np.array([mine[s] for s in scenes])
    b = np.array([naive[s] for s in scenes])
    return float(a.mean() / b.mean()), float(np.median(a) / np.median(b)), int((a < b).sum()), len(scenes)


def table(rows, names, evs) -> list[str]:
    out = ["| estimator | ev | mean m-RMSE | median m-RMSE | mean irr-RMSE | mean / naive | median / naive | "
           "irr mean / naive | wins vs naive |", "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for ev in evs:
        for name in names:
            sel = [r for r in rows if r["estimator"] == name and r["ev"] == ev]
            if not sel:
                continue
            m = np.array([r["m_rmse"] for r in sel])
            i = np.array([r["irr_rmse"] for r in sel])
            mr, md, wins, n = ratios(rows, name, ev)
            ir = ratios(rows, name, ev, "irr_rmse")[0]
            out.append(f"| {name} | {ev:+g} | {m.mean():.3f} | {np.median(m):.3f} | {i.mean():.3f} | {mr:.2f}x | "
                       f"{md:.2f}x | {ir:.2f}x | {wins}/{n} |")
    return out


def bars(rows, name) -> list[str]:
    out = ["| set | ev | median m / naive (<= 0.65) | mean m / naive (<= 0.85) | mean irr / naive (<= 0.75) | "
           "wins | met |", "|---|---:|---:|---:|---:|---:|---|"]
    for label, rs in rows.items():
        for ev in (-2.0, 0.0, 2.0):
            mr, md, wins, n = ratios(rs, name, ev)
            ir = ratios(rs, name, ev, "irr_rmse")[0]
            if ev == 0.0:
                ok = md <= BARS["median_m"] and mr <= BARS["mean_m"] and ir <= BARS["mean_irr"] and \
                    (label != "public" or wins >= 6)
            else:
                ok = mr <= 1.0
            out.append(f"| {label} | {ev:+g} | {md:.2f}x | {mr:.2f}x | {ir:.2f}x | {wins}/{n} | "
                       f"{'yes' if ok else 'no'} |")
    return out


# Changes to the per-source model measured by the same cross-validation and not kept: (what, how to
# re-measure, mean / median / irr-mean ratios to naive and wins at ev -2, 0, +2). The shipped rule's row
# comes from --cv.
TRIED = [
    ("synthetic compact sources (a 0.25-2 degree disk holding 5-300 % of the scene's energy, <= 10 % in a "
     "power-law halo) added to 35 % of the training cameras",
     "python -m training.source_energy.fit cv --quick --inject 0.35",
     ((0.78, 0.56, 0.78, 34), (0.79, 0.64, 0.73, 35), (0.83, 0.75, 0.75, 38))),
    ("a 30th feature: the sun a shadow implies, E_sky,h (lit / shadowed ground - 1) / cos(zenith), over "
     "the region's held energy (code not kept)",
     "(the feature in region_features, then) python -m training.source_energy.fit cv --quick",
     ((0.81, 0.66, 0.77, 35), (0.79, 0.62, 0.73, 40), (0.82, 0.76, 0.75, 42))),
]


def tried(cv_rows, name) -> list[str]:
    """The TRIED table beside the shipped rule's cross-validated row."""
    def cell(v, n):
        return f"{v[0]:.2f}x / {v[1]:.2f}x / {v[2]:.2f}x, {v[3]}/{n}"

    shipped = []
    for ev in (-2.0, 0.0, 2.0):
        mr, md, wins, n = ratios(cv_rows, name, ev)
        shipped.append((mr, md, ratios(cv_rows, name, ev, "irr_rmse")[0], wins))
    out = ["| change | ev -2 | ev 0 | ev +2 | command |", "|---|---|---|---|---|",
           f"| none (`{name}` as shipped) | {' | '.join(cell(v, n) for v in shipped)} | "
           "`python -m training.source_energy.fit cv` |"]
    out += [f"| {what} (over the first 50 scenes) | {' | '.join(cell(v, 50) for v in vals)} | `{cmd}` |"
            for what, cmd, vals in TRIED]
    return out


def plot(rows, name, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(rows), figsize=(5.2 * len(rows), 4.6), dpi=110)
    axes = np.atleast_1d(axes)
    colors = {-2.0: "C0", 0.0: "C3", 2.0: "C2"}
    for ax, (label, rs) in zip(axes, rows.items()):
        lim = [0.02, 8.0]
        for ev in (-2.0, 0.0, 2.0):
            mine = {r["scene"]: r["m_rmse"] for r in rs if r["estimator"] == name and r["ev"] == ev}
            naive = {r["scene"]: r["m_rmse"] for r in rs if r["estimator"] == "naive" and r["ev"] == ev}
            s = sorted(set(mine) & set(naive))
            ax.scatter([naive[k] for k in s], [mine[k] for k in s], s=18, color=colors[ev], label=f"ev {ev:+g}",
                       alpha=0.8)
        ax.plot(lim, lim, "k-", lw=0.8, label="= naive")
        ax.plot(lim, [0.65 * v for v in lim], "k:", lw=0.8, label="0.65x naive")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlim(lim)
        ax.set_ylim(lim)
        ax.set_xlabel("naive m-RMSE (per scene)")
        ax.set_ylabel(f"{name} m-RMSE (whole model)")
        ax.set_title(label)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("Per-scene m-RMSE against naive: below the diagonal is better")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--eval", default="docs/eval/eval.json", help="panolight eval's JSON (public set)")
    ap.add_argument("--cv", default="docs/studies/source_energy_cv.json", help="source_energy cv's JSON (the real HDRs)")
    ap.add_argument("--estimator", default="sources", help="the estimator the bars are checked for")
    ap.add_argument("--neural-cv", default="docs/studies/neural_cv.json",
                    help="training.neural.cv's merged JSON (the networks, leave-scenes-out over the 50)")
    ap.add_argument("--out", default="docs/accuracy.md")
    args = ap.parse_args(argv)
    public = json.loads(Path(args.eval).read_text())
    cv = json.loads(Path(args.cv).read_text())
    shipped = cv.get("shipped", "learned (mu - 0.5 s2)")  # the CV variant whose rule the shipped model uses
    cv_rows = [dict(r, estimator=args.estimator if r["estimator"] == shipped else r["estimator"]) for r in cv["rows"]]
    n_cv = len({r["scene"] for r in cv_rows})
    sets = {"public": public["rows"], f"cross-validation ({n_cv} real HDRs, 5 folds by scene)": cv_rows}
    out = Path(args.out)
    png = out.with_suffix(".png")
    lines = ["# Accuracy on real photographs", "",
             "Regenerated by `python -m training.source_energy.report` from `docs/eval/eval.json` "
             "(`panolight eval -o docs/eval`, the public set: Blender's eight HDRIs) and "
             f"`docs/studies/source_energy_cv.json` (`python -m training.source_energy.fit cv`, leave-scenes-out over the {n_cv} "
             "real HDRs of `../shared/data/hdri`). Inputs are EVALUATION.md's camera JPEGs (q90). Baselines are "
             "projections; the other estimators are scored as the whole model `panolight estimate` writes "
             "(lights + SH, projected to lmax 2).", "",
             f"## Issue 12's bars for `{args.estimator}`", "", *bars(sets, args.estimator), "",
             f"![per-scene m-RMSE against naive]({png.name})", ""]
    pub_names = public["settings"]["estimators"]
    lines += ["## Public set (Blender's eight HDRIs)", "", *table(public["rows"], pub_names, public["settings"]["evs"]),
              "", "Per-scene tables, the sun's share of irradiance and timings: [eval/eval.md](eval/eval.md).", ""]
    cv_names = list(dict.fromkeys(r["estimator"] for r in cv_rows))
    lines += [f"## Cross-validation over the {n_cv} real HDRs", "",
              "Five folds by whole scene (every camera of a test scene stays out of its training folds); each "
              "held-out scene scored at ev -2/0/+2. `learned (mu - c s2)` is the per-source model reporting "
              "exp(mu - c sigma^2); `power-law regions` is the physical glare model on the same regions. "
              f"`{args.estimator}` is the variant with the shipped rule ({shipped}).", "",
              *table(cv_rows, cv_names, (-2.0, 0.0, 2.0)), ""]
    folds = cv.get("folds")
    if folds:
        lines += ["Folds: " + "; ".join(f"{i + 1}: " + ", ".join(f) for i, f in enumerate(folds)), ""]
    ncv = Path(args.neural_cv)
    if ncv.is_file():
        nrows = json.loads(ncv.read_text())["rows"]
        names = list(dict.fromkeys(r["estimator"] for r in nrows))
        lines += ["## The learned estimators in the same cross-validation", "",
                  "The paper's networks trained five times, each without one fold's scenes, scored on them the same "
                  "way (`python -m training.neural.cv`, [learned.md](learned.md#trained-on-real-lighting)): "
                  "`eq5-hdr-pool-128` is the recipe of the shipped `neural` (a correction of the per-source model, "
                  "256 x 128 input, Eq. 5 relighting with the real HDRs); `analytic-guess` and `sources-guess` are the "
                  "first real-data runs (128 x 64 input, no Eq. 5 data); `sources (cross-validated)` is the per-source "
                  "model in that run, over the first 50 scenes it was then trained on (the rows above are over all "
                  f"{n_cv}).", "",
                  *table(nrows, names, (-2.0, 0.0, 2.0)), ""]
    lines += ["## Tried and not kept", "",
              "Changes to the per-source model scored by the same five folds (cells: mean / median m-RMSE and "
              "mean irr-RMSE as ratios to naive, then wins; the tries were measured when the model was trained on the "
              "first 50 scenes, over those 50). The injected sources help at ev -2 (median 0.65x "
              "-> 0.56x) but not at ev 0 or +2, and lose 5-6 wins at ev 0 and +2; an earlier draft of the same "
              "experiment (a pixel-level difference in how the smallest disks are drawn) scored 0.72x at ev -2 and "
              "0.77x / 0.65x, 36 wins at ev 0, so a refit moves these numbers by that much. The shadow feature "
              "moves every number by 0.02 or less.", "",
              *tried(cv_rows, args.estimator), ""]
    out.write_text("\n".join(lines) + "\n", encoding="utf-8")
    plot(sets, args.estimator, png)
    print(f"wrote {out} and {png}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
