"""Latency of the learned estimator's networks (random weights are fine for timing): the ``small``
configuration and the shipped one (its config from models/small.safetensors) against the ``paper``-size one, torch and numpy paths, one LDR panorama at each
configuration's input size, medians of repeated runs in one process; then the whole numpy estimate
(input reduction + the guess + network) on a 1024 x 512 LDR, against the analytic and per-source ones.

    python -m training.benchmarks.bench_neural [--repeats 7]
"""
from __future__ import annotations

import argparse

import torch

from panolight_core.estimators.nn.inputs import CHANNELS
from panolight_core.estimators.nn.model import forward
from training.benchmarks import median_seconds
from training.neural.models import LightingNet, load_config


def median_ms(fn, repeats):
    return 1e3 * median_seconds(fn, repeats)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=7)
    args = ap.parse_args(argv)
    torch.manual_seed(0)
    rows = {}
    print(f"# learned-estimator latency ({torch.get_num_threads()} torch threads), batch 1\n")
    print("| config | input | parameters | MB (float32) | torch ms | numpy ms |")
    print("|---|---|---:|---:|---:|---:|")
    from panolight_core.estimators.nn.estimator import load_model

    shipped = load_model().config
    configs = {"small": load_config("small"), f"shipped ({shipped.get('name', '?')})": shipped,
               "paper": load_config("paper")}
    for name, cfg in configs.items():
        net = LightingNet({k: v for k, v in cfg.items() if k != "source_model"}).eval()
        h = cfg["input_height"]
        x = torch.rand(1, CHANNELS, h, 2 * h)
        weights = {k: v.detach().numpy() for k, v in net.state_dict().items()}
        with torch.no_grad():
            t_torch = median_ms(lambda: net(x), args.repeats)
        t_np = median_ms(lambda: forward(weights, cfg, x.numpy()), max(3, args.repeats // 2))
        n = sum(p.numel() for p in net.parameters())
        rows[name] = (t_torch, t_np)
        print(f"| {name} | {2 * h}x{h} | {n:,} | {n * 4 / 2 ** 20:.1f} | {t_torch:.1f} | {t_np:.1f} |")
    p = rows["paper"]
    for name in list(configs)[:2]:
        s = rows[name]
        print(f"\n{name} vs paper: {p[0] / s[0]:.0f}x faster with torch, {p[1] / s[1]:.0f}x faster with numpy")
    from panolight_core.camera import hdr_to_ldr
    from panolight_core.data import load_studio_hdri
    from panolight_core.estimators import available, estimate

    ldr = hdr_to_ldr(load_studio_hdri("city"), 0.0, 90)
    print("\n| whole estimate, 1024x512 LDR in memory | median ms |\n|---|---:|")
    for name in [n for n in ("analytic", "sources", "neural") if n in available()]:
        rows[f"estimate-{name}"] = median_ms(lambda: estimate(ldr, 2, name), args.repeats)
        print(f"| {name} | {rows[f'estimate-{name}']:.1f} |")
    return rows


if __name__ == "__main__":
    main()
