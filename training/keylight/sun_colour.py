"""The clear-sky sun's colour against the truth: the camera's white point, measured on every un-clipped real sun.

``keylight`` colours a clear-sky sun by the Hosek-Wilkie model (``sky.SkyFit.sun_rgb``), whose linear sRGB is
referred to D65. A camera is not: the photographers of the real HDRs, like a phone's auto white balance, balance a
sunlit scene so that daylight comes out about neutral, and the model's noon sun, (1.15, 0.98, 0.77) at 85 degrees,
then lights a composited object visibly orange where the photo's sun is white. This study takes every scene of
../shared/data/hdri whose MANIFEST ``sun`` column says it holds an un-clipped sun (``sun_elevation.manifest_suns``),
the truth's sun colour (the HDR's energy within CORE_DEG of its brightest source, less the sky between RING_DEG,
luminance 1), and at each ev the clear-sky fit of its camera JPEG (EVALUATION.md, q90) with the sun at the true
direction, as ``sun_elevation`` does; over the fits that pass the cloudiness gate:

- the camera's white point: per channel, the median of log(model / true) over the suns at least
  ``keylight.PARAMS.white_ramp_deg[1]`` up, as a colour of luminance 1 (the model's colour divided by it, made luminance 1
  again, is what the camera shows; lower suns take a share of it, ``keylight.camera_colour``):
  ``keylight.PARAMS.camera_white``;
- cross-validated by scene: each fold's suns corrected by the median of the OTHER folds' (the folds of
  ``training.source_energy.cv``); the colour error of a sun is the largest |log2| of its channels' ratios to the truth
  (0.32: a channel 25 % off), summarised by its median and by elevation band.

    python -m training.keylight.sun_colour [--evs -2 0 2] [--out docs/studies/sun_colour.json]
"""
from __future__ import annotations

import statistics
from pathlib import Path

import numpy as np

from panolight_core import metrics, sh
from panolight_core.camera import hdr_to_ldr
from panolight_core.camera.color import LUMINANCE_WEIGHTS
from panolight_core.estimators import keylight, sources
from panolight_core.estimators import sky as clear_sky
from training.common.folds import fold_of
from training.common.real_hdri import scene_files
from training.common.study import real_hdri_parser, save_study
from training.keylight.sun_elevation import BANDS_DEG, score_manifest_suns

CORE_DEG = 1.5  # the sun's disk and the aureole's core, where the sun's own energy is
RING_DEG = (3.0, 6.0)  # the sky it sits on, whose mean is taken off the core


def true_sun_colour(hdr: np.ndarray, direction) -> np.ndarray | None:
    """(3,) the colour (luminance 1) of the sun at unit ``direction`` in a linear HDR (h, 2h, 3): its energy within
    CORE_DEG less the mean radiance between RING_DEG over the same solid angle. None where that is not a positive
    colour (no source stands out of its sky)."""
    h, w = hdr.shape[:2]
    g = np.degrees(np.arccos(np.clip(sh.pixel_directions(h, w) @ np.asarray(direction, dtype=np.float64), -1.0, 1.0)))
    om = sh.pixel_solid_angles(h, w)
    core, ring = g < CORE_DEG, (g > RING_DEG[0]) & (g < RING_DEG[1])
    if not core.any() or not ring.any():
        return None
    excess = ((hdr[core] - hdr[ring].mean(axis=0)) * om[core][:, None]).sum(axis=0)
    y = float(excess @ LUMINANCE_WEIGHTS)
    return excess / y if excess.min() > 0 and y > 0 else None


def unit_colour(rgb) -> np.ndarray:
    """(3,) ``rgb`` scaled to luminance 1."""
    rgb = np.asarray(rgb, dtype=np.float64)
    return rgb / float(rgb @ LUMINANCE_WEIGHTS)


def colour_error(got, truth) -> float:
    """The largest |log2| of a colour's channel ratios to the truth's, both taken to luminance 1 (0: exact)."""
    return float(np.abs(np.log2(unit_colour(got) / unit_colour(truth))).max())


def score_scene(hdr, evs) -> list[dict]:
    """One scene's rows (none where its brightest source is below the horizon or shows no colour of its own): at
    each ev the model's sun colour from the clear-sky fit at the truth's direction, and the truth's."""
    ds = metrics.dominant_source(hdr)
    elevation = sh.elevation_deg(ds["direction"])
    truth = true_sun_colour(hdr, ds["direction"]) if elevation > 0 else None
    if truth is None:
        return []
    rows = []
    for ev in evs:
        rad, frac_any, frac_all = sources.work_maps(hdr_to_ldr(hdr, ev, 90))
        fit = clear_sky.fit_clear_sky(rad, frac_any == 0, frac_all > 0.5, ds["direction"])
        if fit is None or not fit.sun_energy > 0:
            continue
        rows.append({"ev": ev, "elevation_deg": round(elevation, 2), "turbidity": fit.turbidity,
                     "clear": bool(fit.clear),
                     "true": [round(float(v), 4) for v in truth],
                     "model": [round(float(v), 4) for v in unit_colour(fit.sun_rgb)]})
    return rows


def with_white(white) -> "keylight.KeyLightParams":
    """The shipped key-light parameters with another camera white point (3,)."""
    from dataclasses import replace

    return replace(keylight.PARAMS, camera_white=tuple(float(v) for v in white))


def white_point(rows: list[dict]) -> np.ndarray:
    """(3,) the camera's white point (luminance 1): per channel exp(median log(model / true)) over the ``rows`` of
    suns at least white_ramp_deg[1] up (all of them where none is)."""
    high = [r for r in rows if r["elevation_deg"] >= keylight.PARAMS.white_ramp_deg[1]] or rows
    logs = np.array([np.log(np.array(r["model"]) / np.array(r["true"])) for r in high])
    return unit_colour(np.exp(np.median(logs, axis=0)))


def cross_validate(rows: list[dict], files) -> dict:
    """The white point of all the clear suns, and each fold's suns balanced by the OTHER folds' (by scene; ``files``:
    every scene of the folder, whose folds are those of ``training.source_energy.cv``):
    per row the colour error before (the model's colour), with the shipped camera_white, and cross-validated."""
    clear = [r for r in rows if r["clear"]]
    folds = {p.stem: k for p, k in fold_of(files).items()}
    out = {"suns": len({r["scene"] for r in clear}), "fits": len(clear),
           "white_point": [round(float(v), 4) for v in white_point(clear)],
           "folds": {}}
    for k in sorted(set(folds.values())):
        train = [r for r in clear if folds[r["scene"]] != k]
        if not train:
            continue
        white = white_point(train)
        out["folds"][k] = [round(float(v), 4) for v in white]
        for r in clear:
            if folds[r["scene"]] == k:
                r["error_cv"] = colour_error(keylight.camera_colour(r["model"], r["elevation_deg"], with_white(white)), r["true"])
    for r in clear:
        r["error_model"] = colour_error(r["model"], r["true"])
        r["error_shipped"] = colour_error(keylight.camera_colour(r["model"], r["elevation_deg"]), r["true"])
    return out


def summary(rows: list[dict]) -> list[dict]:
    """Per elevation band (BANDS_DEG) and over all: the clear fits' median colour error, model against
    cross-validated white point against the shipped one."""
    out = []
    for lo, hi in list(zip(BANDS_DEG[:-1], BANDS_DEG[1:])) + [(BANDS_DEG[0], BANDS_DEG[-1])]:
        sel = [r for r in rows if r["clear"] and lo <= r["elevation_deg"] < hi and "error_cv" in r]
        out.append({"band_deg": [lo, hi], "fits": len(sel),
                    **{f"median_error_{k}": statistics.median(r[f"error_{k}"] for r in sel) if sel else None
                       for k in ("model", "cv", "shipped")}})
    return out


def main(argv=None) -> int:
    ap = real_hdri_parser("python -m training.keylight.sun_colour", __doc__)
    ap.add_argument("--out", type=Path, default=None, help="write the rows and summary as JSON here")
    args = ap.parse_args(argv)
    def describe(got):
        if not got:
            return "no colour"
        return f"true {got[0]['true']}, model " + ", ".join(
            f"ev {r['ev']:+g} {r['model']}" + ("" if r["clear"] else " (not clear)") for r in got)

    rows = score_manifest_suns(args.hdri, args.evs, score_scene, describe)
    cv = cross_validate(rows, scene_files(args.hdri))
    print(f"white point over {cv['fits']} clear fits of {cv['suns']} suns: {cv['white_point']} "
          f"(shipped {[round(float(v), 4) for v in keylight.PARAMS.camera_white]}); by fold: {cv['folds']}")
    bands = summary(rows)
    for b in bands:
        lo, hi = b["band_deg"]
        if b["fits"]:
            print(f"{lo:g}-{hi:g} deg: {b['fits']} clear fits, median colour error (max |log2| channel ratio) "
                  f"model {b['median_error_model']:.3f}, cross-validated {b['median_error_cv']:.3f}, "
                  f"shipped {b['median_error_shipped']:.3f}")
    save_study({"camera_white": [float(v) for v in keylight.PARAMS.camera_white], "cv": cv, "summary": bands, "rows": rows},
               args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
