"""SH engine speed against peers, in one process, on this machine.

Prints markdown tables: projection of a 1024 x 512 x 3 float32 panorama at lmax 2, 8, 20 by
  ours (numpy, torch), a naive per-pixel numpy implementation (basis at every pixel, then a weighted
  sum), sphericart and e3nn (when installed; same per-pixel approach with their basis), and the time
  to read the image once (one pass over memory: the bandwidth floor), plus reconstruction and
  irradiance. Medians of repeated runs; ratios are against ours (numpy) from the same run.
Agreement is checked with per-band power sum_m c_lm^2, which does not depend on each library's
frame, ordering or sign convention.

    python -m training.benchmarks.bench_sh [--height 512] [--lmax 2 8 20] [--json out.json]
"""
from __future__ import annotations

import argparse
import json
import platform
import statistics
import time

import numpy as np

from panolight_core import sh

ROW_BLOCK = 32  # rows per chunk for per-pixel peers (bounds their (N, K) basis memory)


def median_time(fn, min_runs=5, budget_s=2.0):
    fn()  # warm-up (tables, caches, JIT)
    times = []
    start = time.perf_counter()
    while len(times) < min_runs or (time.perf_counter() - start < budget_s and len(times) < 50):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def band_power(c, lmax):
    c = np.asarray(c, dtype=np.float64)
    return np.array([(c[l * l:(l + 1) ** 2] ** 2).sum() for l in range(lmax + 1)])


_GRID = {}


def grid(h, w):
    """Pixel directions and solid angles, computed once per size so peers are timed at their best."""
    if (h, w) not in _GRID:
        _GRID[(h, w)] = (sh.pixel_directions(h, w), sh.pixel_solid_angles(h, w))
    return _GRID[(h, w)]


def naive_numpy(img, lmax):
    h, w, _ = img.shape
    d, wts = grid(h, w)
    out = 0
    for y0 in range(0, h, ROW_BLOCK):
        y = sh.basis(d[y0:y0 + ROW_BLOCK].reshape(-1, 3), lmax).astype(img.dtype)
        out = out + y.T @ (img[y0:y0 + ROW_BLOCK].reshape(-1, 3) * wts[y0:y0 + ROW_BLOCK].reshape(-1, 1))
    return out


def make_sphericart(lmax):
    try:
        import sphericart
    except ImportError:
        return None
    calc = sphericart.SphericalHarmonics(lmax)

    def run(img):
        h, w, _ = img.shape
        d, wts = grid(h, w)
        out = 0
        for y0 in range(0, h, ROW_BLOCK):
            y = calc.compute(np.ascontiguousarray(d[y0:y0 + ROW_BLOCK].reshape(-1, 3)))
            out = out + y.T.astype(img.dtype) @ (img[y0:y0 + ROW_BLOCK].reshape(-1, 3) *
                                                 wts[y0:y0 + ROW_BLOCK].reshape(-1, 1))
        return out
    return run


def make_e3nn(lmax):
    try:
        import torch
        from e3nn import o3
    except ImportError:
        return None
    if lmax > 12:
        return "supports l <= 12 only"

    def run(img):
        h, w, _ = img.shape
        d_np, w_np = grid(h, w)
        d = torch.from_numpy(d_np.astype(np.float32))
        wts = torch.from_numpy(w_np.astype(np.float32))
        t = torch.from_numpy(img)
        out = 0
        for y0 in range(0, h, ROW_BLOCK):
            y = o3.spherical_harmonics(list(range(lmax + 1)), d[y0:y0 + ROW_BLOCK].reshape(-1, 3), normalize=True,
                                       normalization="integral")
            out = out + y.T @ (t[y0:y0 + ROW_BLOCK].reshape(-1, 3) * wts[y0:y0 + ROW_BLOCK].reshape(-1, 1))
        return out.numpy()
    return run


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--height", type=int, default=512, help="panorama height (width = 2 x height); default 512")
    ap.add_argument("--lmax", type=int, nargs="+", default=[2, 8, 20])
    ap.add_argument("--budget", type=float, default=1.5, help="seconds of repeats per measurement (default 1.5)")
    ap.add_argument("--json", help="also write the results as JSON here")
    ap.add_argument("--plot", help="also save a PNG plot of projection time against lmax here")
    args = ap.parse_args(argv)
    h, w = args.height, 2 * args.height
    rng = np.random.default_rng(0)
    img = (rng.random((h, w, 3)) ** 4 * 10).astype(np.float32)
    try:
        import torch
        timg = torch.from_numpy(img)
        torch.set_num_threads(max(1, torch.get_num_threads()))
    except ImportError:
        torch, timg = None, None

    floor = median_time(lambda: img.sum(), budget_s=args.budget)
    print(f"# SH projection benchmark: {w} x {h} x 3 float32, {platform.processor() or platform.machine()}, "
          f"numpy {np.__version__}" + (f", torch {torch.__version__} ({torch.get_num_threads()} threads)" if torch else ""))
    print(f"\nread floor (one pass over the {img.nbytes / 2**20:.1f} MB image, img.sum()): {floor * 1e3:.2f} ms\n")
    results = {"width": w, "height": h, "read_floor_ms": floor * 1e3, "projection": [], "reconstruction": [],
               "irradiance": []}
    print("| lmax | method | median ms | x read floor | x ours (numpy) | max band-power rel. diff |")
    print("|---:|---|---:|---:|---:|---:|")
    for lmax in args.lmax:
        ours = sh.project(img, lmax)
        ref_power = band_power(ours, lmax)
        t_ours = median_time(lambda: sh.project(img, lmax), budget_s=args.budget)
        methods = [("ours (numpy)", lambda: sh.project(img, lmax), t_ours)]
        if torch is not None:
            methods.append(("ours (torch)", lambda: sh.project(timg, lmax), None))
        methods.append(("naive per-pixel numpy", lambda: naive_numpy(img, lmax), None))
        for name, factory in (("sphericart", make_sphericart), ("e3nn", make_e3nn)):
            fn = factory(lmax)
            if fn is None or isinstance(fn, str):
                print(f"| {lmax} | {name} | {fn or 'not installed'} | | | |")
            else:
                methods.append((name, (lambda f=fn: f(img)), None))
        for name, fn, t in methods:
            t = t if t is not None else median_time(fn, min_runs=3, budget_s=args.budget)
            out = fn()
            out = out.numpy() if hasattr(out, "numpy") else np.asarray(out)
            diff = np.max(np.abs(band_power(out, lmax) - ref_power) / ref_power.max())
            print(f"| {lmax} | {name} | {t * 1e3:.2f} | {t / floor:.1f} | {t / t_ours:.2f} | {diff:.1e} |")
            results["projection"].append({"lmax": lmax, "method": name, "ms": t * 1e3, "x_floor": t / floor,
                                          "x_ours": t / t_ours, "band_power_rel_diff": float(diff)})
    print("\n| lmax | reconstruct 1024x512 ms | irradiance at 524288 normals ms | R&H 4x4 form ms |")
    print("|---:|---:|---:|---:|")
    normals = sh.pixel_directions(h, w).reshape(-1, 3).astype(np.float32)
    for lmax in args.lmax:
        c = sh.project(img, lmax)
        t_rec = median_time(lambda: sh.reconstruct(c, h, w), budget_s=args.budget)
        t_irr = median_time(lambda: sh.irradiance(c, normals), min_runs=3, budget_s=args.budget)
        t_rh = median_time(lambda: sh.irradiance_rh(c, normals), min_runs=3, budget_s=args.budget) if lmax == 2 else None
        print(f"| {lmax} | {t_rec * 1e3:.2f} | {t_irr * 1e3:.2f} | {'' if t_rh is None else f'{t_rh * 1e3:.2f}'} |")
        results["reconstruction"].append({"lmax": lmax, "ms": t_rec * 1e3})
        results["irradiance"].append({"lmax": lmax, "ms": t_irr * 1e3, "rh_ms": None if t_rh is None else t_rh * 1e3})
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=2)
    if args.plot:
        plot(results, args.plot)
    return results


def plot(results, path):
    """Log-scale projection time per method against lmax, with the read floor as a line."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.0), dpi=110)
    methods = sorted({r["method"] for r in results["projection"]}, key=lambda m: (not m.startswith("ours"), m))
    for m in methods:
        rows = [r for r in results["projection"] if r["method"] == m]
        ax.plot([r["lmax"] for r in rows], [r["ms"] for r in rows], "o-", label=m, lw=2.5 if "ours" in m else 1.2)
    ax.axhline(results["read_floor_ms"], color="k", ls=":", label="read floor (one pass over the image)")
    ax.set_yscale("log")
    ax.set_xlabel("SH order lmax")
    ax.set_ylabel("median ms per projection")
    ax.set_title(f"SH projection of a {results['width']} x {results['height']} x 3 float32 panorama")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


if __name__ == "__main__":
    main()
