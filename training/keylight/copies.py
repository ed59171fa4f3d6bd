"""The key light of a saved-again or downsized camera JPEG, over the real HDRs with a dominant source.

A photo a user gets has often been saved again or made smaller. ``training.keylight.turns`` asks this of the
real photos, which have no truth; here the truth is known. For every scene of ../shared/data/hdri with a dominant
compact source and an un-clipped truth, at each ev: the camera JPEG (EVALUATION.md, q90) as it is, saved again at
JPEG quality 90, and halved (Lanczos) then saved at quality 90 (``turns.copies``). Each copy's default estimate is
scored as ``training.keylight.cv`` scores it: its brightest key light's angle to the source and the source's energy
ratio r (EVALUATION.md) from its ``hdr.exr`` against the truth at the copy's size (area-averaged), and whether its
key light is the one the JPEG as it is gets (within 3 degrees and 1.5x, or none in both).

    python -m training.keylight.copies [--evs -2 0 2] [--fold-models 'runs/folds/sources_{k}.safetensors']
                                       [--out docs/studies/keylight_copies.json]
"""
from __future__ import annotations

import statistics
from pathlib import Path

import numpy as np

from panolight_core import metrics
from panolight_core.camera import hdr_to_ldr
from panolight_core.camera.resample import area_downsample
from panolight_core.estimators.keylight import key_light_range
from panolight_core.pipeline.estimate import estimate_lighting
from panolight_core.pipeline.settings import Settings
from training.common.real_hdri import clipped_truth, load_hdr, scene_files
from training.common.study import fold_estimators, fold_models_option, nested_table, real_hdri_parser, save_study
from training.keylight import turns

QUALITY = 90


def score_copies(hdr: np.ndarray, ds: dict, ev: float, estimator: str = "auto") -> list[dict]:
    """Per copy of the camera JPEG of ``hdr`` at ``ev`` (``turns.copies``: as it is, saved again, halved): its
    brightest key light (direction, intensity, source; None without one), the angle to the dominant source ``ds``
    (180 degrees without a light), r, and "same": the light is the first copy's (3 degrees, 1.5x)."""
    ldr = hdr_to_ldr(hdr, ev, QUALITY)
    rows = []
    for label, px in turns.copies(ldr, (ldr.shape[1] // 2,), QUALITY):
        res = estimate_lighting(px, Settings(estimator=estimator))
        brightest = key_light_range(res.document)
        key = None if brightest is None else res.document["lights"][brightest["index"]]
        truth = hdr if px.shape[:2] == hdr.shape[:2] else area_downsample(hdr, px.shape[0])
        rows.append({"copy": label, "key": turns.key_row(key, 0, px.shape[1]),
                     "angle_deg": round(metrics.angle_deg(ds["direction"], key["direction"]), 3) if key else 180.0,
                     "ratio": metrics.source_energy_ratio(truth, res.hdr_panorama(px), ds["direction"])})
    return turns.mark_same(rows, 3.0, 1.5)


def summary(rows: list[dict]) -> dict:
    """Per ev and copy: scenes, median direction error, energy "within" (2^median |log2 r|), scenes with no key
    light, and how many keep the key light of the JPEG as it is."""
    out = {}
    for ev in sorted({r["ev"] for r in rows}):
        sel = [r for r in rows if r["ev"] == ev]
        for i, label in enumerate(c["copy"] for c in sel[0]["copies"]):
            got = [r["copies"][i] for r in sel]
            out.setdefault(f"{ev:+g}", {})[label] = {
                "scenes": len(got), "median_angle_deg": statistics.median(c["angle_deg"] for c in got),
                "within": metrics.ratio_within(c["ratio"] for c in got),
                "no_key_light": sum(c["key"] is None for c in got), "same_as_the_jpeg": sum(c["same"] for c in got)}
    return out


def table(summ: dict) -> list[str]:
    return nested_table(["| ev | copy | direction, median | energy within | no key light | the JPEG's key light |",
                         "|---:|---|---:|---:|---:|---:|"], summ, lambda ev, label, s: (
        f"{ev} | {label} | {s['median_angle_deg']:.1f} deg | {s['within']:.2f}x | {s['no_key_light']} | "
        f"{s['same_as_the_jpeg']} of {s['scenes']}"))


def main(argv=None) -> int:
    ap = real_hdri_parser("python -m training.keylight.copies", __doc__)
    fold_models_option(ap)
    ap.add_argument("--out", type=Path, default=None, help="write the rows and summary as JSON here")
    args = ap.parse_args(argv)
    files = scene_files(args.hdri)
    clipped = clipped_truth(args.hdri)
    estimator_of = fold_estimators(args.fold_models, files) if args.fold_models else dict.fromkeys(files, "auto")
    rows = []
    for i, p in enumerate(files, 1):
        if p.name in clipped:
            continue
        hdr = load_hdr(p)
        ds = metrics.dominant_source(hdr)
        if not ds["dominant"]:
            continue
        for ev in args.evs:
            got = score_copies(hdr, ds, ev, estimator_of[p])
            rows.append({"scene": p.stem, "ev": ev, "copies": got})
            print(f"[{i}/{len(files)}] {p.stem:28s} ev {ev:+g}: " + "; ".join(
                f"{c['copy']} {c['angle_deg']:.1f} deg r {c['ratio']:.3g}{'' if c['same'] else ' (another)'}"
                for c in got), flush=True)
    summ = summary(rows)
    print("\n".join(table(summ)))
    save_study({"fold_models": args.fold_models, "summary": summ, "rows": rows}, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
