"""The synthetic dataset on disk: sharded folders of compressed NPZ samples, resumable.

DIR/shard-0000/sample-0000000.npz ... (SHARD_SIZE samples per folder), each with
  radiance (H, W, 3) float32 linear HDR (float16 would overflow on suns), normals (H, W, 3) float16 unit
  vectors (0 without a surface), albedo (H, W, 3) float16, mask (H, W) bool, sh (81, 3) float32 (the
  radiance's SH to lmax 8: the lighting at the camera), params (JSON text: scene parameters and seed).
Sample i is rendered from seed ``base_seed + i``, so any process can render any sample; ``--shard I/N``
gives process I the indices i with i mod N == I - 1. Files are written to a temporary name and renamed,
so an interrupted run leaves no half samples and a re-run skips the finished ones.
"""
from __future__ import annotations

import json
import os
import time
from pathlib import Path

import numpy as np

from panolight_core import sh

SHARD_SIZE = 500
SH_ORDER = 8


def sample_path(root, index: int) -> Path:
    return Path(root) / f"shard-{index // SHARD_SIZE:04d}" / f"sample-{index:07d}.npz"


def write_sample(path: Path, out: dict) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.stem}.tmp{os.getpid()}.npz")
    np.savez_compressed(tmp, radiance=out["radiance"].astype(np.float32), normals=out["normals"].astype(np.float16),
                        albedo=out["albedo"].astype(np.float16), mask=out["mask"].astype(bool),
                        sh=sh.project(out["radiance"], SH_ORDER).astype(np.float32),
                        params=np.array(json.dumps(out["params"])))
    os.replace(tmp, path)


def read_sample(path) -> dict:
    """A stored sample as float arrays (normals and albedo back to float32) plus params (dict)."""
    with np.load(path, allow_pickle=False) as z:
        return {"radiance": z["radiance"], "normals": z["normals"].astype(np.float32),
                "albedo": z["albedo"].astype(np.float32), "mask": z["mask"], "sh": z["sh"],
                "params": json.loads(str(z["params"]))}


def is_complete(path: Path) -> bool:
    if not path.is_file():
        return False
    try:
        with np.load(path, allow_pickle=False) as z:
            return {"radiance", "normals", "albedo", "mask", "sh", "params"} <= set(z.files)
    except Exception:  # a damaged file is rendered again
        return False


def list_samples(root) -> list[Path]:
    """Every finished sample under ``root``, sorted."""
    return sorted(Path(root).glob("shard-*/sample-*.npz"))


def synthesize(root, count: int, height: int = 128, spp: int = 64, base_seed: int = 0, shard=(1, 1),
               progress=None) -> dict:
    """Render samples 0..count-1 of this shard that are not on disk yet. Returns counts and timings."""
    from training.synth.scenes import sample

    i_shard, n_shard = shard
    todo = [i for i in range(count) if i % n_shard == i_shard - 1]
    done = skipped = 0
    t0 = time.perf_counter()
    for i in todo:
        path = sample_path(root, i)
        if is_complete(path):
            skipped += 1
            if progress:
                progress(path.name, "skip")
            continue
        write_sample(path, sample(base_seed + i, height, spp))
        done += 1
        if progress:
            progress(path.name, "ok")
    seconds = time.perf_counter() - t0
    return {"rendered": done, "skipped": skipped, "seconds": seconds,
            "seconds_per_sample": seconds / done if done else None}
