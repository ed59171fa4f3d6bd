"""How the LDR estimators do on procedural environments (panolight_core/synthetic.py).

The public HDRIs are only eight scenes; this checks the clipped-highlight model on many synthetic
skies (clear and overcast, sun at 3-75 degrees) and rooms (lamps, windows), whose true lighting is
known exactly, at ev -2, 0, +2. Nothing is fitted: it reports mean m-RMSE / irr-RMSE per kind of scene.

    python -m training.synth.evaluate [--count 60] [--height 256] [--seed 100000] [--jpeg 90]
"""
from __future__ import annotations

import argparse

import numpy as np

from panolight_core import metrics, sh
from panolight_core.camera import hdr_to_ldr
from panolight_core.estimators import estimate
from panolight_core.synthetic import environment

EVS = (-2.0, 0.0, 2.0)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--count", type=int, default=60, help="environments (default 60)")
    ap.add_argument("--height", type=int, default=256)
    ap.add_argument("--seed", type=int, default=100000, help="first seed (default 100000)")
    ap.add_argument("--jpeg", type=int, default=90, help="JPEG quality of the inputs (default 90; 0 = none)")
    args = ap.parse_args(argv)
    scores: dict = {}
    for seed in range(args.seed, args.seed + args.count):
        hdr, params = environment(seed, args.height)
        kind = params["kind"] + (" overcast" if params.get("overcast") else "")
        gt = sh.project(hdr, 2)
        for ev in EVS:
            ldr = hdr_to_ldr(hdr, ev, args.jpeg or None)
            for name in ("naive", "analytic"):
                c = estimate(ldr, 2, name).coeffs
                scores.setdefault((kind, ev, name), []).append((metrics.m_rmse(gt, c), metrics.irr_rmse(gt, c)))
    print("| scene kind | ev | n | naive m-RMSE / irr-RMSE | analytic m-RMSE / irr-RMSE |")
    print("|---|---:|---:|---:|---:|")
    for kind in sorted({k[0] for k in scores}):
        for ev in EVS:
            n = np.mean(scores[(kind, ev, "naive")], axis=0)
            a = np.mean(scores[(kind, ev, "analytic")], axis=0)
            print(f"| {kind} | {ev:+g} | {len(scores[(kind, ev, 'naive')])} | {n[0]:.3f} / {n[1]:.3f} | "
                  f"{a[0]:.3f} / {a[1]:.3f} |")
    return scores


if __name__ == "__main__":
    main()
