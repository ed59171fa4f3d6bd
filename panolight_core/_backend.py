"""Thin numpy/torch switch: one implementation of each algorithm serves both.

Functions in the core take arrays and return arrays of the same kind. A torch tensor in gives a
torch tensor out (same dtype and device, differentiable); anything else is treated as numpy.
torch is imported only when a tensor is actually passed, so the core runs without it (inside Blender).
"""
from __future__ import annotations

import sys

import numpy as np


def is_torch(x) -> bool:
    """True if ``x`` is a torch tensor (without importing torch if it is not loaded)."""
    torch = sys.modules.get("torch")
    return torch is not None and isinstance(x, torch.Tensor)


class _Numpy:
    name = "numpy"

    @staticmethod
    def const(table: np.ndarray, like):
        """A read-only float64 numpy table converted to the dtype of ``like`` (conversions cached)."""
        return _cached_cast(table, like.dtype.str) if table.dtype != like.dtype else table

    stack = staticmethod(np.stack)
    concatenate = staticmethod(np.concatenate)

    @staticmethod
    def to_numpy(x):
        return np.asarray(x)

    contiguous = staticmethod(np.ascontiguousarray)

    @staticmethod
    def zeros(shape, like):
        return np.zeros(shape, dtype=like.dtype)


class _Torch:
    name = "torch"

    def __init__(self):
        import torch

        self.t = torch

    def const(self, table: np.ndarray, like):
        np_dtype = str(like.dtype).replace("torch.", "")
        arr = _cached_cast(table, np.dtype(np_dtype).str) if np_dtype in ("float32", "float64") else table
        return self.t.from_numpy(arr).to(dtype=like.dtype, device=like.device)

    def stack(self, xs, axis=0):
        return self.t.stack(list(xs), dim=axis)

    def concatenate(self, xs, axis=0):
        return self.t.cat(list(xs), dim=axis)

    @staticmethod
    def to_numpy(x):
        return x.detach().cpu().numpy()

    @staticmethod
    def contiguous(x):
        return x.contiguous()

    def zeros(self, shape, like):
        return self.t.zeros(shape, dtype=like.dtype, device=like.device)


_CAST_CACHE: dict = {}


def _cached_cast(table: np.ndarray, dtype: str) -> np.ndarray:
    """Contiguous, writable copy of a read-only table in ``dtype``, memoised per (table, dtype).

    Only read-only tables (the cached grid tables) are memoised; the cache holds a reference to the
    table so its id cannot be reused while the entry lives.
    """
    if table.flags.writeable:
        return np.array(table, dtype=dtype, order="C")
    key = (id(table), dtype)
    hit = _CAST_CACHE.get(key)
    if hit is None:
        if len(_CAST_CACHE) > 256:
            _CAST_CACHE.clear()
        hit = _CAST_CACHE[key] = (table, np.array(table, dtype=dtype, order="C"))
    return hit[1]


_NUMPY = _Numpy()
_TORCH = None


def backend(x):
    """The backend object for array ``x`` (numpy for anything that is not a torch tensor)."""
    global _TORCH
    if is_torch(x):
        if _TORCH is None:
            _TORCH = _Torch()
        return _TORCH
    return _NUMPY


def float_array(x, name: str = "array"):
    """``x`` as a floating array of its own kind (numpy float32/64 kept, ints promoted to float64).

    Raises ValueError naming ``name`` for non-numeric input.
    """
    xp = backend(x)
    if xp is _NUMPY:
        a = np.asarray(x)
        if a.dtype.kind not in "fiub":
            raise ValueError(f"{name}: expected a numeric array, got dtype {a.dtype}")
        if a.dtype.kind != "f" or a.dtype == np.float16:
            a = a.astype(np.float32 if a.dtype == np.float16 else np.float64)
        return xp, a
    if not x.is_floating_point():
        x = x.to(xp.t.float64)
    elif x.dtype in (xp.t.float16, xp.t.bfloat16):
        x = x.to(xp.t.float32)
    return xp, x
