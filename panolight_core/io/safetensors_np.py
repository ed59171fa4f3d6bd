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


def _count(v) -> bool:
    return isinstance(v, int) and not isinstance(v, bool) and v >= 0


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
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError):  # RecursionError: nesting bombs
        raise PanoLightError(f"{p}: not a safetensors file (unreadable header)") from None
    if not isinstance(header, dict):
        raise PanoLightError(f"{p}: not a safetensors file (the header is not a JSON object)")
    meta = header.pop("__metadata__", {}) or {}
    if not isinstance(meta, dict) or not all(isinstance(v, str) for v in meta.values()):
        raise PanoLightError(f"{p}: not a safetensors file (__metadata__ must map names to strings)")
    body = memoryview(data)[8 + n:]
    tensors = {}
    for name, info in header.items():
        if not isinstance(info, dict):
            raise PanoLightError(f"{p}: tensor {name!r} has no description (dtype, shape, data_offsets)")
        dtype = DTYPES.get(info.get("dtype")) if isinstance(info.get("dtype"), str) else None
        if dtype is None:
            raise PanoLightError(f"{p}: tensor {name!r} has unsupported dtype {info.get('dtype')!r}")
        offsets, shape = info.get("data_offsets"), info.get("shape")
        if not (isinstance(offsets, list) and len(offsets) == 2 and all(_count(v) for v in offsets)) or \
                not (isinstance(shape, list) and all(_count(v) for v in shape)):
            raise PanoLightError(f"{p}: tensor {name!r} needs integer 'shape' and two integer 'data_offsets'")
        begin, end = offsets
        shape = tuple(shape)
        count = int(np.prod(shape)) if shape else 1
        if not 0 <= begin <= end <= len(body) or end - begin != count * np.dtype(dtype).itemsize:
            raise PanoLightError(f"{p}: tensor {name!r} is truncated or its offsets are inconsistent")
        tensors[name] = np.frombuffer(body[begin:end], dtype=dtype).reshape(shape).copy()
    return tensors, meta


def load_shipped(path, what: str) -> tuple[dict[str, np.ndarray], dict]:
    """``load_safetensors`` of a file PanoLight ships in panolight_core/models/ (``what`` names it in the
    error when the installation lacks it)."""
    p = Path(path)
    if not p.is_file():
        raise PanoLightError(f"{p}: the {what} is missing from this installation")
    return load_safetensors(p)
