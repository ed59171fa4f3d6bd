"""Fit the clipped-highlight gain model on synthetic environments (never on the public HDRIs).

For each synthetic HDR environment and ev in {-2, 0, +2}: make the LDR input with the EVALUATION.md
camera model, find its clipped blobs, and measure the true mean radiance G inside each blob (in units
of the clip level). Fit log(G - 1) = A + B log(solid angle) + C p by least squares. The fit predicts a
geometric mean with a wide spread, and over-estimated suns cost far more than under-estimated ones, so
a shrinkage lambda (A += log lambda) is then chosen on separate validation seeds to minimise the sum of
mean m-RMSE and irr-RMSE relative to naive (lambda = 0 would be naive). Finally the end-to-end m-RMSE /
irr-RMSE of naive vs analytic are reported on held-out test seeds.

    python -m training.calibrate_highlights [--train 240] [--test 80] [--height 256]
"""
from __future__ import annotations

import argparse

import numpy as np

from panolight_core import metrics, sh
from panolight_core.camera import auto_exposure, hdr_to_ldr, ldr_to_linear
from panolight_core.color import LUMINANCE_WEIGHTS
from panolight_core.highlights import CLIP_LEVEL, area_downsample, blob_features, recover_highlights
from training.synth.environments import environment

EVS = (-2.0, 0.0, 2.0)


def blob_samples(seeds, height, work_height=128):
    rows = []
    for seed in seeds:
        hdr, _ = environment(seed, height)
        for ev in EVS:
            lin = ldr_to_linear(hdr_to_ldr(hdr, ev)).astype(np.float64)
            sat = (lin.max(axis=-1, keepdims=True) >= CLIP_LEVEL).astype(np.float64)
            small = area_downsample(np.concatenate([lin, sat], -1), work_height)
            truth = area_downsample(hdr * auto_exposure(hdr, ev), work_height) @ LUMINANCE_WEIGHTS
            omega = sh.pixel_solid_angles(*truth.shape)
            for f in blob_features(small[..., :3], small[..., 3]):
                m = f["mask"]
                g = float((truth * omega * m).sum() / (omega * m).sum())
                rows.append((np.log(f["solid_angle"]), f["exponent"], g))
    return np.array(rows)


def fit(rows):
    keep = rows[:, 2] > 1.05
    x = np.column_stack([np.ones(keep.sum()), rows[keep, 0], rows[keep, 1]])
    y = np.log(rows[keep, 2] - 1.0)
    coef, *_ = np.linalg.lstsq(x, y, rcond=None)
    resid = y - x @ coef
    return tuple(float(c) for c in coef), float(np.sqrt(np.mean(resid ** 2))), int(keep.sum())


def evaluate(seeds, height, model):
    out = {"naive": [[], []], "analytic": [[], []]}
    for seed in seeds:
        hdr, _ = environment(seed, height)
        gt = sh.project(hdr, 2)
        for ev in EVS:
            lin = ldr_to_linear(hdr_to_ldr(hdr, ev)).astype(np.float64)
            preds = {"naive": sh.project(lin, 2), "analytic": sh.project(recover_highlights(lin, model=model)[0], 2)}
            for k, q in preds.items():
                out[k][0].append(metrics.m_rmse(gt, q))
                out[k][1].append(metrics.irr_rmse(gt, q))
    return {k: (float(np.mean(v[0])), float(np.mean(v[1]))) for k, v in out.items()}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--train", type=int, default=240)
    ap.add_argument("--val", type=int, default=40)
    ap.add_argument("--test", type=int, default=80)
    ap.add_argument("--height", type=int, default=256)
    args = ap.parse_args(argv)
    rows = blob_samples(range(args.train), args.height)
    model, rms, n = fit(rows)
    print(f"fitted on {n} clipped blobs from {args.train} synthetic environments x {len(EVS)} exposures")
    print(f"least squares: A, B, C = ({model[0]:.4f}, {model[1]:.4f}, {model[2]:.4f}), log-residual rms {rms:.2f}")
    val = range(50000, 50000 + args.val)
    base = evaluate(val, args.height, model)["naive"]
    best = None
    for lam in (1.0, 0.5, 0.3, 0.2, 0.1, 0.05, 0.02, 0.01):
        cand = (model[0] + np.log(lam), model[1], model[2])
        m, e = evaluate(val, args.height, cand)["analytic"]
        score = m / base[0] + e / base[1]
        print(f"  lambda {lam:<5} validation m-RMSE {m:.3f} irr-RMSE {e:.3f} (naive {base[0]:.3f} / {base[1]:.3f})")
        if best is None or score < best[0]:
            best = (score, lam, cand)
    model = best[2]
    print(f"GAIN_MODEL = ({model[0]:.4f}, {model[1]:.4f}, {model[2]:.4f})   # lambda {best[1]}")
    test = range(100000, 100000 + args.test)
    res = evaluate(test, args.height, model)
    print(f"held-out {args.test} environments x {len(EVS)} exposures, mean m-RMSE / irr-RMSE:")
    for k, (m, e) in res.items():
        print(f"  {k:9s} {m:.3f} / {e:.3f}")
    return model, res


if __name__ == "__main__":
    main()
