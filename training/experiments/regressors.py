"""The per-source model's trees against small networks, region by region, out of fold (docs/keylight.md, "A better
per-region prediction: tried, not kept").

The rows are the training table's (``data.cached_table``: every scene's augmented cameras, one row per clipped
region, its FEATURES and the natural log of true over held energy). Each regressor is fitted on four of the five
scene folds (``common.folds.scene_folds``, the assignment of every cross-validation here) and predicts the fifth, so no
scene is scored by a model that saw any of its cameras. Printed per group of rows: the weighted RMS and weighted
mean of the log-ratio error (prediction - truth, natural log; rows weighted as the trees are trained,
``fit.sample_weight``):

- **trees**: the shipped settings (``fit.fit_mean``);
- **networks**: ``--networks`` small networks (FEATURES -> 96 ReLU units -> 1, dropout 0.1, AdamW, Huber loss,
  the same row weights), averaged; inputs standardised and held to the training rows' range, so a photo unlike
  the training scenes cannot drive a network outside what it was fitted on;
- **average**: the mean of the two.

    python -m training.experiments.regressors [--table runs/table_s0.npz] [--networks 3] [--out F.json]
    panolight dev source-regressors ...                                              # the same

About 3 minutes here with the table cached (the trees take most of it); building the table takes 1 minute more.
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from panolight_core.estimators import sources
from training.common.folds import scene_folds
from training.common.real_hdri import DEFAULT_HDRI, scene_files
from training.source_energy.data import cached_table
from training.source_energy.fit import fit_mean, sample_weight

HIDDEN = 96
EPOCHS = 25
DOMINANT_SHARE = 0.15  # a region holding more of its scene's true energy is a source that matters
SMALL_SHARE = 0.05
COMPACT_DEG = 12.0


def fit_network(X: np.ndarray, y: np.ndarray, w: np.ndarray, seed: int = 0, epochs: int = EPOCHS) -> dict:
    """One small network fitted to rows (n, F), targets (n,) and weights (n,) -> its arrays (float64): input mean
    and scale, the standardised inputs' training range (lo, hi), and the two layers' weights and biases."""
    import torch
    import torch.nn as nn

    X = np.asarray(X, np.float64)
    mean, scale = X.mean(0), X.std(0) + 1e-6
    xs = (X - mean) / scale
    torch.manual_seed(seed)
    net = nn.Sequential(nn.Linear(X.shape[1], HIDDEN), nn.ReLU(), nn.Dropout(0.1), nn.Linear(HIDDEN, 1))
    opt = torch.optim.AdamW(net.parameters(), 1e-3, weight_decay=1e-3)
    sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, epochs)
    xt = torch.from_numpy(xs.astype(np.float32))
    yt = torch.from_numpy(np.asarray(y, np.float32))
    wt = torch.from_numpy(np.asarray(w, np.float32))
    for epoch in range(epochs):
        net.train()
        order = torch.from_numpy(np.random.default_rng([seed, epoch]).permutation(len(xt)))
        for b in range(0, len(order), 256):
            j = order[b:b + 256]
            loss = nn.functional.huber_loss(net(xt[j])[:, 0], yt[j], reduction="none", delta=2.0)
            loss = (wt[j] * loss).sum() / wt[j].sum()
            opt.zero_grad()
            loss.backward()
            opt.step()
        sched.step()
    arrays = [p.detach().numpy().astype(np.float64) for p in (net[0].weight, net[0].bias, net[3].weight, net[3].bias)]
    return {"mean": mean, "scale": scale, "lo": xs.min(0), "hi": xs.max(0),
            "w1": arrays[0].T, "b1": arrays[1], "w2": arrays[2].T, "b2": arrays[3]}


def network_predict(net: dict, X: np.ndarray) -> np.ndarray:
    """(n,) a network's (``fit_network``) prediction for rows (n, F), each input held to its training range."""
    xs = np.clip((np.asarray(X, np.float64) - net["mean"]) / net["scale"], net["lo"], net["hi"])
    return (np.maximum(xs @ net["w1"] + net["b1"], 0.0) @ net["w2"] + net["b2"])[:, 0]


def out_of_fold(X, y, w, scene, folds, networks: int = 3, log=print) -> dict:
    """{"trees", "networks", "average": (n,) predictions}: each row predicted by models fitted on the rows of the
    other folds' scenes. scene (n,): each row's scene index; folds: lists of scene indices (``common.folds.scene_folds``)."""
    out = {"trees": np.zeros_like(y), "networks": np.zeros_like(y)}
    t0 = time.perf_counter()
    for k, held in enumerate(folds, 1):
        test = np.isin(scene, held)
        if not test.any():
            continue
        train = ~test
        out["trees"][test] = fit_mean(X[train], y[train], w[train]).predict(X[test])
        nets = [fit_network(X[train], y[train], w[train], seed) for seed in range(networks)]
        out["networks"][test] = np.mean([network_predict(n, X[test]) for n in nets], axis=0)
        log(f"  fold {k}/{len(folds)}: {int(test.sum())} rows ({time.perf_counter() - t0:.0f} s)")
    out["average"] = 0.5 * (out["trees"] + out["networks"])
    return out


def row_groups(X: np.ndarray, share: np.ndarray) -> dict:
    """{name: (n,) bool} the groups of rows the table reports: all, the sources that matter (more than
    DOMINANT_SHARE of their scene), those that are compact (radius <= COMPACT_DEG), and the compact small ones."""
    extent = 10.0 ** X[:, sources.FEATURES.index("log_extent_deg")]
    compact = extent <= COMPACT_DEG
    return {"all regions": np.ones(len(X), bool), f"share > {DOMINANT_SHARE:g}": share > DOMINANT_SHARE,
            f"share > {DOMINANT_SHARE:g}, <= {COMPACT_DEG:g} deg": (share > DOMINANT_SHARE) & compact,
            f"share < {SMALL_SHARE:g}, <= {COMPACT_DEG:g} deg": (share < SMALL_SHARE) & compact}


def scores(pred: np.ndarray, y: np.ndarray, w: np.ndarray, groups: dict) -> dict:
    """{group: {"rows", "wrms", "wmean"}}: the weighted RMS and mean of pred - y over each group's rows."""
    err = pred - y
    out = {}
    for name, m in groups.items():
        ww = w[m]
        total = float(ww.sum())
        out[name] = {"rows": int(m.sum()),
                     "wrms": float(np.sqrt((ww * err[m] ** 2).sum() / total)) if total > 0 else float("nan"),
                     "wmean": float((ww * err[m]).sum() / total) if total > 0 else float("nan")}
    return out


def table(results: dict) -> str:
    """A markdown table of ``{regressor: scores(...)}``: weighted RMS (weighted mean) per group."""
    names = list(next(iter(results.values())))
    lines = ["| regressor | " + " | ".join(names) + " |", "|---|" + "---|" * len(names)]
    for reg, sc in results.items():
        lines.append(f"| {reg} | " + " | ".join(f"{sc[n]['wrms']:.3f} ({sc[n]['wmean']:+.2f})" for n in names) + " |")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hdri", default=str(DEFAULT_HDRI), help="folder of real HDR panoramas (default: %(default)s)")
    ap.add_argument("--table", type=Path, default=Path("runs/table_s0.npz"),
                    help="the cached training table (made if missing or stale; default: %(default)s, the one the "
                         "shipped and fold models are trained from)")
    ap.add_argument("--augment", type=int, default=16, help="random cameras per scene (default 16, as shipped)")
    ap.add_argument("--networks", type=int, default=3, help="networks averaged (default 3)")
    ap.add_argument("--out", type=Path, default=None, help="also write the scores as JSON")
    args = ap.parse_args(argv)
    if args.networks < 1:
        ap.error("--networks must be at least 1")
    files = scene_files(args.hdri)
    X, y, share, scene, _ = cached_table(args.table, files, args.augment, 0, 0.0)
    w = sample_weight(share)
    print(f"regressors: {len(files)} scenes, {len(y)} regions, 5 scene folds")
    preds = out_of_fold(X, y, w, scene, scene_folds(len(files), 5), args.networks)
    groups = row_groups(X, share)
    results = {"trees (shipped settings)": scores(preds["trees"], y, w, groups),
               f"{args.networks} networks averaged": scores(preds["networks"], y, w, groups),
               "trees and networks averaged": scores(preds["average"], y, w, groups)}
    print("out of fold: weighted RMS (weighted mean) of the log-ratio error, natural log")
    print(table(results))
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps({"table": str(args.table), "networks": args.networks, "scores": results},
                                       indent=1))
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
