"""End-to-end estimate speed: read a 2048 x 1024 JPEG from disk and estimate its lighting.

The JPEG is made from each Blender studio HDRI (upsampled 2x, or ``--scale``: 8 makes 8192 x 4096; the
EVALUATION.md camera at ev 0,
quality 90) in a temporary folder. Each estimator is timed on decode + estimate, and on decode +
estimate + the default lighting model (lights + auto SH order, what ``panolight estimate`` writes),
interleaved over the scenes and repeated; medians are printed with their ratio to the 100 ms target
(issue 12; issue 3's was 50 ms for decode + estimate) and to the JPEG decode alone in the same run (issue
22's bar: the default estimate, decode included, within 12x the decode).

    python -m training.benchmarks.bench_estimate [--repeats 15] [--scenes city sunset ...] [--estimators keylight sources]
                                                 [--scale 8]
"""
from __future__ import annotations

import argparse
import statistics
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from panolight_core.camera import hdr_to_ldr
from panolight_core.data import STUDIO_HDRIS, load_studio_hdri
from panolight_core.estimators import available, estimate
from panolight_core.io import read_image, write_srgb8
from panolight_core.pipeline import fit_pixels

TARGET_MS = 100.0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=15)
    ap.add_argument("--scenes", nargs="+", default=list(STUDIO_HDRIS))
    ap.add_argument("--estimators", nargs="+", default=None, help="estimators to time (default: every one available)")
    ap.add_argument("--scale", type=int, default=2, help="upsample each 1024 x 512 HDRI this many times (default 2: "
                                                          "2048 x 1024, issue 22's bar; 8: an 8K photo)")
    args = ap.parse_args(argv)
    if args.scale < 1:
        ap.error(f"--scale is a whole upsampling factor of 1 or more, got {args.scale}")
    unknown = sorted(set(args.estimators or ()) - set(available()))
    if unknown:
        ap.error(f"unknown estimator(s) {', '.join(unknown)}: choose from {', '.join(available())}")

    with tempfile.TemporaryDirectory() as tmp:
        files = []
        for scene in args.scenes:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                hdr = load_studio_hdri(scene)
            size = f"{hdr.shape[1] * args.scale} x {hdr.shape[0] * args.scale}"
            path = Path(tmp) / f"{scene}.jpg"
            big = np.repeat(np.repeat(hdr, args.scale, axis=0), args.scale, axis=1)
            write_srgb8(path, hdr_to_ldr(big, 0), quality=90)
            del big  # not kept through the timing (800 MB at --scale 8)
            files.append(path)
        names = tuple(args.estimators or available())  # bench_neural.py has the network's forward pass alone
        times = {n: [] for n in names + tuple(f"{n} + model" for n in names) + ("decode only",)}
        for f in files:  # warm-up
            for n in names:
                estimate(read_image(f, ldr_as_uint8=True), 2, n)
        for _ in range(args.repeats):
            for f in files:
                t = time.perf_counter()
                read_image(f, ldr_as_uint8=True)
                times["decode only"].append(time.perf_counter() - t)
                for n in names:
                    t = time.perf_counter()
                    estimate(read_image(f, ldr_as_uint8=True), 2, n)
                    times[n].append(time.perf_counter() - t)
                    t = time.perf_counter()
                    fit_pixels(read_image(f, ldr_as_uint8=True), estimator=n)
                    times[f"{n} + model"].append(time.perf_counter() - t)
    print(f"# decode + estimate, {size} JPEG q90, lmax 2; {len(files)} scenes x {args.repeats} repeats\n")
    print("| estimator | median ms | p90 ms | x 100 ms target | x decode |")
    print("|---|---:|---:|---:|---:|")
    out = {}
    decode = statistics.median(times["decode only"])
    for n, ts in times.items():
        med, p90 = 1e3 * statistics.median(ts), 1e3 * float(np.percentile(ts, 90))
        out[n] = med
        print(f"| {n} | {med:.1f} | {p90:.1f} | {med / TARGET_MS:.2f} | {med / (1e3 * decode):.1f} |")
    return out


if __name__ == "__main__":
    main()
