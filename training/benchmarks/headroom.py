"""How good can any LDR estimator get on the public set? Oracles that know part of the clipped truth.

For each Blender studio HDRI at ev 0 (EVALUATION.md camera, JPEG q90) the clipped pixels of the LDR
(brightest channel >= 254) are replaced by the true exposed HDR radiance capped at C times the clip
level, the rest stays the linearised LDR, and the result is projected (lmax 2) and scored. C = 1 is the
naive baseline; C = inf knows every clipped value. The table says how much of the clipped dynamic
range an estimator must recover, at the right pixels, to reach a given mean m-RMSE / irr-RMSE: the
issue-6 bar (25 % better than naive: m-RMSE 0.842, irr-RMSE 0.358) is met only for C between 100
and 300 (m-RMSE) and about 30 (irr-RMSE).

    python -m training.benchmarks.headroom [--out docs/headroom.md]
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from panolight_core import metrics, sh
from panolight_core.camera import auto_exposure, clipped_mask, hdr_to_ldr, ldr_to_linear
from panolight_core.data import STUDIO_HDRIS, load_studio_hdri

CAPS = (1.0, 3.0, 10.0, 30.0, 100.0, 300.0, 1000.0, 1e4, float("inf"))


def run(caps=CAPS, ev: float = 0.0, jpeg_quality: int = 90) -> dict:
    """{cap: [(scene, m_rmse, irr_rmse), ...]} for oracle-filled clipped pixels."""
    out = {c: [] for c in caps}
    for scene in STUDIO_HDRIS:
        hdr = load_studio_hdri(scene)
        gt = sh.project(hdr, 2)
        k = auto_exposure(hdr, ev)
        ldr = hdr_to_ldr(hdr, ev, jpeg_quality)
        lin, clip = ldr_to_linear(ldr).astype(np.float64), clipped_mask(ldr)[..., None]
        for c in caps:
            q = sh.project(np.where(clip, np.minimum(hdr * k, c), lin), 2)
            out[c].append((scene, metrics.m_rmse(gt, q), metrics.irr_rmse(gt, q)))
    return out


def markdown(result: dict) -> str:
    scenes = [s for s, _, _ in next(iter(result.values()))]
    lines = ["| clipped pixels known up to | " + " | ".join(scenes) + " | mean m-RMSE | mean irr-RMSE |",
             "|---|" + "---:|" * (len(scenes) + 2)]
    for c, rows in result.items():
        label = "nothing (naive)" if c == 1 else ("everything" if c == float("inf") else f"{c:g} x clip level")
        lines.append(f"| {label} | " + " | ".join(f"{m:.2f}" for _, m, _ in rows)
                     + f" | {np.mean([m for _, m, _ in rows]):.3f} | {np.mean([i for _, _, i in rows]):.3f} |")
    return "\n".join(lines) + "\n\ncells: m-RMSE per scene at ev 0 (JPEG q90); lower is better\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m training.benchmarks.headroom", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default=None, help="also write the table to this markdown file")
    args = ap.parse_args(argv)
    table = markdown(run())
    print(table)
    if args.out:
        Path(args.out).write_text("# Headroom: oracles that know the clipped radiance\n\n" + table)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
