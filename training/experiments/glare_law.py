"""The glare law around clipped regions over the real HDRs: how well the glare a compact source leaves in the
unclipped ring weighs it, and why it cannot be trusted (docs/keylight.md, "A better per-region prediction: tried,
not kept").

For every scene of ../shared/data/hdri at each ev: the camera JPEG (EVALUATION.md, q90), its regions and the
per-source trees' mu (``--fold-models``: each scene by the trees of its fold), and for each compact region (radius
<= COMPACT_DEG) its ring at 512 rows: the fine clipped radius r (the farthest pixel white in every channel within the
region's radius + 1.5 degrees), the background (the median luminance r + 12 to r + 16 degrees out, unclipped pixels)
and the excess over it r + 1.4 to r + 6 degrees out, in four annuli and in eight sectors. A point source of energy E
(clip units x sr) leaves an excess c E theta^-2 (theta in radians); the study fits the one constant c over the
sources that matter (over DOMINANT_SHARE of their scene) and reports, with it:

- the glare law's and the trees' median |log error| of the energy over those sources;
- how many regions pass each gate that could tell a source from a lit wall or a speck beside one (the profile
  follows theta^-2; no larger region within 16 degrees; the excess alike in the eight sectors), real sources
  against regions holding under SMALL_SHARE of their scene;
- how many of the sources the trees weigh more than e^2 low pass them.

    python -m training.experiments.glare_law --fold-models 'runs/folds/sources_{k}.safetensors' [--out F.json]
    panolight dev glare-law ...                                                        # the same

About a minute here.
"""
from __future__ import annotations

import json
import math
import statistics
from pathlib import Path

import numpy as np

from panolight_core import sh
from panolight_core.camera import auto_exposure, hdr_to_ldr
from panolight_core.camera.color import LUMINANCE_WEIGHTS
from panolight_core.estimators.highlights import work_maps
from panolight_core.estimators.keylight import with_key_lights
from panolight_core.estimators.sources.features import cap_cells
from panolight_core.estimators.sources.recovery import recover
from training.common.real_hdri import load_hdr, scene_files
from training.common.study import fold_models_option, real_hdri_parser, scene_models
from training.source_energy.data import region_targets

HEIGHT = 512  # the ring is read at the training panoramas' resolution
COMPACT_DEG = 12.0
ANNULI_DEG = (1.4, 2.0, 3.0, 4.0, 6.0)  # beyond the fine clipped radius
BACKGROUND_DEG = (12.0, 16.0)
SECTORS = 8
NEIGHBOUR_DEG = 16.0  # a larger region nearer than this (beyond both radii) may be what the ring shows
DOMINANT_SHARE = 0.15
SMALL_SHARE = 0.05
GLARE_SLOPE = (-3.5, -1.5)  # log excess against log theta, for a profile that follows theta^-2
GLARE_SPREAD = 0.5  # the largest spread of log(excess theta^2) over the annuli
ISOTROPY = 0.5  # log of the 80th over the 20th percentile of the sectors' excess


def ring(lum, clear, white, dirs, centre, extent_deg: float) -> dict | None:
    """The glare ring of a region centred at unit ``centre`` with radius ``extent_deg``, from maps at HEIGHT rows:
    luminance (h, 2h), unclipped (h, 2h) bool, white (h, 2h) bool (every channel clipped), unit directions
    (h, 2h, 3). Returns {"radius_deg", "background", "log_c" (per annulus: log(excess x theta^2), theta in
    radians), "slope" (of log excess on log theta), "sectors" (excess per sector, NaN where too few pixels)}; None
    without a background or with under two annuli of positive excess."""
    cell = 180.0 / lum.shape[0]
    reach = min(extent_deg + 1.5 + BACKGROUND_DEG[1] + cell, 180.0)
    r0, r1, near, ang = cap_cells(dirs, centre, math.radians(reach))
    ang = np.degrees(ang)
    lu, cl, wh = lum[r0:r1][near], clear[r0:r1][near], white[r0:r1][near]
    core = wh & (ang < extent_deg + 1.5)
    radius = float(ang[core].max()) if core.any() else 0.5 * cell
    bg = cl & (ang >= radius + BACKGROUND_DEG[0]) & (ang < radius + BACKGROUND_DEG[1])
    if bg.sum() < 3:
        return None
    background = float(np.median(lu[bg]))
    log_c, log_t = [], []
    for lo, hi in zip(ANNULI_DEG[:-1], ANNULI_DEG[1:]):
        m = cl & (ang >= radius + lo) & (ang < radius + hi)
        excess = float(np.median(lu[m])) - background if m.sum() >= 3 else 0.0
        if excess > 0.002:
            t = math.radians(radius + 0.5 * (lo + hi))
            log_c.append(math.log(excess) + 2.0 * math.log(t))
            log_t.append(math.log(t))
    if len(log_c) < 2:
        return None
    slope = float(np.polyfit(log_t, np.array(log_c) - 2.0 * np.array(log_t), 1)[0])
    up = np.array([0.0, 0.0, 1.0]) if abs(centre[2]) < 0.99 else np.array([1.0, 0.0, 0.0])
    e1 = np.cross(up, centre)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(centre, e1)
    d = dirs[r0:r1][near]
    sector = (((np.arctan2(d @ e2, d @ e1) + math.pi) / (2.0 * math.pi) * SECTORS).astype(int)) % SECTORS
    band = cl & (ang >= radius + ANNULI_DEG[0]) & (ang < radius + ANNULI_DEG[-1])
    sectors = [float(np.median(lu[band & (sector == k)])) - background if (band & (sector == k)).sum() >= 3
               else float("nan") for k in range(SECTORS)]
    return {"radius_deg": radius, "background": background, "log_c": log_c, "slope": slope, "sectors": sectors}


def isotropy(sectors) -> float:
    """log of the 80th over the 20th percentile of the sectors' excess (inf where one is at or below the
    background, NaN with under five sectors measured)."""
    s = np.array([v for v in sectors if np.isfinite(v)])
    if s.size < 5:
        return float("nan")
    if (s <= 0).any():
        return float("inf")
    return float(np.log(np.percentile(s, 80) / np.percentile(s, 20)))


def scene_rows(ldr, truth, model) -> list[dict]:
    """One dict per compact region of a camera JPEG with a glare ring: its share of the truth's energy, the true log
    ratio, the trees' mu, held energy, radius, whether a larger region is near, how the default estimate weighs the
    key light it makes there (``key``: its method, None without one) and the ring (``ring``)."""
    rec = with_key_lights(recover(ldr, model))
    regions = rec.regions
    if regions.count == 0:
        return []
    target, share = region_targets(regions, truth)  # the recovery's own regions: no second work map
    rad, frac_any, frac_all = work_maps(ldr, HEIGHT)
    lum = rad @ LUMINANCE_WEIGHTS
    dirs = sh.pixel_directions(*lum.shape)
    extent = regions.extent_deg()
    key = {k.region: k.method for k in rec.keys}
    out = []
    for i in range(regions.count):
        if extent[i] > COMPACT_DEG:
            continue
        found = ring(lum, frac_any == 0, frac_all > 0, dirs, regions.centre[i], float(extent[i]))
        if found is None:
            continue
        gap = np.degrees(np.arccos(np.clip(regions.centre @ regions.centre[i], -1.0, 1.0))) - extent - extent[i]
        larger_near = bool(np.any((regions.clipped_sr > regions.clipped_sr[i]) & (gap < NEIGHBOUR_DEG)))
        out.append({"share": float(share[i]), "true": float(target[i]), "mu": float(rec.mu[i]),
                    "held": float(regions.held[i]), "extent_deg": float(extent[i]), "larger_near": larger_near,
                    "key": key.get(i), **found})
    return out


def summarise(rows: list[dict]) -> dict:
    """The law's constant (fitted over the sources that matter), its and the trees' errors there, and the gates'
    counts (see the module's text)."""
    dominant = [r for r in rows if r["share"] > DOMINANT_SHARE]
    if not dominant:
        return {"sources": 0}
    for r in rows:
        r["law"] = statistics.median(r["log_c"]) - math.log(max(r["held"], 1e-12))  # log(E c) - log held
    log_c = statistics.median(r["law"] - r["true"] for r in dominant)  # log c: the median over the sources
    for r in rows:
        r["glare"] = r["law"] - log_c  # the log ratio the law gives
        spread = max(r["log_c"]) - min(r["log_c"])
        r["glare_like"] = GLARE_SLOPE[0] < r["slope"] < GLARE_SLOPE[1] and spread < GLARE_SPREAD
        r["isotropy"] = isotropy(r["sectors"])

    def counts(gate) -> dict:
        passed = [r for r in rows if gate(r)]
        return {"sources": sum(r["share"] > DOMINANT_SHARE for r in passed),
                "small": sum(r["share"] < SMALL_SHARE for r in passed)}

    missed = [r for r in dominant if r["true"] - r["mu"] > 2.0]
    keys = [r for r in rows if (r["key"] or "").startswith("per-source")]  # the default's lamps (not skies)
    real_keys = [r for r in keys if r["share"] > DOMINANT_SHARE]
    other_keys = [r for r in keys if r["share"] < SMALL_SHARE]
    clean = (lambda r: r["glare_like"] and not r["larger_near"] and r["isotropy"] < ISOTROPY)
    return {
        "sources": len(dominant), "log_c": log_c,
        "glare_median_abs_error": statistics.median(abs(r["glare"] - r["true"]) for r in dominant),
        "trees_median_abs_error": statistics.median(abs(r["mu"] - r["true"]) for r in dominant),
        "small_median_error": statistics.median(r["glare"] - r["true"] for r in rows if r["share"] < SMALL_SHARE),
        "gates": {"glare-like, up to 8 deg, no larger region near":
                  counts(lambda r: r["glare_like"] and not r["larger_near"] and r["extent_deg"] <= 8.0),
                  "glare-like, no larger region near, isotropic": counts(clean)},
        "missed_by_trees": len(missed), "missed_passing_isotropic_gate": sum(clean(r) for r in missed),
        "per_source_key_lights": {
            "count": len(keys), "sources": len(real_keys), "small": len(other_keys),
            "sources_median_abs_error": statistics.median(abs(r["glare"] - r["true"]) for r in real_keys)
            if real_keys else None,
            "small_over_e2": sum(r["glare"] - r["true"] > 2.0 for r in other_keys)}}


def _finite(row: dict) -> dict:
    """``row`` with its infinite and NaN numbers (also in lists) as None: strict JSON."""
    def clean(v):
        if isinstance(v, float) and not math.isfinite(v):
            return None
        return [clean(x) for x in v] if isinstance(v, list) else v
    return {k: clean(v) for k, v in row.items()}


def main(argv=None) -> int:
    ap = real_hdri_parser("python -m training.experiments.glare_law", __doc__)
    fold_models_option(ap)
    ap.add_argument("--out", type=Path, default=None, help="also write the summary and every region's row as JSON")
    args = ap.parse_args(argv)
    files = scene_files(args.hdri)
    if not args.fold_models:
        print("glare-law: the shipped trees saw every scene: their error here is in sample (use --fold-models)")
    model_of = scene_models(args.fold_models, files)
    rows = []
    for n, path in enumerate(files, 1):
        hdr = load_hdr(path)
        for ev in args.evs:
            found = scene_rows(hdr_to_ldr(hdr, ev, 90), auto_exposure(hdr, ev) * hdr, model_of[path])
            rows += [{"scene": path.stem, "ev": ev, **r} for r in found]
        if n % 10 == 0 or n == len(files):
            print(f"  {n}/{len(files)} scenes, {len(rows)} compact regions with a ring")
    summary = summarise(rows)
    if not summary["sources"]:
        print(f"glare-law: no compact region with a ring holds more than {DOMINANT_SHARE:g} of its scene: nothing to fit")
        return 1
    print(f"the law c E theta^-2 over {summary['sources']} sources (over {DOMINANT_SHARE:g} of their scene): "
          f"log c = {summary['log_c']:.2f}; median |log error| {summary['glare_median_abs_error']:.2f} "
          f"(the trees: {summary['trees_median_abs_error']:.2f}); regions under {SMALL_SHARE:g}: median error "
          f"{summary['small_median_error']:+.2f}")
    for gate, c in summary["gates"].items():
        print(f"  {gate}: {c['sources']} sources pass, {c['small']} regions under {SMALL_SHARE:g}")
    print(f"  sources the trees weigh more than e^2 low: {summary['missed_by_trees']}, of which "
          f"{summary['missed_passing_isotropic_gate']} pass the isotropic gate")
    k = summary["per_source_key_lights"]
    if k["sources"]:
        print(f"  the default's {k['count']} compact per-source key lights: the law weighs the {k['sources']} sources "
              f"within e^{k['sources_median_abs_error']:.2f} (median) and {k['small_over_e2']} of the {k['small']} "
              f"regions under {SMALL_SHARE:g} more than e^2 too strong")
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps({"summary": summary, "rows": [_finite(r) for r in rows]}, indent=1))
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
