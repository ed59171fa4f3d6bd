"""The sun a photo does not show, over the real HDRs: how well the sky alone locates and weighs it, and how
often the estimator invents one.

``keylight.hidden_sun`` adds a sun where no clipped region holds a clear-sky sun but the visible sky puts one
(``sun_search.search_sun``: the clear-sky position that best fits the sky, ``SunSearch.found``). Since issue 58 it does
so only with ``--sky-sun`` (``KeyLightParams.sky_alone_sun``; by default the note says where): every measurement
here is of that option (``SKY_SUN``). Three measurements:

1. **Located from the sky alone.** For every scene of ../shared/data/hdri with a dominant compact source
   above the horizon (EVALUATION.md), at each ev: the camera JPEG (EVALUATION.md, q90), with every work cell
   within ``--mask`` degrees of the true source hidden from the search (neither seen nor clipped: the sun and
   its glare retouched out or veiled). Per scene: whether the search finds a sun, its direction error, the
   gate's numbers (residual, visible sky, contrast: the best position's score over the median position's),
   and the fit's solar energy x SKY_CORRECTION over the truth's energy within 5 degrees (in camera units).
   Lamps indoors are the check that the gate refuses what is no sky.
2. **Invented suns.** Every scene at each ev, unmasked, through the ``keylight`` estimator with ``--sky-sun``: each
   hidden sun it adds, and the angle to the truth's brightest source. Where the truth has no dominant source within
   20 degrees of it, the sun is false.
3. **Retouched, end to end.** Every scene with a dominant source above the horizon, its HDR retouched as a photo
   editor would: everything within ``--mask`` degrees of the source painted in the colour of the sky just beyond,
   then the camera JPEG of that. The whole estimate (``keylight --sky-sun`` and ``sources``, the shipped model) is scored
   against the ORIGINAL HDR, whose sun lit the scene: whether a hidden sun is made, its direction error, the
   dominant source's energy ratio r (EVALUATION.md) and m-RMSE / naive at lmax 2.

    python -m training.keylight.hidden_sun [--evs -2 0 2] [--mask 20] [--out docs/studies/hidden_sun.json]
    python -m training.keylight.hidden_sun --picture ../shared/data/ldr/examplepano.jpg docs/hidden_sun.jpg
    panolight dev hidden-sun ...   (the same)

``--picture PHOTO IMAGE`` draws, over the photo, how well a clear sky with its sun at each position fits the
photo's sky (bright: fits), the sun the search puts there and its 68 % circle, and what lighting.json says.
"""
from __future__ import annotations

import json
import math
import statistics
from dataclasses import replace
from pathlib import Path

import numpy as np

from panolight_core import metrics, sh
from panolight_core.camera import auto_exposure, hdr_to_ldr
from panolight_core.estimators import keylight, sources, sun_search
from training.common.real_hdri import clipped_truth, load_hdr, scene_files
from training.common.study import real_hdri_parser, save_study

RIGHT_DEG = 20.0  # a hidden sun this close to the truth's dominant source is that source


SKY_SUN = replace(keylight.PARAMS, sky_alone_sun=True)  # --sky-sun: the option this study measures


def located(hdr: np.ndarray, ev: float, mask_deg: float) -> dict | None:
    """The sun search on the camera JPEG of ``hdr`` with the truth's dominant source (and ``mask_deg`` around
    it) hidden; None when the scene has no dominant source above the horizon."""
    ds = metrics.dominant_source(hdr)
    if not ds["dominant"] or ds["direction"][2] <= 0:
        return None
    rad, frac_any, frac_all = sources.work_maps(hdr_to_ldr(hdr, ev, 90))
    near = sh.pixel_directions(*frac_any.shape) @ ds["direction"] > math.cos(math.radians(mask_deg))
    found = sun_search.search_sun(rad, (frac_any == 0) & ~near, (frac_all > 0.5) & ~near, max_contrast=None)
    row = {"ev": ev, "true_elevation_deg": round(math.degrees(math.asin(float(ds["direction"][2]))), 2),
           "share": round(float(ds["share"]), 4), "found": False}
    if not isinstance(found, sun_search.SunSearch):  # no sky to fit at all
        return row
    truth = float(ds["energy"]) * auto_exposure(hdr, ev)
    return dict(row, found=bool(found.found), angle_deg=round(metrics.angle_deg(ds["direction"], found.direction), 3),
                elevation_deg=round(found.elevation_deg, 2), contrast=round(found.contrast, 4),
                rms=round(found.fit.rms, 4), sky_sr=round(found.fit.sky_sr, 3), blueness=round(found.fit.blueness, 3),
                colour_match=round(found.colour_match, 3), direction_68_deg=round(found.direction_68_deg, 3),
                clear=bool(found.fit.clear), energy_ratio=keylight.PARAMS.sky_correction * found.fit.sun_energy / truth)


def invented(hdr: np.ndarray, ev: float) -> dict:
    """The shipped estimator's hidden suns on the camera JPEG of ``hdr`` (unmasked)."""
    ds = metrics.dominant_source(hdr)
    ldr = hdr_to_ldr(hdr, ev, 90)
    rec = keylight.with_key_lights(sources.recover(ldr, maps=sources.work_maps(ldr)), SKY_SUN)
    suns = [k for k in rec.keys if k.region < 0]
    out = {"ev": ev, "dominant": bool(ds["dominant"]), "hidden": []}
    for k in suns:
        angle = metrics.angle_deg(ds["direction"], k.direction)
        out["hidden"].append({"angle_deg": round(angle, 3), "right": bool(ds["dominant"] and angle <= RIGHT_DEG),
                              "elevation_deg": round(math.degrees(math.asin(float(k.direction[2]))), 2)})
    return out


def retouch(hdr: np.ndarray, direction, mask_deg: float) -> np.ndarray:
    """``hdr`` with every pixel within ``mask_deg`` of unit ``direction`` painted in the mean colour of the sky
    ring mask_deg..mask_deg + 2 degrees from it (above the horizon): the sun and its glare retouched out."""
    h, w = hdr.shape[:2]
    dirs = sh.pixel_directions(h, w)
    ang = np.degrees(np.arccos(np.clip(dirs @ np.asarray(direction, dtype=np.float64), -1.0, 1.0)))
    ring = (ang >= mask_deg) & (ang < mask_deg + 2.0) & (dirs[..., 2] > 0)
    out = np.array(hdr, dtype=np.float64, copy=True)
    if ring.any():
        out[ang < mask_deg] = hdr[ring].mean(axis=0)
    return out


def retouched(hdr: np.ndarray, ev: float, mask_deg: float) -> dict | None:
    """The whole estimate of the camera JPEG of ``hdr`` with its dominant source retouched out (``retouch``),
    scored against ``hdr`` itself; None when the scene has no dominant source above the horizon."""
    from panolight_core.camera import ldr_to_linear
    from panolight_core.pipeline.estimate import estimate_lighting
    from panolight_core.pipeline.settings import Settings

    ds = metrics.dominant_source(hdr)
    if not ds["dominant"] or ds["direction"][2] <= 0:
        return None
    ldr = hdr_to_ldr(retouch(hdr, ds["direction"], mask_deg), ev, 90)
    gt = sh.project(np.asarray(hdr, dtype=np.float64), 2)
    naive = metrics.m_rmse(gt, sh.project(ldr_to_linear(ldr), 2))
    row = {"ev": ev}
    for name in ("sources", "keylight"):
        res = estimate_lighting(ldr, Settings(estimator=name, sky_sun=True))
        est = {"m_rmse_over_naive": metrics.m_rmse(gt, res.model.project(2)) / naive,
               "ratio": metrics.source_energy_ratio(hdr, res.hdr_panorama(ldr), ds["direction"])}
        if name == "keylight":
            suns = [k for k in res.estimate.recovery.keys if k.region < 0]
            est["hidden_sun"] = bool(suns)
            if suns:
                est["angle_deg"] = round(metrics.angle_deg(ds["direction"], suns[0].direction), 3)
                est["direction_68_deg"] = round(float(np.degrees(suns[0].direction_68)), 3)
        row[name] = est
    return row


def picture(photo: Path, out: Path, width: int = 1024) -> dict:
    """The sun search on a photo, drawn: the photo (``width`` x width / 2) with each sky position tinted by how
    well a clear sky with the sun there fits (the search's coarse score, relative to the best), the search's
    sun and its 68 % circle; returns lighting.json's ``estimator.sun_search`` for it."""
    from PIL import Image, ImageDraw

    from panolight_core.io import read_image

    ldr = np.asarray(read_image(photo, ldr_as_uint8=True))
    if ldr.dtype != np.uint8:
        raise SystemExit(f"{photo}: --picture takes an 8-bit photo (JPEG or PNG)")
    rad, frac_any, frac_all = maps = sources.work_maps(ldr)
    rec = keylight.with_key_lights(sources.recover(ldr, maps=maps), SKY_SUN)
    h = width // 2
    dirs = sh.pixel_directions(h, width)
    el = np.degrees(np.arcsin(np.clip(dirs[..., 2], -1, 1)))
    az = np.degrees(np.arctan2(dirs[..., 1], dirs[..., 0]))
    step = 2.5
    grid_el, grid_az = np.arange(step / 2, 90.0, step), np.arange(-180.0, 180.0, step)
    e, a = np.radians(grid_el)[:, None], np.radians(grid_az)[None, :]
    suns = np.stack(np.broadcast_arrays(np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)), axis=-1).reshape(-1, 3)
    scores = sun_search.position_scores(rad, frac_any == 0, frac_all > 0.5, suns).reshape(grid_el.size, grid_az.size)
    fit = np.where(np.isfinite(scores), np.nanmin(np.where(np.isfinite(scores), scores, np.nan)) / scores, 0.0)
    i = np.clip(((el + 0.0) / step).astype(int), 0, grid_el.size - 1)
    j = np.clip(((az + 180.0) / step).astype(int), 0, grid_az.size - 1)
    tint = np.where(el > 0, fit[i, j] ** 4, 0.0)[..., None]
    img = np.asarray(Image.fromarray(ldr).convert("RGB").resize((width, h), Image.BILINEAR), dtype=np.float64)
    img = img * (1 - 0.6 * tint) + 0.6 * tint * np.array([255.0, 200.0, 0.0])
    canvas = Image.fromarray(np.clip(img, 0, 255).astype(np.uint8))
    draw = ImageDraw.Draw(canvas)
    report = rec.sun_search or {"searched": False, "why": "not a keylight estimate"}
    if report.get("direction"):
        v = np.asarray(report["direction"])
        y, x = sh.grid.pixel_at(v, h, width)
        ry = report["direction_68_deg"] / 180.0 * h
        rx = ry / max(math.cos(math.radians(report["elevation_deg"])), 0.2)
        colour = (255, 255, 255) if report["hidden_sun"] else (255, 80, 80)
        draw.ellipse([x - rx, y - ry, x + rx, y + ry], outline=colour, width=2)
        draw.ellipse([x - 3, y - 3, x + 3, y + 3], fill=colour)
    text = ("hidden sun made" if report.get("hidden_sun") else
            "no hidden sun: " + "; ".join(report.get("refused", [])) if report.get("searched") else
            "not searched: " + report.get("why", ""))
    draw.rectangle([0, 0, width, 16], fill=(0, 0, 0))
    draw.text((4, 2), f"{Path(photo).name}: tint = how well a clear sky with its sun there fits the sky; {text}",
              fill=(255, 255, 255))
    out.parent.mkdir(parents=True, exist_ok=True)
    canvas.save(out, **({"quality": 88} if out.suffix.lower() in (".jpg", ".jpeg") else {}))
    return report


def summary(rows: list[dict], evs) -> dict:
    out = {}
    for ev in evs:
        loc = [r for r in rows if r["kind"] == "located" and r["ev"] == ev and not r["clipped_truth"]]
        suns = [r for r in loc if r.get("found")]
        errs = sorted(r["angle_deg"] for r in suns)
        inv = [r for r in rows if r["kind"] == "invented" and r["ev"] == ev]
        hidden = [h for r in inv for h in r["hidden"]]
        ret = [r for r in rows if r["kind"] == "retouched" and r["ev"] == ev and not r["clipped_truth"]]
        made = [r for r in ret if r["keylight"]["hidden_sun"]]

        def within(name, sel):
            return metrics.ratio_within(r[name]["ratio"] for r in sel)

        retouched_summary = {
            "scenes": len(ret), "hidden_suns": len(made),
            "median_angle_deg": statistics.median(r["keylight"]["angle_deg"] for r in made) if made else None,
            "energy_within": {"keylight": within("keylight", made), "sources": within("sources", made)},
            "m_rmse_median": {n: statistics.median(r[n]["m_rmse_over_naive"] for r in made) if made else None
                              for n in ("keylight", "sources")},
            "m_rmse_mean": {n: statistics.mean(r[n]["m_rmse_over_naive"] for r in made) if made else None
                            for n in ("keylight", "sources")},
            "keylight_wins": sum(r["keylight"]["m_rmse_over_naive"] < r["sources"]["m_rmse_over_naive"] for r in made)}
        out[f"{ev:+g}"] = {
            "retouched": retouched_summary,
            "dominant_above_horizon": len(loc), "found": len(suns),
            "median_angle_deg": statistics.median(errs) if errs else None,
            "angle_68_deg": float(np.percentile(errs, 68)) if errs else None,
            "energy_within": metrics.ratio_within(r["energy_ratio"] for r in suns if r["energy_ratio"] > 0),
            # how often the error is within the 68 % radius the search reports (calibrated: 0.68)
            "direction_68_covers": statistics.mean(r["angle_deg"] <= r["direction_68_deg"] for r in suns) if suns else None,
            "median_direction_68_deg": statistics.median(r["direction_68_deg"] for r in suns) if suns else None,
            "energy_ratios": sorted(round(r["energy_ratio"], 3) for r in suns),
            "scenes": len(inv), "hidden_suns": len(hidden), "right": sum(h["right"] for h in hidden),
            "false": [f"{r['scene']} ({h['angle_deg']:.0f} deg off)" for r in inv for h in r["hidden"] if not h["right"]]}
    return out


def main(argv=None) -> int:
    ap = real_hdri_parser("python -m training.keylight.hidden_sun", __doc__)
    ap.add_argument("--mask", type=float, default=20.0,
                    help="degrees around the true source hidden from the search in the location study (default: %(default)s)")
    ap.add_argument("--out", type=Path, default=None, help="write the rows and summary as JSON here")
    ap.add_argument("--picture", nargs=2, type=Path, metavar=("PHOTO", "IMAGE"), default=None,
                    help="only draw the sun search on an 8-bit photo into IMAGE (.png or .jpg; no study)")
    args = ap.parse_args(argv)
    if args.picture:
        report = picture(*args.picture)
        print(json.dumps(report), f"\nwrote {args.picture[1]}", sep="")
        return 0
    files = scene_files(args.hdri)
    clipped = clipped_truth(args.hdri)
    rows = []
    for i, p in enumerate(files, 1):
        hdr = load_hdr(p)
        for ev in args.evs:
            loc = located(hdr, ev, args.mask)
            if loc is not None:
                rows.append(dict(loc, kind="located", scene=p.stem, clipped_truth=p.name in clipped))
                if loc["found"]:
                    print(f"[{i}/{len(files)}] {p.stem:28s} ev {ev:+g} located: {loc['angle_deg']:5.1f} deg off, "
                          f"energy x{loc['energy_ratio']:.2f} (contrast {loc['contrast']:.2f})", flush=True)
            ret = retouched(hdr, ev, args.mask)
            if ret is not None:
                rows.append(dict(ret, kind="retouched", scene=p.stem, clipped_truth=p.name in clipped))
                if ret["keylight"]["hidden_sun"]:
                    print(f"[{i}/{len(files)}] {p.stem:28s} ev {ev:+g} retouched: hidden sun "
                          f"{ret['keylight']['angle_deg']:5.1f} deg off, r {ret['keylight']['ratio']:.2f} "
                          f"(sources {ret['sources']['ratio']:.3f}), m-RMSE / naive {ret['keylight']['m_rmse_over_naive']:.2f} "
                          f"(sources {ret['sources']['m_rmse_over_naive']:.2f})", flush=True)
            inv = dict(invented(hdr, ev), kind="invented", scene=p.stem, clipped_truth=p.name in clipped)
            rows.append(inv)
            for h in inv["hidden"]:
                print(f"[{i}/{len(files)}] {p.stem:28s} ev {ev:+g} hidden sun {h['angle_deg']:.1f} deg from the truth's "
                      f"brightest source ({'right' if h['right'] else 'FALSE'})", flush=True)
    result = {"mask_deg": args.mask, "summary": summary(rows, args.evs), "rows": rows}
    print(json.dumps(result["summary"], indent=1))
    save_study(result, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
