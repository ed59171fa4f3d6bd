"""Better captures (EVALUATION.md "Better captures"): what an HDR that clips its own source gives today, against
one JPEG. The baseline issue 45's restoration is to beat.

For every scene of ../shared/data/hdri with a dominant compact source and an un-clipped truth: the truth at the
ev-0 camera's exposure (the factor that puts its median luminance at 0.18: the JPEG's white is then 1), and
- the camera JPEG at ev 0 (q90), estimated as ``panolight estimate`` does (``keylight``);
- bracket sets: the camera's JPEGs at each set's exposures (default {-2, 0, +2} and {-4, -2, 0, +2, +4}) merged
  (``camera.brackets``: an HDR whose ceiling is the darkest frame's white, then restored as any such file);
- with ``--bracket-curve``, the bracket sets shot by a camera with another tone curve: merged through the curve
  recovered from each set (``camera.response``) and, for comparison, decoded as sRGB;
- with ``--raw``, camera RAWs: a DNG of the truth (``panolight_core.io.dng``: an RGGB mosaic with a sensor's photon
  and read noise) whose white is 2^k times the JPEG's, read back through rawpy (LibRaw's demosaic) as
  ``panolight estimate`` reads a RAW, and restored;
- the same truth clipped per channel at 2^k (k = 2, 4, 6 stops over the JPEG's white), as a float HDR file
  that clips its sun holds it, estimated as an HDR input: as it is (``--restore none``: its exact projection, the
  lights the model takes) and restored (the default: ``sources.restore``).
Each is scored against the truth: m-RMSE at lmax 2 over the JPEG's naive projection's and over the clipped
file's own projection, the dominant source's energy ratio r (on the estimate's hdr.exr), the shadow contrast
C (EVALUATION.md) and the brightest light's direction error.

    python -m training.keylight.captures [--stops 2 4 6] [--as-ldr] [--raw 2 3] [--bracket-curve contrast:1.6]
        [--fold-models PATTERN]
        [--hdr-fold-models PATTERN]
        [--out docs/studies/captures.json] [--plot docs/studies/captures.png]
    python -m training.keylight.captures --from docs/studies/captures.json --plot docs/studies/captures.png
    python -m training.keylight.captures --public --out docs/studies/captures_public.json

``--public`` scores the eight HDRIs the bpy package ships (EVALUATION.md's public set) in place of ../shared's,
by the shipped models, which never saw them: a check on real HDRs the project never trained or tuned on.
"""
from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
from pathlib import Path

import numpy as np

from panolight_core import metrics, sh
from panolight_core.camera import TONE_CURVES, auto_exposure, hdr_to_ldr, ldr_to_linear
from panolight_core.camera.brackets import merge_brackets
from panolight_core.camera.color import LUMINANCE_WEIGHTS, linear_to_srgb
from panolight_core.errors import PanoLightError
from panolight_core.pipeline.estimate import estimate_lighting
from panolight_core.pipeline.settings import Settings
from training.common.real_hdri import DEFAULT_HDRI, load_hdr
from training.common.study import (
    public_option,
    restoring_estimators,
    restoring_fold_models_option,
    save_study,
    study_files,
)


def score(truth: np.ndarray, ds: dict, pixels: np.ndarray, scale: float = 1.0, estimator: str = "auto",
          restore: str = "auto", sun=None) -> dict:
    """One capture's estimate (``estimate_lighting`` of uint8 or float ``pixels`` by ``estimator``, with ``restore``
    and the artist's sun at unit ``sun`` if given, its units times ``scale`` in the truth's) scored against
    ``truth`` (the HDR at the camera's exposure) and its dominant source ``ds``."""
    res = estimate_lighting(pixels, Settings(estimator=estimator, restore=restore,
                                             sun_direction=None if sun is None else tuple(float(v) for v in sun)))
    key = metrics.brightest_light(res.model.lights)
    gt = sh.project(truth, 2)
    own = ldr_to_linear(pixels) if pixels.dtype == np.uint8 else pixels
    return {"m_rmse": metrics.m_rmse(gt, scale * res.model.project(2)),
            "own_projection_m_rmse": metrics.m_rmse(gt, scale * sh.project(own, 2)),
            "ratio": metrics.source_energy_ratio(truth, scale * res.hdr_panorama(pixels), ds["direction"]),
            "contrast": metrics.model_shadow_contrast(res.model, ds["direction"]),
            "angle_deg": metrics.angle_deg(ds["direction"], key["peak_direction"]) if key else 180.0}


def raw_capture(truth: np.ndarray, stops: float, seed: int) -> np.ndarray:
    """``truth`` as a camera RAW whose sensor's white is 2^stops times the JPEG's white, read back: a DNG written
    with a sensor's noise (seeded) and decoded by ``io.read_raw`` (units: the sensor's white)."""
    import tempfile

    from panolight_core.io.dng import write_dng
    from panolight_core.io.read_raw import read_raw

    with tempfile.TemporaryDirectory() as tmp:
        path = write_dng(Path(tmp) / "capture.dng", truth, scale=2.0 ** -stops, rng=np.random.default_rng(seed))
        return read_raw(path)[0]


CLICK_DEG = 1.0  # --pointed: the artist's click lands this far from the true source, in a direction drawn per scene
TIE_NOISE = 1e-2  # ... on a file whose plateau lost its exact ties (resampled after its merge): each pixel times
# 1 + this x a uniform draw in [-1, 1], 50 times camera.ceiling's tolerance (at 1e-3 a few top pixels still tied)


def untied(clipped: np.ndarray, seed: int) -> np.ndarray:
    """A clipped HDR (H, W, 3) whose plateau lost its exact ties, as a file resampled after its merge has: every
    value times 1 + TIE_NOISE x U(-1, 1) (float32)."""
    rng = np.random.default_rng(seed)
    return (clipped * (1.0 + TIE_NOISE * rng.uniform(-1.0, 1.0, clipped.shape))).astype(np.float32)


def clicked(direction, seed: int) -> np.ndarray:
    """Unit ``direction`` moved CLICK_DEG toward a direction drawn from ``seed``: an artist's click on the sun."""
    d = np.asarray(direction, dtype=np.float64)
    v = np.cross(d, np.random.default_rng(seed).normal(size=3))
    v /= np.linalg.norm(v)
    a = math.radians(CLICK_DEG)
    return math.cos(a) * d + math.sin(a) * v


def scene_rows(path: Path, stops, as_ldr: bool = False, estimator: str = "auto", brackets=(), raws=(),
               curve: tuple | None = None, pointed=()) -> list[dict]:
    """The captures of one scene (none without a dominant source): the ev-0 JPEG, then the HDR clipped at each
    2^stops (with ``as_ldr`` also that file through the LDR path, its ceiling the white: a restoration tried by
    the machinery as it is), then each bracket set of ``brackets`` (tuples of evs: the camera's JPEGs at those
    exposures merged, ``camera.brackets``), then a camera RAW whose white is each 2^raws over the JPEG's
    (``raw_capture``), then the HDR clipped at each 2^pointed with its ties lost (``untied``), as it is and with the
    artist's click (``clicked``; a click the pipeline refuses is scored without it, its row saying why under
    ``refused``), each with the scene's true contrast. ``curve``: (name, parameter) of another camera's tone
    curve (``camera.TONE_CURVES``) for the bracket sets' frames, each set merged through the curve recovered from
    it and, for comparison, decoded as sRGB; their units (a convention for such a camera) matched to the truth's
    median."""
    hdr = load_hdr(path)
    ds = metrics.dominant_source(hdr)
    if not ds["dominant"]:
        return []
    truth = hdr * auto_exposure(hdr, 0.0)
    true_c = metrics.true_shadow_contrast(hdr, ds["direction"])
    captures = [("JPEG", hdr_to_ldr(hdr, 0.0, 90), 1.0, "auto")]
    for s in stops:
        clipped = np.minimum(truth, 2.0 ** s)
        captures.append((f"HDR clipped at +{s:g} stops, as it is", clipped.astype(np.float32), 1.0, "none"))
        captures.append((f"HDR clipped at +{s:g} stops, restored", clipped.astype(np.float32), 1.0, "auto"))
        if as_ldr:  # the same file through the LDR path: its ceiling made the white of an 8-bit sRGB picture
            ldr = np.round(linear_to_srgb(clipped / 2.0 ** s) * 255.0).astype(np.uint8)
            captures.append((f"HDR clipped at +{s:g} stops, as an 8-bit picture", ldr, 2.0 ** s, "auto"))
    for evs in brackets:  # the reference frame (ev 0) sets the units: the truth's
        name = f"{len(evs)} brackets {{{', '.join(f'{ev:+g}' for ev in evs)}}}"
        if curve is None:
            merged, _ = merge_brackets([hdr_to_ldr(hdr, ev, 90) for ev in evs], [2.0 ** ev for ev in evs])
            captures.append((name, merged, 1.0, "auto"))
            continue
        frames = [hdr_to_ldr(hdr, ev, 90, curve=curve[0], curve_param=curve[1]) for ev in evs]
        for own in (True, False):
            merged, info = merge_brackets(frames, [2.0 ** ev for ev in evs], response=own)
            scale = float(np.median(truth @ LUMINANCE_WEIGHTS) / np.median(merged @ LUMINANCE_WEIGHTS))
            how = "its own curve where recovered" if own else "decoded as sRGB"
            captures.append((f"{name}, {curve[0]} {curve[1]:g} camera, {how}", merged, scale, "auto"))
    seed = int.from_bytes(path.stem.encode()[:8], "little")
    for k in raws:  # the sensor's white is the unit: 2^k of the truth's
        captures.append((f"RAW, white at +{k:g} stops, restored", raw_capture(truth, k, seed), 2.0 ** k, "auto"))
    suns = {}
    for k in pointed:  # the file lost its plateau's ties: found by the artist's click, or taken as it is
        untied_file = untied(np.minimum(truth, 2.0 ** k), seed)
        captures.append((f"HDR clipped at +{k:g} stops, ties lost, as it is", untied_file, 1.0, "auto"))
        captures.append((f"HDR clipped at +{k:g} stops, ties lost, the sun clicked", untied_file, 1.0, "auto"))
        suns[len(captures) - 1] = clicked(ds["direction"], seed)
    rows = []
    for i, (name, pixels, scale, restore) in enumerate(captures):
        row = {"scene": path.stem, "capture": name, "true_contrast": true_c}
        try:
            row.update(score(truth, ds, pixels, scale, estimator, restore, suns.get(i)))
        except PanoLightError as exc:  # the click refused in one line (no plateau near it, no sky to weigh it):
            row.update(score(truth, ds, pixels, scale, estimator, restore), refused=str(exc))  # the file as it is
        rows.append(row)
    jpeg = rows[0]["own_projection_m_rmse"]  # the JPEG's naive projection: the EVALUATION.md baseline
    for row in rows:
        row["m_rmse_over_naive"] = row["m_rmse"] / jpeg
        row["m_rmse_over_own"] = row["m_rmse"] / row["own_projection_m_rmse"]
        # harm against the input as it is: a file its own projection, a set (and a JPEG) the ev-0 JPEG's naive one
        as_is = jpeg if "brackets" in row["capture"] or row["capture"] == "JPEG" else row["own_projection_m_rmse"]
        row["harmed"] = metrics.harmed(row["m_rmse"], as_is)
    return rows


def summary(rows: list[dict]) -> dict:
    """Per capture: scenes, direction median, energy and contrast "within 2^x" and worst, m-RMSE over the
    JPEG's naive projection and over the capture's own, medians."""
    out = {}
    for name in dict.fromkeys(r["capture"] for r in rows):
        sel = [r for r in rows if r["capture"] == name]
        ratios = [r["ratio"] for r in sel]
        contrasts = [r["contrast"] / r["true_contrast"] for r in sel]
        out[name] = {"harmed": sum(bool(r.get("harmed")) for r in sel),
                     "scenes": len(sel), "median_angle_deg": statistics.median(r["angle_deg"] for r in sel),
                     "energy_within": metrics.ratio_within(ratios),
                     "energy_worst": max(ratios, key=lambda v: abs(math.log2(max(v, 1e-12)))),
                     "contrast_within": metrics.ratio_within(contrasts),
                     "contrast_worst": max(contrasts, key=lambda v: abs(math.log2(v))),
                     "m_rmse_over_naive_median": statistics.median(r["m_rmse_over_naive"] for r in sel),
                     "m_rmse_over_own_median": statistics.median(r["m_rmse_over_own"] for r in sel)}
    return out


def table(summ: dict) -> list[str]:
    lines = ["| capture | harmed | scenes | direction median | energy within | worst r | contrast within | worst C / "
             "C_true | m-RMSE / naive JPEG | m-RMSE / own projection |", "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for name, s in summ.items():
        lines.append(f"| {name} | {s.get('harmed', '?')} | {s['scenes']} | {s['median_angle_deg']:.1f} deg | "
                     f"{s['energy_within']:.2f}x | "
                     f"{s['energy_worst']:.3g} | {s['contrast_within']:.2f}x | {s['contrast_worst']:.3g} | "
                     f"{s['m_rmse_over_naive_median']:.3f} | {s['m_rmse_over_own_median']:.3f} |")
    return lines


def plot(summ: dict, out: Path) -> Path:
    """A picture of ``summary``: per capture, the dominant source's energy and the shadow contrast "within" (log
    scale, 1 is exact) and the m-RMSE over the capture's own projection, with issue 45's bars for a clipped HDR."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(summ)
    fig, axes = plt.subplots(1, 3, figsize=(13, 0.45 * len(names) + 1.4), sharey=True)
    panels = (("energy_within", "dominant source's energy within (x)", 1.5, True),
              ("contrast_within", "shadow contrast within (x)", 1.25, True),
              ("m_rmse_over_own_median", "m-RMSE / own projection (median)", 0.5, False))
    y = np.arange(len(names))
    for ax, (key, title, bar, log) in zip(axes, panels):
        values = [summ[n][key] for n in names]
        ax.barh(y, values, color=["#888" if "as it is" in n else "#2a7" if "restored" in n else "#47a" for n in names])
        ax.axvline(bar, color="k", ls="--", lw=1)
        if log:  # ratios of 1 or more: ticks in plain numbers
            from matplotlib.ticker import FixedLocator, FuncFormatter, NullFormatter

            ax.set_xscale("log")
            ax.set_xlim(1.0, 2.0 * max(values))
            ticks = (1, 2, 5, 10, 30, 100) if max(values) > 10 else (1, 1.25, 1.5, 2, 3, 5)
            ax.xaxis.set_major_locator(FixedLocator([t for t in ticks if t <= 2.0 * max(values)]))
            ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
            ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_title(f"{title}; bar {bar:g}", fontsize=9)
        for yi, v in zip(y, values):
            ax.text(v, yi, f" {v:.2f}", va="center", fontsize=8)
    axes[0].set_yticks(y, names, fontsize=8)
    axes[0].invert_yaxis()
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m training.keylight.captures", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hdri", type=Path, default=DEFAULT_HDRI, help="folder of real HDR panoramas (default: %(default)s)")
    ap.add_argument("--stops", type=float, nargs="+", default=[2.0, 4.0, 6.0],
                    help="clip the HDR at 2^STOPS times the JPEG's white (default: 2 4 6)")
    ap.add_argument("--as-ldr", action="store_true",
                    help="also estimate each clipped file through the LDR path, its ceiling the white of an 8-bit "
                         "sRGB picture (the per-source and key-light machinery as they are)")
    ap.add_argument("--brackets", action="append", default=None, metavar="EVS",
                    help="a bracket set of the camera's JPEGs, merged, as --brackets=-2,0,2 (again for another set; "
                         "default: -2,0,2 and -4,-2,0,2,4; --brackets= alone: no sets)")
    ap.add_argument("--bracket-curve", default=None, metavar="NAME:PARAM",
                    help="the bracket sets' camera has this tone curve (camera.TONE_CURVES, e.g. contrast:1.6): each "
                         "set merged through the curve recovered from it, and decoded as sRGB")
    ap.add_argument("--pointed", type=float, nargs="*", default=[], metavar="STOPS",
                    help="also the HDR clipped at 2^STOPS with its plateau's exact ties lost (a file resampled after "
                         "its merge, which camera.ceiling cannot find), as it is and with the artist's click on its "
                         f"sun ({CLICK_DEG:g} deg off the truth's direction; e.g. --pointed 2 4; default: none)")
    ap.add_argument("--raw", type=float, nargs="*", default=[], metavar="STOPS",
                    help="also a camera RAW (a noisy DNG, demosaiced by LibRaw) whose sensor's white is 2^STOPS "
                         "times the JPEG's (e.g. --raw 2 3; default: none)")
    restoring_fold_models_option(ap)
    public_option(ap)
    ap.add_argument("--out", type=Path, default=None, help="write the rows and summary here (JSON)")
    ap.add_argument("--plot", type=Path, default=None, metavar="PNG",
                    help="also draw the summary here; with --from, draw a JSON this study wrote, without running it")
    ap.add_argument("--from", dest="source", type=Path, default=None, metavar="JSON",
                    help="with --plot: the study's JSON to draw")
    args = ap.parse_args(argv)
    if args.source:
        summ = json.loads(args.source.read_text(encoding="utf-8"))["summary"]
        print("\n".join(table(summ)))
        print(f"wrote {plot(summ, args.plot or args.source.with_suffix('.png'))}")
        return 0
    files, clipped = study_files(ap, args)
    estimator_of = restoring_estimators(args, files)
    sets = args.brackets if args.brackets is not None else ["-2,0,2", "-4,-2,0,2,4"]
    brackets = [tuple(float(v) for v in b.split(",")) for b in sets if b.strip()]
    curve = None
    if args.bracket_curve:
        name, _, param = args.bracket_curve.partition(":")
        curve = (name, float(param) if param else TONE_CURVES[name][1])
    rows = []
    for i, path in enumerate(files, 1):
        if path.name in clipped:
            continue  # a truth that clips its own source is a lower bound, never a target
        got = scene_rows(path, args.stops, args.as_ldr, estimator_of[path], brackets, args.raw, curve, args.pointed)
        rows += got
        for r in got:
            print(f"[{i}/{len(files)}] {r['scene']:28s} {r['capture']:24s} angle {r['angle_deg']:6.1f}  r {r['ratio']:7.3f}  "
                  f"C {r['contrast']:6.2f} of {r['true_contrast']:6.2f}  m/naive {r['m_rmse_over_naive']:.3f}", flush=True)
    summ = summary(rows)
    print("\n".join(table(summ)))
    save_study({"scenes": "public" if args.public else str(args.hdri), "stops": args.stops, "brackets": sets, "raw": args.raw, "pointed": args.pointed, "bracket_curve": args.bracket_curve, "fold_models": args.fold_models, "hdr_fold_models": args.hdr_fold_models,
                "summary": summ, "rows": rows}, args.out)
    if args.plot:
        print(f"wrote {plot(summ, args.plot)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
