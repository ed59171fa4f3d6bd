"""Leave-scenes-out cross-validation of the per-source energy model (``source_energy cv``)."""
from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from panolight_core import metrics, sh
from panolight_core.camera import hdr_to_ldr, ldr_to_linear
from panolight_core.estimators import sources
from panolight_core.estimators.highlights import recover_highlights
from panolight_core.estimators.sources.features import region_features
from panolight_core.estimators.sources.regions import WIDE_CONCENTRATION
from panolight_core.pipeline import fit_radiance
from training.common.folds import scene_folds

EVS = (-2.0, 0.0, 2.0)


def score_scene(hdr: np.ndarray, variants: dict, evs=EVS, jpeg: int = 90) -> list[dict]:
    """EVALUATION.md on one HDR: rows of (ev, estimator, m_rmse, irr_rmse). variants: name ->
    function(ldr, truth_exposed) -> radiance map (or 'naive'/'analytic' builtins)."""
    gt = sh.project(hdr, 2)
    rows = []
    for ev in evs:
        ldr = hdr_to_ldr(hdr, ev, jpeg, robust=True)
        for name, fn in variants.items():
            if name == "naive":
                q = sh.project(ldr_to_linear(ldr), 2)
            else:
                q = fit_radiance(fn(ldr), hdr_input=False).project(2)  # what panolight estimate writes
            rows.append({"ev": ev, "estimator": name, "m_rmse": metrics.m_rmse(gt, q),
                         "irr_rmse": metrics.irr_rmse(gt, q)})
    return rows


SHRINKS = (0.0,)
WIDE_CONCENTRATIONS = (0.0, 1.0, 2.0, 3.0)  # profile of wide regions' excess (the decision's guard and tolerance
# were chosen by earlier runs: min_median_ratio 0.1 and tolerance 0.05)
DECIDED = f"learned (decision, wide regions q = {sources.WIDE_CONCENTRATION:g})"  # what the estimator reports


def recover_variant(ldr, model=None, log_ratio_fn=None, wide_concentration: float = WIDE_CONCENTRATION):
    """``sources.recover`` with a study's variant: another ratio function ``log_ratio_fn(regions) -> (mu, sigma,
    reported)`` (no decision then), or the regions' wide-profile exponent ``wide_concentration``
    (``Regions.shape_exponents``). Through ``sources.assemble``, the core's lower-level entry point."""
    maps = sources.work_maps(ldr)
    regions = region_features(*maps, wide_concentration=wide_concentration)
    if log_ratio_fn is not None:
        return sources.assemble(maps, regions, log_ratio_fn(regions))
    return sources.assemble(maps, regions, *sources.decide(maps[0], regions, model or sources.load_source_model()))


def power_law_log_ratio(regions):
    """The physical model alone as a region ratio (the learned model's yardstick): the power law's gain
    over the clipped area, no spread."""
    gain = 10.0 ** regions.feature("log_power_law_gain")
    ratio = (regions.held + (gain - 1.0) * regions.clipped_sr) / np.maximum(regions.held, 1e-30)
    lr = np.log(np.maximum(ratio, 1.0))
    return lr, np.zeros_like(lr), lr


def variant_label(shrink: float) -> str:
    return "learned (mu)" if shrink == 0 else f"learned (mu - {shrink:g} s2)"


def fold_variants(model: sources.SourceModel, shrinks=SHRINKS, quick: bool = False) -> dict:
    """Estimators to score on a fold's held-out scenes: name -> (ldr -> work map), None for naive; quick:
    naive and the shipped rule (DECIDED) only."""
    def learned(shrink):
        def run(ldr):
            def fn(reg):
                mu, sigma, _ = model.predict(reg.features)
                return mu, sigma, np.maximum(mu - shrink * sigma ** 2, 0.0)
            return recover_variant(ldr, log_ratio_fn=fn).work
        return run

    def decided(q):
        def run(ldr):
            return recover_variant(ldr, model, wide_concentration=q).work
        return run

    def coarse(rows, clipped_excess):
        """The shipped rule's work map averaged to ``rows`` (the network's 64: what a network correcting the
        per-source model starts from), plus ``clipped_excess`` x the any-channel clipped fraction."""
        def run(ldr):
            from panolight_core.camera.resample import area_downsample
            from panolight_core.estimators.highlights import work_maps

            work = sources.recover(ldr, model).work
            work = area_downsample(work, rows) if work.shape[0] > rows else work
            if clipped_excess:
                work = work + clipped_excess * work_maps(ldr, work.shape[0])[1][..., None]
            return work
        return run

    if quick:
        return {"naive": None, DECIDED: decided(sources.WIDE_CONCENTRATION)}
    return {"naive": None,
            "analytic": lambda ldr: recover_highlights(ldr, 64)[0],
            "sources at 64 rows": coarse(64, 0.0),
            "sources + 0.05 clipped": coarse(sources.WORK_HEIGHT, 0.05),
            "sources at 64 rows + 0.05 clipped (the untrained network)": coarse(64, 0.05),
            "power-law regions": lambda ldr: recover_variant(ldr, log_ratio_fn=power_law_log_ratio).work,
            **{variant_label(c): learned(c) for c in shrinks},
            **{f"learned (decision, wide regions q = {q:g})": decided(q) for q in WIDE_CONCENTRATIONS}}


def cross_validate(files, X, y, w, g, args, fit, load_hdr):
    """Leave-scenes-out folds over the region table (X, y, w, g: source_energy.build_table), scored by
    EVALUATION.md on each held-out scene. fit and load_hdr: source_energy's (passed in, so this module
    does not import the one that runs it)."""
    folds = scene_folds(len(files), args.folds, args.seed)
    rows = []
    t0 = time.perf_counter()
    for k, test in enumerate(folds):
        train = ~np.isin(g, test)
        mean, spread, _ = fit(X[train], y[train], w[train], args.seed, g[train])
        model = sources.SourceModel(mean, spread, 1.0, sources.FEATURES, {}, Path("fold"))
        pred = mean.predict(X[~train])
        variants = fold_variants(model, quick=getattr(args, "quick", False))
        for i in test:
            hdr = load_hdr(files[i])
            for r in score_scene(hdr, variants):
                rows.append(dict(r, scene=files[i].stem, fold=k))
        rmse = float(np.sqrt(np.average((pred - y[~train]) ** 2, weights=w[~train])))
        print(f"fold {k + 1}/{len(folds)}: {len(test)} scenes, held-out log-ratio RMSE {rmse:.3f} "
              f"({time.perf_counter() - t0:.0f} s)")
    from training.source_energy.report import table

    print("\n".join(table(rows, list(dict.fromkeys(r["estimator"] for r in rows)), EVS)))
    out = Path(args.out or "docs/studies/source_energy_cv.json")
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"rows": rows, "shipped": DECIDED,
                               "augment": args.augment, "seed": args.seed,
                               "folds": [[files[i].stem for i in f] for f in folds]}, indent=1) + "\n",
                   encoding="utf-8")
    print(f"wrote {out}")
    return rows
