"""The clear-sky sun's energy against the truth, by the sun's elevation: every un-clipped sun of the real HDRs.

``keylight`` weighs a clear-sky sun by the Hosek-Wilkie fit of the visible sky times SKY_CORRECTION, the median
true / physical of the dominant real suns (``training.keylight.cv``). Those suns are 10 degrees up or more, and
a sun nearer the horizon is what the real photos of low suns (dawns, sunsets, a field at evening) show. This study
takes every scene of ../shared/data/hdri whose MANIFEST ``sun`` column says it holds an un-clipped sun ("yes",
not a lower bound), dominant or not, and at each ev fits the clear sky of its camera JPEG (EVALUATION.md, q90) with
the sun at the TRUE direction (the luminance-weighted centroid of the brightest pixels,
``metrics.dominant_source``), so the sun's position is no error of its own. Each row: the elevation, the fit's
turbidity and whether it passes the cloudiness gate, and the truth's energy within 5 degrees over the fit's
corrected energy (SKY_CORRECTION x the fit's solar disk, in the same camera units): 1 is exact, 0.1 a sun the fit
makes 10x too strong.

    python -m training.keylight.sun_elevation [--evs -2 0 2] [--out docs/studies/sun_elevation.json]
"""
from __future__ import annotations

import statistics
from pathlib import Path

from panolight_core import metrics, sh
from panolight_core.camera import auto_exposure, hdr_to_ldr
from panolight_core.estimators import keylight, sources
from panolight_core.estimators import sky as clear_sky
from training.common.real_hdri import load_hdr, manifest
from training.common.study import real_hdri_parser, save_study

BANDS_DEG = (0.0, 10.0, 20.0, 45.0, 90.0)  # the summary's elevation bands


def manifest_suns(folder: Path) -> list[Path]:
    """The scene files whose MANIFEST ``sun`` column says they hold an un-clipped sun ("yes ..." without "lower
    bound"), in the manifest's order."""
    return [Path(folder) / row["file"] for row in manifest(folder)
            if row["sun"].startswith("yes") and "lower bound" not in row["sun"]]


def score_manifest_suns(folder: Path, evs, score, describe) -> list[dict]:
    """The rows ``score(hdr, evs)`` gives for each of ``manifest_suns(folder)``, each with its scene's name, printing
    one line per scene: ``describe(its rows)``."""
    rows = []
    files = manifest_suns(folder)
    for i, path in enumerate(files, 1):
        got = [dict(r, scene=path.stem) for r in score(load_hdr(path), evs)]
        rows += got
        print(f"[{i}/{len(files)}] {path.stem}: {describe(got)}", flush=True)
    return rows


def score_scene(hdr, evs) -> list[dict]:
    """One scene's rows (none where its brightest source is below the horizon): at each ev the clear-sky fit of
    the camera JPEG with the sun at the truth's direction, and the truth's cone energy over the fit's corrected."""
    ds = metrics.dominant_source(hdr)
    elevation = sh.elevation_deg(ds["direction"])
    if elevation <= 0:
        return []
    rows = []
    for ev in evs:
        rad, frac_any, frac_all = sources.work_maps(hdr_to_ldr(hdr, ev, 90))
        fit = clear_sky.fit_clear_sky(rad, frac_any == 0, frac_all > 0.5, ds["direction"])
        row = {"ev": ev, "elevation_deg": round(elevation, 2), "share": round(ds["share"], 4), "fit": fit is not None}
        if fit is not None:
            physical = keylight.PARAMS.sky_correction * fit.sun_energy
            row.update(turbidity=fit.turbidity, clear=bool(fit.clear), rms=round(fit.rms, 4),
                       true_over_physical=ds["energy"] * auto_exposure(hdr, ev) / physical if physical > 0 else None)
        rows.append(row)
    return rows


def summary(rows: list[dict]) -> list[dict]:
    """Per elevation band (BANDS_DEG): the fits that pass the gate, their median true / physical, and how far
    the corrected fit lands ("within" 2^median |log2|, EVALUATION.md's summary)."""
    out = []
    for lo, hi in zip(BANDS_DEG[:-1], BANDS_DEG[1:]):
        sel = [r["true_over_physical"] for r in rows if r.get("clear") and r.get("true_over_physical")
               and lo <= r["elevation_deg"] < hi]
        out.append({"band_deg": [lo, hi], "fits": len(sel),
                    "median_true_over_physical": statistics.median(sel) if sel else None,
                    "within": metrics.ratio_within(sel)})
    return out


def table(rows: list[dict]) -> list[str]:
    lines = ["| scene | elevation | ev | turbidity | clear | true / physical |", "|---|---:|---:|---:|---|---:|"]
    for r in sorted(rows, key=lambda r: (r["elevation_deg"], r["scene"], r["ev"])):
        if not r["fit"]:
            lines.append(f"| {r['scene']} | {r['elevation_deg']:.1f} | {r['ev']:+g} | no fit | | |")
            continue
        lines.append(f"| {r['scene']} | {r['elevation_deg']:.1f} | {r['ev']:+g} | {r['turbidity']:g} | "
                     f"{'yes' if r['clear'] else 'no'} | {r['true_over_physical']:.2f} |")
    return lines


def main(argv=None) -> int:
    ap = real_hdri_parser("python -m training.keylight.sun_elevation", __doc__)
    ap.add_argument("--out", type=Path, default=None, help="write the rows and summary as JSON here")
    args = ap.parse_args(argv)
    rows = score_manifest_suns(args.hdri, args.evs, score_scene, lambda got: ", ".join(
        f"ev {r['ev']:+g} {r['true_over_physical']:.2f}" for r in got if r.get("true_over_physical")))
    print("\n".join(table(rows)))
    bands = summary(rows)
    for b in bands:
        lo, hi = b["band_deg"]
        print(f"{lo:g}-{hi:g} deg: {b['fits']} clear fits" + (
            f", median true / physical {b['median_true_over_physical']:.2f}, within {b['within']:.2f}x" if b["fits"] else ""))
    save_study({"sky_correction": keylight.PARAMS.sky_correction, "summary": bands, "rows": rows}, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
