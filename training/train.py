"""Training the learned estimator (``panolight train CONFIG --data DIR --out DIR``).

Two stages as in the paper: the LDR-to-HDR autoencoder first (L2 on log(1 + HDR) against the relit HDR
image, plus L2 on its SH-projected low-frequency lighting), then the lighting encoder with the
autoencoder frozen (0.01 L_SH + 0.3 L_RC + 0.7 L_RL, training/losses.py). Adam, lr 1e-4.
Each epoch: a progress line, validation (loss and m-RMSE of the predicted lighting), a row in
OUT/metrics.csv, and OUT/checkpoint.pt (reloaded with torch.load(weights_only=True) to resume).
At the end OUT/model.safetensors + OUT/config.json hold the weights for torch-free inference.
Run under ``torchrun --nproc_per_node N`` it trains data-parallel (DDP: gloo on CPU, nccl on GPU).
"""
from __future__ import annotations

import csv
import json
import math
import os
import time
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F

from panolight_core import metrics, sh
from training.losses import reconstruction_loss, total_loss
from training.models import LightingNet, load_config
from training.relight_data import procedural_pool, relight_dataset, synthetic_sources


def _distributed():
    if int(os.environ.get("WORLD_SIZE", "1")) > 1 and not torch.distributed.is_initialized():
        backend = "nccl" if torch.cuda.is_available() else "gloo"
        torch.distributed.init_process_group(backend)
    if torch.distributed.is_initialized():
        return torch.distributed.get_rank(), torch.distributed.get_world_size()
    return 0, 1


def _resize(x: torch.Tensor, height: int) -> torch.Tensor:
    return x if x.shape[-2] == height else F.interpolate(x, size=(height, 2 * height), mode="area")


def _ae_loss(net, batch, height):
    target = _resize(batch["relit_hdr"], height)
    hdr = net.ae(_resize(batch["input"], height))
    dense = ((torch.log1p(hdr) - torch.log1p(target)) ** 2).mean()
    lmax = net.config["lmax"]
    low = reconstruction_loss(sh.project(hdr.permute(0, 2, 3, 1), lmax), sh.project(target.permute(0, 2, 3, 1), lmax))
    return dense + low


def _lighting_loss(net, batch, height, weights):
    coeffs, _ = net(_resize(batch["input"], height))
    image = batch["image"].permute(0, 2, 3, 1)
    normals = batch["normals"].permute(0, 2, 3, 1)
    loss, parts = total_loss(image, normals, coeffs, batch["train_sh"], weights)
    return loss, coeffs


def train(config, data, out, *, epochs: int = 10, ae_epochs: int = 2, batch_size: int = 8, lr: float = 1e-4,
          seed: int = 0, workers: int = 2, val_fraction: float = 0.1, pool_size: int = 256, log=print) -> dict:
    cfg = load_config(config) if not isinstance(config, dict) else config
    rank, world = _distributed()
    out = Path(out)
    if rank == 0:
        out.mkdir(parents=True, exist_ok=True)
    torch.manual_seed(seed)
    sources = synthetic_sources(data)
    n_val = max(1, int(len(sources) * val_fraction))
    train_src, val_src = sources[n_val:], sources[:n_val]
    pool = procedural_pool(pool_size, cfg["lmax"], seed=10 ** 6 + seed)
    train_ds = relight_dataset(train_src, pool, seed=seed)
    val_ds = relight_dataset(val_src, pool, seed=seed + 10 ** 6)
    sampler = torch.utils.data.distributed.DistributedSampler(train_ds, shuffle=True, seed=seed) if world > 1 else None
    loader = torch.utils.data.DataLoader(train_ds, batch_size=batch_size, shuffle=sampler is None, sampler=sampler,
                                         num_workers=workers, drop_last=len(train_ds) > batch_size)
    val_loader = torch.utils.data.DataLoader(val_ds, batch_size=batch_size, num_workers=workers)
    net = LightingNet(cfg)
    model = torch.nn.parallel.DistributedDataParallel(net) if world > 1 else net
    opt = torch.optim.Adam(net.parameters(), lr=lr)
    start, ckpt = 0, out / "checkpoint.pt"
    if ckpt.is_file():
        state = torch.load(ckpt, weights_only=True)
        net.load_state_dict(state["model"])
        opt.load_state_dict(state["optimizer"])
        start = int(state["epoch"]) + 1
        log(f"resuming from {ckpt} at epoch {start}")
    height = cfg["input_height"]
    history = []
    for epoch in range(start, epochs):
        stage = "ae" if epoch < ae_epochs else "lighting"
        for p in net.ae.parameters():
            p.requires_grad_(stage == "ae")
        if sampler is not None:
            sampler.set_epoch(epoch)
        model.train()
        t0, losses = time.perf_counter(), []
        for step, batch in enumerate(loader):
            opt.zero_grad()
            if stage == "ae":
                loss = _ae_loss(net, batch, height)
            else:
                loss, _ = _lighting_loss(model if world == 1 else net, batch, height, cfg.get("loss_weights"))
            loss.backward()
            opt.step()
            losses.append(float(loss.detach()))
            if rank == 0 and (step % 10 == 0 or step == len(loader) - 1):
                log(f"epoch {epoch + 1}/{epochs} [{stage}] step {step + 1}/{len(loader)} loss {np.mean(losses):.4f}")
        row = {"epoch": epoch + 1, "stage": stage, "train_loss": float(np.mean(losses)),
               "seconds": time.perf_counter() - t0, **_validate(net, val_loader, height, stage, cfg)}
        history.append(row)
        if rank == 0:
            _log_row(out / "metrics.csv", row)
            torch.save({"model": net.state_dict(), "optimizer": opt.state_dict(), "epoch": epoch, "config": cfg},
                       out / "checkpoint.tmp")
            os.replace(out / "checkpoint.tmp", ckpt)
            log(f"epoch {epoch + 1}: train {row['train_loss']:.4f}, val {row['val_loss']:.4f}, "
                f"val m-RMSE {row['val_m_rmse']:.3f} ({row['seconds']:.0f} s)")
    if rank == 0:
        export(net, cfg, out)
    return {"history": history, "weights": str(out / "model.safetensors")}


@torch.no_grad()
def _validate(net, loader, height, stage, cfg):
    net.eval()
    losses, errors = [], []
    for batch in loader:
        if stage == "ae":
            losses.append(float(_ae_loss(net, batch, height)))
        else:
            loss, _ = _lighting_loss(net, batch, height, cfg.get("loss_weights"))
            losses.append(float(loss))
        coeffs, _ = net(_resize(batch["input"], height))
        for p, t in zip(coeffs.numpy(), batch["train_sh"].numpy()):
            errors.append(metrics.m_rmse(t.astype(np.float64), p.astype(np.float64)))
    return {"val_loss": float(np.mean(losses)), "val_m_rmse": float(np.mean([e for e in errors if math.isfinite(e)]))}


def _log_row(path: Path, row: dict):
    new = not path.is_file()
    with open(path, "a", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(row))
        if new:
            w.writeheader()
        w.writerow(row)


def export(net, cfg, out):
    """model.safetensors (no pickle; loadable without torch) and config.json."""
    from safetensors.torch import save_file

    save_file({k: v.detach().contiguous() for k, v in net.state_dict().items()}, str(Path(out) / "model.safetensors"),
              metadata={"config": json.dumps(cfg)})
    (Path(out) / "config.json").write_text(json.dumps(cfg, indent=2) + "\n")


def main(argv=None):
    """``python -m training.train ...`` (what torchrun launches): the arguments of ``panolight train``."""
    import sys

    from panolight_core.cli import main as cli_main

    return cli_main(["train", *(sys.argv[1:] if argv is None else argv)])


if __name__ == "__main__":
    raise SystemExit(main())
