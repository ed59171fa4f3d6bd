"""Training-data speed: rendering samples per second (by resolution and spp) and on-the-fly relighting
pairs per second (one process, and a DataLoader with workers), plus disk per sample.

    python -m training.benchmarks.bench_synth [--samples 6]
"""
from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--samples", type=int, default=6, help="samples rendered per configuration (default 6)")
    args = ap.parse_args(argv)
    import torch

    from training.neural.relight_data import procedural_pool, relight_dataset, synthetic_sources
    from training.render import mitsuba as mr
    from training.synth import store

    variant = mr.mitsuba().variant()
    # Fresh seeds every run: Dr.Jit caches compiled kernels on disk, and a scene seen before renders
    # without LLVM compilation, which a real dataset build (new scenes) does not enjoy.
    base = 10 ** 7 + int(time.time()) % 10 ** 6 * 10
    print(f"# synthetic data speed ({variant}, {torch.get_num_threads()} torch threads)\n")
    print("| resolution | spp | s / sample (median) | samples / s | MB / sample |")
    print("|---|---:|---:|---:|---:|")
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        for height, spp in ((64, 16), (128, 16), (128, 64)):
            root = Path(tmp) / f"{height}-{spp}"
            store.synthesize(root, 1, height, spp, base_seed=base)  # warm-up (imports, envmap tables)
            times = []
            for i in range(args.samples):
                t = time.perf_counter()
                store.write_sample(store.sample_path(root, 1 + i), __import__("training.synth.scenes", fromlist=["x"])
                                   .sample(base + 1 + i, height, spp))
                times.append(time.perf_counter() - t)
            size = np.mean([p.stat().st_size for p in store.list_samples(root)]) / 2 ** 20
            med = statistics.median(times)
            results[(height, spp)] = (med, size)
            print(f"| {2 * height}x{height} | {spp} | {med:.2f} | {1 / med:.2f} | {size:.2f} |")
        root = Path(tmp) / "128-16"
        ds = relight_dataset(synthetic_sources(root), procedural_pool(64), seed=0)
        ds[0]
        t = time.perf_counter()
        n = 0
        for _ in range(3):
            for i in range(len(ds)):
                ds[i]
                n += 1
        single = n / (time.perf_counter() - t)
        loader = torch.utils.data.DataLoader(ds, batch_size=4, num_workers=2, persistent_workers=True)
        list(loader)
        t = time.perf_counter()
        m = sum(b["input"].shape[0] for _ in range(3) for b in loader)
        workers = m / (time.perf_counter() - t)
    print(f"\nrelighting pairs per second at 256x128 (load + blend + relight + LDR): {single:.1f} in one process, "
          f"{workers:.1f} with a 2-worker DataLoader")
    for spp in (16, 64):
        med, size = results[(128, spp)]
        print(f"\n2,000 samples at 256x128, {spp} spp{' (the default)' if spp == 64 else ''}: about "
              f"{2000 * med / 60:.0f} min and {2000 * size / 1024:.2f} GB on this machine (extrapolated from the median)")
    return results


if __name__ == "__main__":
    main()
