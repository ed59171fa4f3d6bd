"""Do no harm (issue 58): decisions that price being wrong, scored out of fold by harmed scenes first.

For every scene of ../shared/data/hdri with an un-clipped truth, at each ev, the camera JPEG (EVALUATION.md, q90)
is estimated as the shipped per-source model (of the scene's fold, which never saw it) and key lights do, under
each variant, and the recovered work map is scored as ``training.keylight.rules`` scores it (m-RMSE at lmax 2,
as a ratio to the naive map's; harmed: EVALUATION.md's "Harm", ``metrics.harmed``). Variants:

- ``shipped``: the default as it ships: the fill's decision (``sources.choose_shrink``) keeps, of its candidates,
  only those that harm no truth within the prediction's 68 % range (every region at mu - sigma, mu, mu + sigma
  together), then takes the least expected error: a minimax guard over the range, expected loss inside it, never
  bolder than the expected loss alone;
- ``expected``: the decision by the least expected error alone (the rule before issue 58);
- ``bounded:Z``: the shipped guard over the truths at Z standard deviations (Z 1 ships);
- ``quantile:P``: every region reports the P quantile of its predicted log ratio (mu + z_P sigma, at least 0):
  the decision of least expected pinball loss when an over-estimate costs (1 - P) / P times an under-estimate;
- a variant followed by ``+sky-sun``: a sun the photo does not show is put back where its sky's gradient alone
  places it (``--sky-sun``; the default before issue 58); by ``+key-decided``: no key light carries more than its
  regions' decided energy; by ``+as-before``: a clear-sky sun whose evidence disagrees weighed as before the shipped
  rule (``keylight.weighing.when_disagreeing``); with it, ``+key-agree``: any clear-sky sun whose fit's 68 % range lies
  wholly above the trees' carries no more than its regions' decided energy, ``+trusted-agree``: only a trusted one
  (the fit's floor), ``+trusted-untrust``: a trusted one weighed as untrusted (no floor, no cap); with
  ``--clipped``, ``+lamps-decided``: a restored plateau's key light with no clear-sky fit takes the decided fill's
  energy, not the trees' mean (``lamps_decided``).

    python -m training.experiments.do_no_harm --fold-models 'runs/folds/sources_{k}.safetensors' --out runs/harm.json \
        [--variants expected+sky-sun expected shipped bounded:1.5 quantile:0.2]
    python -m training.experiments.do_no_harm --clipped 4 --variants expected+as-before shipped   # an HDR clipped 4 stops over
    python -m training.experiments.do_no_harm --clipped 4 --variants shipped --fold-models 'runs/folds/sources_{k}.safetensors' \
        --hdr-fold-models 'runs/hdr/all8/sources_{k}.safetensors'   # ... out of fold
"""
from __future__ import annotations

import contextlib
import statistics
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from pathlib import Path
from statistics import NormalDist

import numpy as np

from panolight_core import metrics, sh, threads
from panolight_core.camera import auto_exposure, hdr_to_ldr, ldr_to_linear
from panolight_core.estimators import keylight, sources
from panolight_core.estimators.keylight import weighing
from panolight_core.estimators.sources import decision, recovery
from panolight_core.estimators.sources.fill import cap_log_ratios, fill_with_keys
from panolight_core.lighting import spheres
from panolight_core.pipeline import fit_radiance
from training.common.real_hdri import clipped_truth, load_hdr, scene_files
from training.common.study import (
    fold_model_paths,
    fold_of,
    real_hdri_parser,
    restoring_fold_models_option,
    save_study,
    scene_models,
)

VARIANTS = ("expected+sky-sun", "expected", "shipped", "bounded:1.5", "bounded:2", "quantile:0.16", "quantile:0.3")


@contextlib.contextmanager
def decision_rule(rule: str):
    """The fill's decision ``recover`` uses under a variant's first part, for the ``with`` block: "shipped";
    "expected" (the least expected error alone, no harm guard: the rule before issue 58); "bounded:Z" (the guard
    over the truths at -Z, 0, +Z standard deviations); "quantile:P"."""
    saved = recovery.choose_shrink, recovery.shrunk, decision.harmless, decision.HARM_RANGE_Z
    name, _, arg = rule.partition(":")
    if name == "expected":
        decision.harmless = lambda m_rmse: np.ones(len(m_rmse), bool)
    elif name == "bounded":
        decision.HARM_RANGE_Z = (-float(arg), 0.0, float(arg))
    elif name == "quantile":
        z = NormalDist().inv_cdf(float(arg))
        recovery.choose_shrink = lambda *a, **k: (0.0, {})
        recovery.shrunk = lambda mu, sigma, c: np.maximum(mu + z * sigma, 0.0)
    elif name != "shipped":
        raise ValueError(f"unknown decision {rule!r}")
    try:
        yield
    finally:
        recovery.choose_shrink, recovery.shrunk, decision.harmless, decision.HARM_RANGE_Z = saved


@contextlib.contextmanager
def disagreement(shipped: bool):
    """Within it, a clear-sky sun whose evidence disagrees is weighed as shipped (``weighing.when_disagreeing``), or
    as before it (``shipped`` False: the variant ``+as-before``)."""
    saved = weighing.when_disagreeing
    if not shipped:
        weighing.when_disagreeing = lambda energy, *rest, **kw: energy
    try:
        yield
    finally:
        weighing.when_disagreeing = saved


@contextlib.contextmanager
def lamps_decided(on: bool):
    """Within it (``on``: the variant ``+lamps-decided``), a restored plateau's key light without a clear-sky fit (a
    lamp, a window, a fixture) takes the decided fill's energy, as a photo's does, and only a clear-sky sun its
    belief (``weighing.key_energy`` with ``belief``: the trees' mean for a lamp)."""
    saved = weighing.key_energy
    if on:
        def key_energy(physical, learned, decided, trusted, params=keylight.PARAMS):
            if params.belief and physical is None:
                return decided
            return saved(physical, learned, decided, trusted, params)

        weighing.key_energy = key_energy
    try:
        yield
    finally:
        weighing.key_energy = saved


def agreeing(k, rec):
    """``+key-agree``: a clear-sky sun whose fit's 68 % range lies wholly above the trees' (their high end under the
    fit's low end) carries at most its regions' decided energy; any other light as it is."""
    if k.region < 0 or k.physical is None:
        return k
    high = rec.regions.added_energy(rec.mu + rec.sigma, [k.region, *k.parts])
    return k if high >= k.physical / keylight.PARAMS.sky_spread else replace(k, energy=min(k.energy, k.decided))


def untrusting(k, rec):
    """``+trusted-untrust``: a trusted clear-sky sun (its fit's floor and cap) whose fit's 68 % range lies wholly
    above the trees' is weighed as an untrusted one (``keylight.key_energy``: its fit capped at the larger of the
    trees' mean and the decided fill, no floor) and its regions keep their decided fill (no cap)."""
    if k.region < 0 or k.physical is None or k.cap is None:
        return k
    high = rec.regions.added_energy(rec.mu + rec.sigma, [k.region, *k.parts])
    if high >= k.physical / keylight.PARAMS.sky_spread:
        return k
    return replace(k, energy=keylight.key_energy(k.physical, k.learned, k.decided, False), cap=None)


def score(hdr: np.ndarray, ev: float, model, variants=VARIANTS) -> dict:
    """One scene at one ev: naive's and each variant's [m-RMSE, irr-RMSE], the key lights' sources, and the
    three-sphere protocol of the published tables (``lighting.spheres``: diffuse, matte-silver and mirror spheres
    under the estimate and the truth; naive's and each variant's model, lights and SH)."""
    ds = metrics.dominant_source(hdr)
    gt = sh.project(hdr, 2)
    ldr = hdr_to_ldr(hdr, ev, 90, robust=True)
    unit = 1.0 / auto_exposure(hdr, ev, robust=True)  # the camera's clip units in the HDR's
    true_spheres = spheres.render_spheres(spheres.environment_from_panorama(hdr))
    naive = sh.project(ldr_to_linear(ldr), 2)
    maps = sources.work_maps(ldr)
    row = {"ev": ev, "dominant": bool(ds["dominant"]), "naive": [metrics.m_rmse(gt, naive), metrics.irr_rmse(gt, naive)],
           "scale_defined": metrics.scale_defined(gt), "variants": {}, "keys": {},
           "spheres": {"naive": spheres.model_scores(true_spheres, naive, [], unit)}}
    for variant in variants:
        rule, *extras = variant.split("+")
        with decision_rule(rule):
            rec = sources.recover(ldr, model, maps=maps)
        params = replace(keylight.PARAMS, sky_alone_sun="sky-sun" in extras)
        with disagreement("as-before" not in extras):
            keys = keylight.find_key_lights(maps, rec.regions, (rec.mu, rec.sigma, rec.log_ratio), params)
        if "key-agree" in extras:
            keys = [agreeing(k, rec) for k in keys]
        if "trusted-agree" in extras:  # the same, for a trusted sun only (the fit's floor), any other as it is
            keys = [agreeing(k, rec) if k.cap is not None else k for k in keys]
        if "trusted-untrust" in extras:  # a trusted sun the trees disagree with weighed as an untrusted one
            keys = [untrusting(k, rec) for k in keys]
        if "key-decided" in extras:
            keys = [replace(k, energy=min(k.energy, k.decided)) if k.region >= 0 else k for k in keys]
            keys = [k for k in keys if k.energy > 0]
        work = fill_with_keys(maps[0], rec.regions, cap_log_ratios(rec.regions, rec.log_ratio, keys), keys)[1]
        fitted = fit_radiance(work, hdr_input=False)
        q = fitted.project(2)
        row["variants"][variant] = [metrics.m_rmse(gt, q), metrics.irr_rmse(gt, q)]
        row["spheres"][variant] = spheres.model_scores(true_spheres, fitted.coeffs, fitted.lights, unit)
        row["keys"][variant] = [k.method.split(":")[0].split(" (")[0] for k in keys]
    return row


def score_clipped(hdr: np.ndarray, stops: float, variants=VARIANTS, estimator: str = "auto") -> dict:
    """An HDR file clipped 2^``stops`` over the ev-0 exposure's white (as a merge without an ND filter clips its sun),
    estimated whole as ``panolight estimate`` does (restored: by the shipped HDR model, or ``estimator``, a fold's
    registered one) under each variant's decision and key-light rule: the model's [m-RMSE, irr-RMSE] at lmax 2
    against the truth, and the file's own as "naive" (harm is against the file as it is)."""
    from panolight_core.pipeline.estimate import estimate_lighting
    from panolight_core.pipeline.settings import Settings

    ds = metrics.dominant_source(hdr)
    truth = hdr * auto_exposure(hdr, 0.0)
    gt = sh.project(truth, 2)
    pixels = np.minimum(truth, 2.0 ** stops).astype(np.float32)
    own = sh.project(pixels, 2)
    row = {"ev": stops, "dominant": bool(ds["dominant"]), "naive": [metrics.m_rmse(gt, own), metrics.irr_rmse(gt, own)],
           "scale_defined": metrics.scale_defined(gt), "variants": {}, "keys": {}}
    for variant in variants:
        rule, *extras = variant.split("+")
        with decision_rule(rule), disagreement("as-before" not in extras), lamps_decided("lamps-decided" in extras):
            res = estimate_lighting(pixels, Settings(estimator=estimator, sky_sun="sky-sun" in extras))
        q = res.model.project(2)
        row["variants"][variant] = [metrics.m_rmse(gt, q), metrics.irr_rmse(gt, q)]
        row["keys"][variant] = [str(light.get("source", "exact")).split(":")[0].split(" (")[0]
                                for light in res.document["lights"]]
    return row


def _scene_job(args):
    path, evs, model_path, variants, clipped, hdr_model_path = args
    if clipped is not None:
        estimator = "auto"
        if hdr_model_path:  # the scene's fold: its photo model and the HDR model that restores (never saw it)
            from panolight_core.estimators import register_source_model

            estimator = register_source_model("keylight-fold", model_path, key_lights=True, hdr_path=hdr_model_path)
        return [dict(score_clipped(load_hdr(Path(path)), clipped, variants, estimator), scene=Path(path).stem)]
    from panolight_core.estimators.sources import load_source_model

    model = load_source_model(model_path) if model_path else load_source_model()
    hdr = load_hdr(Path(path))
    return [dict(score(hdr, ev, model, variants), scene=Path(path).stem) for ev in evs]


def summary(rows: list[dict], variants) -> dict:
    """Per variant: harmed scenes (first), m-RMSE / naive median and mean over every scene and over those with a
    dominant source, and the harmed scenes' names; and the same counts over the scenes whose truth m-RMSE's median
    scale is defined for (``metrics.scale_defined``; "defined")."""
    out = {}
    for v in variants:
        ratio = [r["variants"][v][0] / r["naive"][0] for r in rows]
        dom = [r["variants"][v][0] / r["naive"][0] for r in rows if r["dominant"]]
        harmed = [r["scene"] for r in rows if metrics.harmed(r["variants"][v][0], r["naive"][0])]
        ok = [r for r in rows if r.get("scale_defined", True)]
        dom_ok = [r["variants"][v][0] / r["naive"][0] for r in ok if r["dominant"]]
        out[v] = {"harmed": len(harmed), "scenes": len(rows), "m_rmse_median": statistics.median(ratio),
                  "m_rmse_mean": statistics.mean(ratio), "dominant": len(dom),
                  "dominant_median": statistics.median(dom) if dom else None,
                  "dominant_mean": statistics.mean(dom) if dom else None, "harmed_scenes": harmed,
                  "defined": {"scenes": len(ok), "harmed": sum(metrics.harmed(r["variants"][v][0], r["naive"][0])
                                                               for r in ok),
                              "dominant": len(dom_ok), "dominant_median": statistics.median(dom_ok) if dom_ok else None,
                              "dominant_mean": statistics.mean(dom_ok) if dom_ok else None},
                  "spheres": spheres.score_medians([r["spheres"][v] for r in rows if v in r.get("spheres", {})])}
    if rows and all("naive" in r.get("spheres", {}) for r in rows):  # the scale: the naive projection's row
        out["naive"] = {"spheres": spheres.score_medians([r["spheres"]["naive"] for r in rows])}
    return out


def sphere_table(summ: dict) -> str:
    """Markdown: per variant and the naive projection, the spheres' median RMSE, si-RMSE and RGB angular error."""
    lines = ["| estimate | diffuse RMSE / si-RMSE / angle | matte silver | mirror |", "|---|---|---|---|"]
    for name, x in summ.items():
        sp = x.get("spheres") or {}
        if sp:
            lines.append(f"| {name} | " + " | ".join(f"{sp[k]['rmse']:.3f} / {sp[k]['si_rmse']:.3f} / "
                                                     f"{sp[k]['angular_deg']:.1f} deg" for k in spheres.SPHERES) + " |")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = real_hdri_parser("python -m training.experiments.do_no_harm", __doc__)
    restoring_fold_models_option(ap)
    ap.add_argument("--variants", nargs="+", default=list(VARIANTS), metavar="VARIANT",
                    help="the variants to score (module doc; default: %(default)s)")
    ap.add_argument("--clipped", type=float, default=None, metavar="STOPS",
                    help="instead of camera JPEGs, each HDR clipped this many stops over its ev-0 white and restored "
                         "as panolight estimate does, harm against the file as it is: by the shipped HDR model (in "
                         "sample), or out of fold with --fold-models and --hdr-fold-models")
    ap.add_argument("--workers", type=int, default=2, help="processes, one scene each at a time (default 2)")
    ap.add_argument("--out", type=Path, default=None, help="write the rows and summary as JSON here")
    args = ap.parse_args(argv)
    files = scene_files(args.hdri)
    clipped = clipped_truth(args.hdri)
    model_of = scene_models(args.fold_models, files)
    if args.hdr_fold_models and not (args.fold_models and args.clipped is not None):
        ap.error("--hdr-fold-models restores the --clipped files out of fold: give --clipped and --fold-models too")
    hdr_paths = fold_model_paths(args.hdr_fold_models) if args.hdr_fold_models else {}
    hdr_of = {p: str(hdr_paths[k]) for p, k in fold_of(files).items()} if hdr_paths else {}
    jobs = [(str(p), list(args.evs), str(model_of[p].path) if args.fold_models else None, args.variants, args.clipped,
             hdr_of.get(p)) for p in files if p.name not in clipped]
    rows = []
    with ProcessPoolExecutor(args.workers, mp_context=threads.process_context()) as pool:
        for i, got in enumerate(pool.map(_scene_job, jobs), 1):
            rows += got
            for r in got:
                print(f"[{i}/{len(jobs)}] {r['scene']:28s} ev {r['ev']:+g}: naive {r['naive'][0]:.3f}  " + "  ".join(
                    f"{v} {r['variants'][v][0] / r['naive'][0]:.2f}x" for v in args.variants), flush=True)
    result = {"fold_models": args.fold_models, "summary": {}}
    print("| ev | variant | harmed | scenes | m-RMSE / naive, median / mean | dominant: median / mean "
          "| where the scale is "
          "defined: harmed, dominant median / mean | harmed scenes |")
    print("|---|---|---:|---:|---:|---:|---:|---|")
    for ev in ([args.clipped] if args.clipped is not None else args.evs):
        s = summary([r for r in rows if r["ev"] == ev], args.variants)
        result["summary"][f"{ev:+g}"] = s
        for v, x in s.items():
            if "harmed" in x:  # the naive projection's entry holds its spheres alone
                d = x["defined"]
                print(f"| {ev:+g} | `{v}` | {x['harmed']} | {x['scenes']} | {x['m_rmse_median']:.3f} / "
                      f"{x['m_rmse_mean']:.3f} | {x['dominant_median']:.3f} / {x['dominant_mean']:.3f} | "
                      f"{d['harmed']} of {d['scenes']}, {d['dominant_median']:.3f} / {d['dominant_mean']:.3f} | "
                      f"{', '.join(x['harmed_scenes'])} |")
    if args.clipped is None:  # the three-sphere protocol, beside the published tables' (a different data set)
        for ev in args.evs:
            print(f"\nthe three spheres at ev {ev:+g} (medians; RMSE and si-RMSE over the truth sphere's RMS):")
            print(sphere_table(result["summary"][f"{ev:+g}"]))
    save_study(dict(result, rows=rows), args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
