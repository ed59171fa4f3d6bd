"""Training the learned estimator (``panolight train CONFIG --data DIR --out DIR``).

Data: training/neural/lighting_data.py prepares (once, cached) procedural environments, synthetic Mitsuba
panoramas and their paper-style relit versions. Two stages as in the paper: the LDR-to-HDR autoencoder
first (L2 on log(1 + HDR) against the true HDR, plus L2 on its SH-projected low-frequency lighting),
then the lighting encoder with the autoencoder frozen (0.01 L_SH + 0.3 L_RC + 0.7 L_RL,
training/neural/losses.py; scale-normalised per sample). Adam with the config's "lr" (the paper's 1e-4 in
``paper``; 1e-3 in ``small``, which gets far fewer steps on a CPU), unless ``lr`` is given.
Each epoch: progress lines, validation (loss, m-RMSE and irr-RMSE of the predicted lighting), a row in
OUT/metrics.csv, and OUT/checkpoint.pt (reloaded with torch.load(weights_only=True) to resume).
OUT/model.safetensors + OUT/config.json hold the weights of the lighting epoch with the best validation
m-RMSE (early stopping; written when it improves) for torch-free inference. The autoencoder is frozen at
its own best validation epoch (restored before the lighting stage, or exported when only it trains): a
late autoencoder epoch that diverges costs nothing. Both stages' starting points (the input's guess;
the encoder with its residual at zero) are validated too and can be what is kept: a network never
ships worse on validation than the estimator it corrects.
Run under ``torchrun --nproc_per_node N -m training.neural.torchrun`` it trains data-parallel (DDP: gloo on CPU, nccl on GPU).
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

from panolight_core import metrics, sh
from training.neural import lighting_data
from training.neural.losses import reconstruction_loss, total_loss
from training.neural.models import LightingNet, load_config

LUMINANCE = torch.tensor([0.2126, 0.7152, 0.0722])


def _distributed():
    if int(os.environ.get("WORLD_SIZE", "1")) > 1 and not torch.distributed.is_initialized():
        backend = "nccl" if torch.cuda.is_available() else "gloo"
        torch.distributed.init_process_group(backend)
    if torch.distributed.is_initialized():
        return torch.distributed.get_rank(), torch.distributed.get_world_size()
    return 0, 1


def held_out_scenes(hdr, fold) -> list[str]:
    """The scene names (file stems) of fold (K, N) of the real HDRs in folder ``hdr``: the assignment of
    ``source_energy cv`` (training.common.folds.scene_folds), so a network and the per-source model are
    scored on the same held-out scenes."""
    from training.common.folds import fold_files
    from training.common.real_hdri import scene_files

    return sorted(f.stem for f in fold_files(scene_files(Path(hdr)), fold))


def _datasets(cfg, data, procedural, val_procedural, seed, cache, log, hdr=None, hdr_copies=0, hold_out=None,
              relight_pool="procedural"):
    """Prepare (or reuse) the cached train and validation arrays (procedural and synthetic parts cached
    apart, so more Mitsuba samples do not redo the procedural ones); the first 10 % of the synthetic
    samples and of the HDR panoramas, and procedural seeds of their own, are held out. hold_out: fold
    (K, N) of the real HDRs kept out of training and validation alike (held_out_scenes), for a
    leave-scenes-out test. relight_pool: "hdr" relights the synthetic samples (Eq. 5) with the lightings of
    the real HDRs of their own split (training samples with training scenes, validation with validation
    scenes; a held-out fold with neither); "procedural": 256 procedural environments."""
    from training.synth.store import list_samples

    files = list_samples(data) if data else []
    if data and not files:
        from panolight_core.errors import PanoLightError

        raise PanoLightError(f"{data}: no synthetic samples (write some with 'panolight synth --out {data}')")
    from panolight_core.errors import PanoLightError
    from training.common.real_hdri import hdr_files

    if relight_pool not in ("procedural", "hdr"):
        raise PanoLightError(f"relight pool {relight_pool!r}: choose procedural or hdr")
    if relight_pool == "hdr" and not (hdr and files):
        raise PanoLightError("--relight-pool hdr relights the --data samples with the --hdr panoramas: give both")
    real = hdr_files(hdr) if hdr else []
    if hold_out:
        test = set(held_out_scenes(hdr, hold_out))
        real = [f for f in real if f.stem not in test]
    n_val, n_val_hdr = len(files) // 10, (max(1, len(real) // 10) if len(real) >= 2 else 0)
    h, lmax = cfg["input_height"], cfg["lmax"]
    out = []
    for name, fs, n_proc, hs, s in (("train", files[n_val:], procedural, real[n_val_hdr:], seed),
                                    ("val", files[:n_val], val_procedural, real[:n_val_hdr], seed + 500)):
        parts = []
        for what, kw in (("procedural", {"procedural": n_proc}), ("synthetic", {"synth": fs}), ("HDR", {"hdr": hs})):
            if not any(kw.values()):
                continue
            kw = {"synth": None, "procedural": 0, "hdr": None, **kw}
            if kw["hdr"]:
                kw["hdr_copies"] = hdr_copies
            if kw["synth"] and relight_pool == "hdr":
                if not hs:
                    raise PanoLightError(f"--relight-pool hdr: the {name} split has no HDR panorama to relight "
                                         f"its synthetic samples with (give at least two --hdr panoramas)")
                kw["pool_hdr"] = hs
            if cfg.get("guess", "analytic") != "analytic":
                kw.update(guess=cfg["guess"], source_model=cfg.get("source_model"))
            path = Path(cache) / lighting_data.cache_name(height=h, lmax=lmax, seed=s, **kw)
            if not path.is_file():
                count = kw["procedural"] or len(kw["synth"] or kw["hdr"]) * max(1, kw.get("hdr_copies", 0))
                log(f"preparing the {name} set's {count} {what} samples -> {path}")
                lighting_data.prepare(path, height=h, lmax=lmax, seed=s, **kw,
                                      progress=_every(lambda d, n, name=name, what=what: log(f"  {name} {what}: {d}/{n}"), 250))
            parts.append(lighting_data.load(path))
        if not parts:
            from panolight_core.errors import PanoLightError

            raise PanoLightError(f"the {name} set is empty: give --val-procedural, or more synthetic samples or "
                                 f"HDR panoramas (a tenth of each is held out for validation)")
        out.append(lighting_data.concat(parts))
    return out


def _every(fn, n):
    return lambda done, total: fn(done, total) if done % n == 0 or done == total else None


def _batch(arr, idx):
    """float32 tensors of one batch: x, log_hdr, sh, the photometric geometry and the loss scale."""
    def t(a):
        return torch.from_numpy(np.asarray(a, dtype=np.float32))

    sh_t = t(arr["sh"][idx])
    height = arr["x"].shape[-2]
    normals, image = lighting_data.probe_geometry(height)
    normals, image = np.repeat(normals[None], len(idx), 0), np.repeat(image[None], len(idx), 0)
    for j, g in enumerate(arr["geo_index"][idx]):
        if g >= 0:
            normals[j], image[j] = arr["normals"][g], arr["image"][g]
    scale = torch.clamp(sh_t[:, 0] @ LUMINANCE / math.sqrt(4 * math.pi), min=1e-3)
    return {"x": t(arr["x"][idx]), "log_hdr": t(arr["log_hdr"][idx]), "sh": sh_t, "scale": scale,
            "normals": t(normals).permute(0, 2, 3, 1), "image": t(image).permute(0, 2, 3, 1)}


def _ae_loss(ae, b, lmax):
    hdr = ae(b["x"])
    dense = ((torch.log1p(hdr) - b["log_hdr"]) ** 2).mean()
    low = reconstruction_loss(sh.project(hdr.permute(0, 2, 3, 1), lmax), b["sh"], relative=True)
    return dense + low


def _lighting_loss(model, b, weights):
    coeffs, _ = model(b["x"])
    loss, _ = total_loss(b["image"], b["normals"], coeffs, b["sh"], weights, b["scale"])
    return loss


def load_autoencoder(path, net) -> dict:
    """The autoencoder state (``ae.*`` tensors, prefix removed) of a model.safetensors for ``net``'s
    configuration, read without pickle and checked: PanoLightError naming the file when a tensor is
    missing, has another shape, or holds NaN / Inf."""
    from panolight_core.errors import PanoLightError
    from panolight_core.io.safetensors_np import load_safetensors

    weights, _ = load_safetensors(path)
    ae = {k[3:]: v for k, v in weights.items() if k.startswith("ae.")}
    for name, want in net.ae.state_dict().items():
        got = ae.get(name)
        if got is None:
            raise PanoLightError(f"{path}: no autoencoder tensor 'ae.{name}' (weights of another configuration?)")
        if tuple(got.shape) != tuple(want.shape):
            raise PanoLightError(f"{path}: tensor 'ae.{name}' has shape {tuple(got.shape)}; this configuration "
                                 f"needs {tuple(want.shape)}")
        if not np.isfinite(got).all():
            raise PanoLightError(f"{path}: tensor 'ae.{name}' holds NaN or Inf weights (a diverged training run?)")
    return {name: torch.from_numpy(np.array(ae[name], dtype=np.float32)) for name in net.ae.state_dict()}


def train(config, data, out, *, epochs: int = 10, ae_epochs: int = 2, batch_size: int = 16, lr: float | None = None,
          seed: int = 0, procedural: int = 4000, val_procedural: int = 400, cache=None, max_minutes=None,
          ae_from=None, hdr=None, hdr_copies: int = 0, hold_out=None, relight_pool: str = "procedural",
          log=print) -> dict:
    """Train ``config`` (name, path or dict) on procedural environments plus the synthetic samples under
    ``data`` (may be None); write metrics.csv, checkpoint.pt and the exported weights to ``out``.
    cache: folder of the prepared arrays (default: ``data``, else ``out``). max_minutes: stop after the
    epoch that crosses this budget (the exported model is still the best validation epoch). ae_from: a
    model.safetensors whose autoencoder to start from (with ae_epochs=0: ablations of the lighting
    stage share one trained autoencoder, as the paper's two-stage training allows). hdr: a folder of
    real HDR panoramas (Laval style) added as coupled examples; Blender's studio HDRIs are refused.
    hdr_copies: augmented views of each (source_energy's camera; 0: one plain view). hold_out: fold (K, N)
    of those scenes left out entirely (written to OUT/held_out.json for training.neural.cv). relight_pool:
    "hdr" relights the synthetic samples with the real HDRs' lightings (_datasets)."""
    cfg = load_config(config) if not isinstance(config, dict) else config
    ae_state = None if ae_from is None else load_autoencoder(ae_from, LightingNet(cfg))  # fail before any work
    rank, world = _distributed()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    torch.manual_seed(seed)
    extra = {"hdr_copies": hdr_copies, "hold_out": hold_out, "relight_pool": relight_pool}
    if rank == 0:  # one process prepares the arrays, the others then read them
        if hold_out:
            (out / "held_out.json").write_text(json.dumps({"fold": list(hold_out), "hdr": str(Path(hdr).resolve()),
                                                           "scenes": held_out_scenes(hdr, hold_out)}, indent=1))
        train_arr, val_arr = _datasets(cfg, data, procedural, val_procedural, seed, cache or data or out, log, hdr,
                                       **extra)
    if world > 1:
        torch.distributed.barrier()
    if rank != 0:
        train_arr, val_arr = _datasets(cfg, data, procedural, val_procedural, seed, cache or data or out,
                                       lambda m: None, hdr, **extra)
    net = LightingNet(cfg)
    if ae_state is not None:
        net.ae.load_state_dict(ae_state)
    opt = torch.optim.Adam(net.parameters(), lr=lr if lr is not None else cfg.get("lr", 1e-4))
    start, ckpt = 0, out / "checkpoint.pt"
    ae_best = None  # (validation m-RMSE, state) of the autoencoder's best epoch: the lighting stage starts from it
    if ckpt.is_file():
        state = torch.load(ckpt, weights_only=True)
        net.load_state_dict(state["model"])
        opt.load_state_dict(state["optimizer"])
        start = int(state["epoch"]) + 1
        if "ae_best" in state:
            ae_best = (float(state["ae_best_score"]), state["ae_best"])
        log(f"resuming from {ckpt} at epoch {start}")

    def restore_best_autoencoder():
        if ae_best is not None:
            net.ae.load_state_dict(ae_best[1])
            log(f"autoencoder: its best epoch restored (validation m-RMSE {ae_best[0]:.3f})")
    n = len(train_arr["sh"])
    history, t_start = [], time.perf_counter()
    best = min((float(r["val_m_rmse"]) for r in _read_rows(out / "metrics.csv") if r["stage"] == "lighting"),
               default=math.inf)
    def clone(module):
        return {k: v.detach().clone() for k, v in module.state_dict().items()}

    if start == 0 and ae_epochs > 0:  # the starting point is a candidate too: the input's guess, untrained
        row0 = validate(net, val_arr, "ae", cfg)
        ae_best = (row0["val_m_rmse_dense"], clone(net.ae))
        log(f"epoch 0: the autoencoder as it starts, val m-RMSE {row0['val_m_rmse_dense']:.3f}")
    for epoch in range(start, epochs):
        stage = "ae" if epoch < ae_epochs else "lighting"
        if stage == "lighting" and epoch == ae_epochs:  # the autoencoder is frozen from here: its best epoch
            restore_best_autoencoder()
            row0 = validate(net, val_arr, "lighting", cfg)  # the encoder as it starts (its residual head: 0)
            if rank == 0 and row0["val_m_rmse"] < best:
                best = row0["val_m_rmse"]
                export(net, cfg, out)
                log(f"lighting epoch 0: the encoder as it starts, val m-RMSE {best:.3f}, exported")
        for p in net.ae.parameters():
            p.requires_grad_(stage == "ae")
        # DDP syncs the parameters that train in this stage (built after freezing, so frozen ones are left out)
        part = net.ae if stage == "ae" else net
        model = torch.nn.parallel.DistributedDataParallel(part) if world > 1 else part
        order = np.random.default_rng([seed, epoch]).permutation(n)[rank::world]
        steps = max(1, len(order) // batch_size)
        model.train()
        t0, losses = time.perf_counter(), []
        for step in range(steps):
            b = _batch(train_arr, np.sort(order[step * batch_size:(step + 1) * batch_size]))
            opt.zero_grad()
            loss = _ae_loss(model, b, cfg["lmax"]) if stage == "ae" else _lighting_loss(model, b, cfg.get("loss_weights"))
            loss.backward()
            opt.step()
            losses.append(float(loss.detach()))
            if rank == 0 and (step % 50 == 0 or step == steps - 1):
                log(f"epoch {epoch + 1}/{epochs} [{stage}] step {step + 1}/{steps} loss {np.mean(losses):.4f}")
        row = {"epoch": epoch + 1, "stage": stage, "train_loss": float(np.mean(losses)),
               "seconds": time.perf_counter() - t0, **validate(net, val_arr, stage, cfg)}
        history.append(row)
        if stage == "ae" and (ae_best is None or row["val_m_rmse_dense"] < ae_best[0]):
            ae_best = (row["val_m_rmse_dense"], clone(net.ae))
        if rank == 0:
            _log_row(out / "metrics.csv", row)
            extra = {"ae_best": ae_best[1], "ae_best_score": ae_best[0]} if ae_best is not None else {}
            torch.save({"model": net.state_dict(), "optimizer": opt.state_dict(), "epoch": epoch, "config": cfg,
                        **extra}, out / "checkpoint.tmp")
            os.replace(out / "checkpoint.tmp", ckpt)
            if stage == "lighting" and row["val_m_rmse"] < best:  # early stopping: keep the best epoch
                best = row["val_m_rmse"]
                export(net, cfg, out)
                log(f"epoch {epoch + 1}: best validation m-RMSE so far, exported")
            log(f"epoch {epoch + 1}: train {row['train_loss']:.4f}, val {row['val_loss']:.4f}, val m-RMSE "
                f"{row['val_m_rmse']:.3f} (dense {row['val_m_rmse_dense']:.3f}), irr {row['val_irr_rmse']:.3f} "
                f"({row['seconds']:.0f} s)")
        if max_minutes is not None and (time.perf_counter() - t_start) / 60 > max_minutes:
            log(f"stopping after epoch {epoch + 1}: the {max_minutes} minute budget is spent")
            break
    if rank == 0 and not math.isfinite(best):  # no lighting epoch ran (autoencoder only): its best epoch
        restore_best_autoencoder()
        export(net, cfg, out)
    return {"history": history, "weights": str(out / "model.safetensors")}


def _read_rows(path: Path) -> list[dict]:
    return list(csv.DictReader(open(path))) if path.is_file() else []


@torch.no_grad()
def validate(net, arr, stage, cfg, batch_size: int = 64) -> dict:
    """Loss, and mean m-RMSE / irr-RMSE (EVALUATION.md) of the predicted lighting and of the projection
    of the autoencoder's HDR map ("dense"), over the validation arrays."""
    net.eval()
    losses, m, m_dense, irr = [], [], [], []
    lmax = cfg["lmax"]
    for i in range(0, len(arr["sh"]), batch_size):
        b = _batch(arr, np.arange(i, min(i + batch_size, len(arr["sh"]))))
        losses.append(float(_ae_loss(net.ae, b, lmax) if stage == "ae" else _lighting_loss(net, b, cfg.get("loss_weights"))))
        coeffs, hdr = net(b["x"])
        dense = sh.project(hdr.permute(0, 2, 3, 1).double(), lmax).numpy()
        for p, d, t in zip(coeffs.double().numpy(), dense, b["sh"].double().numpy()):
            m.append(metrics.m_rmse(t, p))
            m_dense.append(metrics.m_rmse(t, d))
            irr.append(metrics.irr_rmse(t, p))

    def mean(v):
        v = [e for e in v if math.isfinite(e)]
        return float(np.mean(v)) if v else float("nan")

    return {"val_loss": float(np.mean(losses)), "val_m_rmse": mean(m), "val_irr_rmse": mean(irr),
            "val_m_rmse_dense": mean(m_dense)}


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
