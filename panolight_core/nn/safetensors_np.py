"""Reading .safetensors with numpy only (no torch, no pickle): what Blender needs for model weights.

Format (huggingface/safetensors): an 8-byte little-endian header length N, N bytes of JSON
{name: {"dtype", "shape", "data_offsets": [begin, end]}, "__metadata__": {...}}, then the raw
little-endian tensor bytes; offsets are relative to the end of the header.
"""
from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np

from ..errors import PanoLightError

DTYPES = {"F64": "<f8", "F32": "<f4", "F16": "<f2", "I64": "<i8", "I32": "<i4", "I16": "<i2", "I8": "i1",
          "U8": "u1", "BOOL": "?"}
MAX_HEADER = 100 * 2 ** 20


def load_safetensors(path) -> tuple[dict[str, np.ndarray], dict]:
    """({name: array}, metadata) from a .safetensors file; PanoLightError naming the file on any damage."""
    p = Path(path)
    try:
        data = p.read_bytes()
    except OSError as exc:
        raise PanoLightError(f"{p}: cannot read weights: {exc.strerror or exc}") from None
    if len(data) < 8:
        raise PanoLightError(f"{p}: not a safetensors file (too short)")
    (n,) = struct.unpack("<Q", data[:8])
    if n > MAX_HEADER or 8 + n > len(data):
        raise PanoLightError(f"{p}: not a safetensors file (header length {n} does not fit the file)")
    try:
        header = json.loads(data[8:8 + n])
    except (UnicodeDecodeError, json.JSONDecodeError):
        raise PanoLightError(f"{p}: not a safetensors file (unreadable header)") from None
    meta = header.pop("__metadata__", {}) or {}
    body = memoryview(data)[8 + n:]
    tensors = {}
    for name, info in header.items():
        dtype = DTYPES.get(info.get("dtype"))
        if dtype is None:
            raise PanoLightError(f"{p}: tensor {name!r} has unsupported dtype {info.get('dtype')!r}")
        begin, end = info["data_offsets"]
        shape = tuple(int(s) for s in info["shape"])
        count = int(np.prod(shape)) if shape else 1
        if not 0 <= begin <= end <= len(body) or end - begin != count * np.dtype(dtype).itemsize:
            raise PanoLightError(f"{p}: tensor {name!r} is truncated or its offsets are inconsistent")
        tensors[name] = np.frombuffer(body[begin:end], dtype=dtype).reshape(shape).copy()
    return tensors, meta
