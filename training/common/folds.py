"""Leave-scenes-out folds: the one assignment of the real HDRs to folds that every cross-validation uses (the
per-source model's, the key light's and the network's), and the --hold-out / --fold option's K/N."""
from __future__ import annotations

import numpy as np


def parse_fold(text: str) -> tuple[int, int]:
    """'K/N' (fold K of N, from 1) -> (K, N); an argparse type (ArgumentTypeError otherwise)."""
    import argparse

    try:
        k, n = (int(v) for v in str(text).split("/"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"a fold is K/N, e.g. 1/5; got {text!r}") from None
    if not 1 <= k <= n or n < 2:
        raise argparse.ArgumentTypeError(f"a fold K/N needs 1 <= K <= N and N >= 2; got {text!r}")
    return k, n


def scene_folds(count: int, folds: int = 5, seed: int = 0) -> list[np.ndarray]:
    """Indices of ``count`` scenes (source_energy.scene_files order) in ``folds`` leave-scenes-out folds:
    the assignment every cross-validation here uses (the per-source model's and the network's)."""
    perm = np.random.default_rng(seed).permutation(count)
    return [perm[i::folds] for i in range(folds)]


def fold_of(files, folds: int = 5) -> dict:
    """{file: K}: the fold (from 1) of each scene (source_energy.scene_files order): the model trained with
    ``--hold-out K/N`` never saw it."""
    return {files[i]: k for k, idx in enumerate(scene_folds(len(files), folds), 1) for i in idx}


def fold_files(files, fold) -> list:
    """The files (source_energy.scene_files order) of fold (K, N): the scenes a run with ``--hold-out K/N``
    leaves out."""
    k, n = fold
    return [files[i] for i in sorted(scene_folds(len(files), n)[k - 1])]
