"""Small panoramas: how a clipped sun or lamp is weighed in a file narrower than the per-source model's training
cameras framed (``sources.TRAINED_MIN_WIDTH``), the evidence for ``panolight estimate``'s warning on such files
(``pipeline.estimate.narrow_warning``; docs/studies/small_inputs.md).

For each real HDR of ``../shared/data/hdri`` with a dominant compact source and an un-clipped truth, made WIDTH
pixels wide (area-averaged, as an export or a thumbnail is), at the ev-0 camera's exposure: the camera JPEG (q90)
and the file clipped at +STOPS over the JPEG's white, restored (the default). Each is scored as
``training.keylight.captures`` scores its captures (the dominant source's energy ratio r, the shadow contrast C,
the key light's direction, m-RMSE at lmax 2 over the JPEG's naive projection at the same width and over the
capture's own projection), against the truth at the same width.

    python -m training.experiments.small_inputs [--widths 1024 512 384 256 128] [--stops 4]
        [--fold-models 'runs/cmp/new/sources_{k}.safetensors' --hdr-fold-models 'runs/hdr/all8/sources_{k}.safetensors']
        [--photos ../shared/data/ldr] [--out docs/studies/small_inputs.json]

With ``--photos``, real photos (no truth) as they are and made narrower: how far their key light moves with the
file's size.
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

from panolight_core import metrics, sh
from panolight_core.camera import auto_exposure, hdr_to_ldr, ldr_to_linear
from panolight_core.camera.resample import area_downsample
from training.common.real_hdri import DEFAULT_HDRI, clipped_truth, load_hdr, scene_files
from training.common.study import restoring_estimators, restoring_fold_models_option, save_study
from training.keylight.captures import score, summary, table

WIDTHS = (1024, 512, 384, 256, 128)


def scene_rows(path: Path, widths=WIDTHS, stops: float = 4.0, estimator: str = "auto") -> list[dict]:
    """One scene's rows (none without a dominant source): at each width, its JPEG and its HDR clipped at 2^stops
    and restored, scored against the truth at that width. The exposure is the full-size file's ev 0, so every
    width's JPEG has the same white."""
    hdr = load_hdr(path)
    ds = metrics.dominant_source(hdr)
    if not ds["dominant"]:
        return []
    k = auto_exposure(hdr, 0.0)
    true_c = metrics.true_shadow_contrast(hdr, ds["direction"])
    rows = []
    for width in widths:
        small = hdr if width >= hdr.shape[1] else area_downsample(hdr, width // 2, width)
        truth = small * k
        jpeg = hdr_to_ldr(truth, jpeg_quality=90, scale=1.0)
        clipped = np.minimum(truth, 2.0 ** stops).astype(np.float32)
        naive = metrics.m_rmse(sh.project(truth, 2), sh.project(ldr_to_linear(jpeg), 2))
        for name, pixels in ((f"JPEG, {width} wide", jpeg),
                             (f"HDR clipped at +{stops:g} stops, restored, {width} wide", clipped)):
            row = {"scene": path.stem, "capture": name, "width": width, "true_contrast": true_c,
                   **score(truth, ds, pixels, 1.0, estimator)}
            row["m_rmse_over_naive"] = row["m_rmse"] / naive
            row["m_rmse_over_own"] = row["m_rmse"] / row["own_projection_m_rmse"]
            rows.append(row)
    return rows


PHOTO_WIDTHS = (4096, 2048, 1024, 512)


def photo_rows(path: Path, widths=PHOTO_WIDTHS) -> list[dict]:
    """A real photo (no truth) as it is and made narrower (Lanczos, as an editor does; only widths below its own):
    each size's key light (the brightest light's intensity, its ratio to the full size's and the angle between
    their directions; None where there is none) and the whole model's band-0 luminance over the full size's."""
    from panolight_core.camera import lanczos_resize
    from panolight_core.camera.color import LUMINANCE_WEIGHTS
    from panolight_core.io import read_image
    from panolight_core.pipeline.estimate import estimate_lighting

    full = read_image(path, ldr_as_uint8=True)
    rows, ref = [], None
    for width in [full.shape[1]] + [w for w in widths if w < full.shape[1]]:
        pixels = full if width == full.shape[1] else lanczos_resize(full, width, width // 2)
        res = estimate_lighting(pixels)
        key = metrics.brightest_light(res.model.lights)
        row = {"photo": path.name, "width": width, "key_intensity": key["intensity"] if key else None,
               "direction": key["peak_direction"] if key else None,
               "band0": float(res.model.project(0)[0] @ LUMINANCE_WEIGHTS),
               "narrow_warning": any("pixels:" in w for w in res.warnings)}
        ref = ref or row
        row["key_over_full"] = (row["key_intensity"] / ref["key_intensity"]
                                if key and ref["key_intensity"] else None)
        row["angle_from_full_deg"] = (metrics.angle_deg(ref["direction"], row["direction"])
                                      if key and ref["direction"] is not None else None)
        row["band0_over_full"] = row["band0"] / ref["band0"]
        rows.append(row)
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m training.experiments.small_inputs", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hdri", type=Path, default=DEFAULT_HDRI, help="folder of real HDR panoramas (default: %(default)s)")
    ap.add_argument("--widths", type=int, nargs="+", default=list(WIDTHS),
                    help="panorama widths, pixels (default: %(default)s)")
    ap.add_argument("--stops", type=float, default=4.0,
                    help="clip the HDR at 2^STOPS times the JPEG's white (default: %(default)s)")
    restoring_fold_models_option(ap)
    ap.add_argument("--photos", type=Path, default=None, metavar="FOLDER",
                    help="also these real photos (*.jpg; e.g. ../shared/data/ldr), as they are and made narrower: "
                         "how their key light moves with the file's size (no truth)")
    ap.add_argument("--out", type=Path, default=None, help="write the rows and summary here (JSON)")
    args = ap.parse_args(argv)
    if any(w < 16 or w % 2 for w in args.widths):
        ap.error("--widths: each width must be even and at least 16 pixels")
    files = scene_files(args.hdri)
    estimator_of = restoring_estimators(args, files)
    skip = clipped_truth(args.hdri)
    rows = []
    for i, path in enumerate(files, 1):
        if path.name in skip:
            continue  # a truth that clips its own source is a lower bound, never a target
        got = scene_rows(path, args.widths, args.stops, estimator_of[path])
        rows += got
        for r in got:
            print(f"[{i}/{len(files)}] {r['scene']:28s} {r['capture']:40s} r {r['ratio']:8.3g}  "
                  f"C {r['contrast']:6.2f} of {r['true_contrast']:6.2f}  m/own {r['m_rmse_over_own']:.3f}", flush=True)
    summ = summary(rows)
    for name, s in summ.items():
        sel = [r for r in rows if r["capture"] == name]
        s["over_3x_off"] = sum(abs(math.log2(max(r["ratio"], 1e-12))) > math.log2(3.0) for r in sel)
        s["median_ratio"] = float(np.exp(np.median(np.log([max(r["ratio"], 1e-12) for r in sel]))))
    print("\n".join(table(summ)))
    print("\n| capture | median r | off by more than 3x |\n|---|---:|---:|")
    for name, s in summ.items():
        print(f"| {name} | {s['median_ratio']:.3g} | {s['over_3x_off']} of {s['scenes']} |")
    photos = []
    if args.photos:
        print("\n| photo | width | key light / full size's | moved | band 0 / full size's |\n|---|---:|---:|---:|---:|")
        for path in sorted(args.photos.glob("*.jpg")):
            for r in photo_rows(path):
                photos.append(r)
                key = "none" if r["key_over_full"] is None else f"{r['key_over_full']:.2f}"
                moved = "" if r["angle_from_full_deg"] is None else f"{r['angle_from_full_deg']:.1f} deg"
                print(f"| {r['photo']} | {r['width']} | {key} | {moved} | {r['band0_over_full']:.2f} |", flush=True)
    save_study({"widths": args.widths, "stops": args.stops, "fold_models": args.fold_models,
                "hdr_fold_models": args.hdr_fold_models, "summary": summ, "rows": rows, "photos": photos}, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
