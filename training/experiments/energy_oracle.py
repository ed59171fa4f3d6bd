"""Experiment, not shipped: how much of a restored HDR's error is its key light's energy, and whether the two
estimates of a clear-sky sun's energy could be combined better (issue 45; docs/studies/captures.md, "What holds
the +4-stop bars").

For each real HDR of ``../shared/data/hdri`` with a dominant compact source and an un-clipped truth, clipped at
+STOPS over the ev-0 JPEG's white and restored (the default) by the fold models that never saw it:
- its m-RMSE (lmax 2) over the clipped file's own projection, as shipped;
- the same with the brightest light's intensity divided by the scene's energy ratio r (the oracle: the key light
  given the truth's energy), and with the best of 97 factors from 1/64 to 64 (a lower bound);
- for a clear-sky sun within 5 deg of the truth's direction, the ratio r its two estimates would give alone: the
  trees' mean (``KeyLight.learned``) and the sky fit's (``KeyLight.physical``), each r x estimate / the light's
  energy (the light dominates the 5-degree cone), then the median |log2 r| of w x the trees' + (1 - w) x the
  fit's in log, for fixed w and for inverse-variance weights (the trees' sigma, a fixed spread for the fit).

A third estimate, from the ground (``--ground``, over a saved run's rows; no fold models): an outdoor file's ground
stays linear under a clipped sun, and a white ground in sun against one in shadow is G = 1 + E_sun / E_sky on a
horizontal surface. ``ground_contrast`` reads G as the two means of a 2-means split of the lower hemisphere's log
luminance, the sun's irradiance then (G - 1) x the sky's, set against the truth's.

    python -m training.experiments.energy_oracle --fold-models 'runs/cmp/new/sources_{k}.safetensors' \\
        --hdr-fold-models 'runs/hdr/all8/sources_{k}.safetensors' [--stops 4] [--out energy_oracle.json]
    python -m training.experiments.energy_oracle --ground docs/studies/energy_oracle.json
"""
from __future__ import annotations

import argparse
import copy
import math
import statistics
import sys
from pathlib import Path

import numpy as np

from panolight_core import metrics, sh
from panolight_core.camera import auto_exposure
from panolight_core.camera.color import luminance
from panolight_core.pipeline.estimate import estimate_lighting
from panolight_core.pipeline.settings import Settings
from training.common.real_hdri import DEFAULT_HDRI, load_hdr, manifest
from training.common.study import restoring_estimators, restoring_fold_models_option, save_study, study_files

FACTORS = np.geomspace(1.0 / 64.0, 64.0, 97)
WEIGHTS = (0.0, 0.25, 0.4, 0.5, 0.6, 0.75, 1.0)  # the trees' weight in log; 0.5 is the geometric mean that ships
FIT_SIGMAS = (0.4, math.log(2.0), 1.0, 1.5)  # the sky fit's spread (natural log) for inverse-variance weights


def scene_row(path: Path, stops: float = 4.0, estimator: str = "auto") -> dict | None:
    """One scene's shipped, oracle and best m-RMSE over its own projection, its r, and its brightest key light's
    two estimates (None where a scene has no dominant source)."""
    hdr = load_hdr(path)
    ds = metrics.dominant_source(hdr)
    if not ds["dominant"]:
        return None
    truth = hdr * auto_exposure(hdr, 0.0)
    pixels = np.minimum(truth, 2.0 ** stops).astype(np.float32)
    res = estimate_lighting(pixels, Settings(estimator=estimator))
    gt = sh.project(truth, 2)
    own = metrics.m_rmse(gt, sh.project(pixels, 2))
    r = metrics.source_energy_ratio(truth, res.hdr_panorama(pixels), ds["direction"])
    row = {"scene": path.stem, "r": r, "shipped": metrics.m_rmse(gt, res.model.project(2)) / own}
    if not res.model.lights:
        return row
    model = copy.deepcopy(res.model)
    i = max(range(len(model.lights)), key=lambda j: model.lights[j]["intensity"])
    base = res.model.lights[i]["intensity"]

    def scored(factor: float) -> float:
        model.lights[i]["intensity"] = base * factor
        return metrics.m_rmse(gt, model.project(2)) / own

    row.update(oracle=scored(1.0 / max(r, 1e-9)), best=min(scored(f) for f in FACTORS))
    keys = res.estimate.recovery.keys if res.estimate.recovery is not None else []
    if keys:
        key = max(keys, key=lambda k: k.energy)
        row.update(key_angle_deg=metrics.angle_deg(key.direction, ds["direction"]), method=key.method,
                   trees_r=r * key.learned / key.energy,
                   fit_r=None if key.physical is None else r * key.physical / key.energy,
                   trees_sigma=float(res.estimate.recovery.sigma[key.region]) if key.region >= 0 else None)
    return row


GROUND_BAND_DEG = (-70.0, -10.0)  # the ground read: elevations clear of the horizon's haze and of the tripod


def ground_contrast(hdr: np.ndarray, direction) -> dict:
    """An outdoor HDR (H, W, 3) whose dominant source is at the unit ``direction`` (world frame, +Z up): the lit /
    shadowed contrast G its ground reads (the two means of a 2-means split of the log luminance at GROUND_BAND_DEG,
    solid-angle weighted), the truth's G = 1 + E_sun / E_sky on a horizontal surface (the sun: the source's cone
    less its ring, ``metrics.true_sun_share``'s), and the ratio of the sun's irradiance G gives to the truth's."""
    h, w = hdr.shape[:2]
    dirs, omega = sh.pixel_directions(h, w), sh.pixel_solid_angles(h, w)
    lum = luminance(np.asarray(hdr, dtype=np.float64))
    d = np.asarray(direction, dtype=np.float64)
    horizontal = float((lum * omega * np.maximum(dirs[..., 2], 0.0)).sum())
    sun_normal = metrics.true_sun_share(hdr, d, metrics.SOURCE_CONE_DEG) * float(
        (lum * omega * np.maximum(dirs @ d, 0.0)).sum())
    sun = sun_normal * max(float(d[2]), 0.0)
    true_g = 1.0 + sun / max(horizontal - sun, 1e-12)
    lo, hi = (math.sin(math.radians(a)) for a in GROUND_BAND_DEG)
    band = (dirs[..., 2] > lo) & (dirs[..., 2] < hi)
    logl, wt = np.log(np.maximum(lum[band], 1e-12)), omega[band]
    a, b = np.quantile(logl, [0.2, 0.8])
    for _ in range(50):
        dark = np.abs(logl - a) < np.abs(logl - b)
        if dark.all() or not dark.any():
            break
        a2, b2 = np.average(logl[dark], weights=wt[dark]), np.average(logl[~dark], weights=wt[~dark])
        if (a2, b2) == (a, b):
            break
        a, b = a2, b2
    g = math.exp(b - a)
    return {"ground_g": g, "true_g": true_g, "ground_r": (g - 1.0) / max(true_g - 1.0, 1e-12)}


def ground_rows(rows: list[dict], folder: Path) -> list[dict]:
    """``ground_contrast`` for each outdoor scene of a run's ``rows`` (MANIFEST kind), merged into a copy of its
    row."""
    listed = {Path(r["file"]).stem: r for r in manifest(folder)}
    out = []
    for row in rows:
        if listed.get(row["scene"], {}).get("kind") != "outdoor":
            continue
        hdr = load_hdr(folder / listed[row["scene"]]["file"])
        out.append({**row, **ground_contrast(hdr, metrics.dominant_source(hdr)["direction"])})
    return out


def with_ground(suns: list[dict], weights=(0.0, 0.15, 0.25, 1.0 / 3.0, 0.5, 1.0)) -> dict:
    """Median |log2 r| (as "within x") and the count off by more than 3x of the clear-sky suns placed within 5 deg
    when the ground's estimate takes ``weight`` in log and the shipped geometric mean of the trees' and the fit's
    the rest."""
    suns = [s for s in suns if s.get("fit_r") and s.get("key_angle_deg", 180.0) < 5.0]
    out = {"suns": len(suns)}
    for w in weights:
        errs = [abs((1.0 - w) * 0.5 * (math.log2(s["trees_r"]) + math.log2(s["fit_r"]))
                    + w * math.log2(max(s["ground_r"], 1e-12))) for s in suns]
        out[f"ground weight {w:.2f}"] = {"within": 2.0 ** statistics.median(errs) if errs else float("nan"),
                                         "over_3x": sum(e > math.log2(3.0) for e in errs)}
    return out


def combinations(rows: list[dict]) -> dict:
    """Median |log2 r| (as "within x") of the clear-sky suns placed within 5 deg, for each way of combining the
    trees' and the fit's estimates in log."""
    suns = [r for r in rows if r.get("fit_r") and r.get("key_angle_deg", 180.0) < 5.0]

    def within(weight_of) -> float:
        errs = [abs(weight_of(s) * math.log2(s["trees_r"]) + (1.0 - weight_of(s)) * math.log2(s["fit_r"]))
                for s in suns]
        return 2.0 ** statistics.median(errs) if errs else float("nan")

    out = {"suns": len(suns)}
    out.update({f"w={w:g}": within(lambda s, w=w: w) for w in WEIGHTS})
    out.update({f"inverse variance, fit sigma {f:.2f}": within(
        lambda s, f=f: (1.0 / s["trees_sigma"] ** 2) / (1.0 / s["trees_sigma"] ** 2 + 1.0 / f ** 2))
        for f in FIT_SIGMAS})
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m training.experiments.energy_oracle", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hdri", type=Path, default=DEFAULT_HDRI, help="folder of real HDR panoramas (default: %(default)s)")
    ap.add_argument("--stops", type=float, default=4.0, help="clip at 2^STOPS times the JPEG's white (default: 4)")
    restoring_fold_models_option(ap)
    ap.add_argument("--out", type=Path, default=None, help="write the rows and summary here (JSON)")
    ap.add_argument("--ground", type=Path, default=None, metavar="JSON",
                    help="read a saved run's rows and add the ground's estimate of each outdoor sun (no fold models)")
    args = ap.parse_args(argv)
    if args.ground:
        import json

        rows = ground_rows(json.loads(args.ground.read_text(encoding="utf-8"))["rows"], args.hdri)
        for r in rows:
            print(f"{r['scene']:28s} G ground {r['ground_g']:6.2f}  truth {r['true_g']:6.2f}  sun r {r['ground_r']:6.3f}")
        summ = {"outdoor": len(rows), "ground_alone_within": metrics.ratio_within(r["ground_r"] for r in rows),
                "ground_alone_over_3x": sum(abs(math.log2(max(r["ground_r"], 1e-12))) > math.log2(3.0) for r in rows),
                "combined": with_ground(rows)}
        print(f"the ground's sun alone, {len(rows)} outdoor scenes: within {summ['ground_alone_within']:.2f}x, "
              f"{summ['ground_alone_over_3x']} off by more than 3x")
        for name, v in summ["combined"].items():
            print(f"  clear-sky suns: {v}" if name == "suns" else f"  {name}: within {v['within']:.3f}x, "
                  f"{v['over_3x']} over 3x")
        save_study({"ground_of": str(args.ground), "band_deg": GROUND_BAND_DEG, "summary": summ, "rows": rows},
                   args.out)
        return 0
    files, skip = study_files(ap, args)
    estimator_of = restoring_estimators(args, files)
    rows = []
    for i, path in enumerate(files, 1):
        row = None if path.name in skip else scene_row(path, args.stops, estimator_of[path])
        if row is not None:
            rows.append(row)
            print(f"[{i}/{len(files)}] {row['scene']:28s} r {row['r']:7.3f}  m/own {row['shipped']:.3f}  "
                  f"oracle {row.get('oracle', row['shipped']):.3f}", flush=True)
    summ = {k: statistics.median(r.get(k, r["shipped"]) for r in rows) for k in ("shipped", "oracle", "best")}
    summ["scenes"] = len(rows)
    summ["combinations"] = combinations(rows)
    print(f"m-RMSE / own projection, median of {len(rows)}: shipped {summ['shipped']:.3f}, the key light at the "
          f"truth's energy {summ['oracle']:.3f}, at its best factor {summ['best']:.3f}")
    for name, v in summ["combinations"].items():
        print(f"  {name}: {v:.3f}" if name != "suns" else f"  clear-sky suns: {v}")
    save_study({"stops": args.stops, "fold_models": args.fold_models, "hdr_fold_models": args.hdr_fold_models,
                "summary": summ, "rows": rows}, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
