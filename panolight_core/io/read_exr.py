"""OpenEXR's luminance/chroma images (Y, RY, BY; chroma often subsampled), which OpenImageIO's Python
reader cannot deliver: read whole with the OpenEXR package (the CLI has it; in Blender such a file is
refused by the decoder, not misread) and turned into Rec.709 RGB."""
from __future__ import annotations

import numpy as np

from ..camera.color import LUMINANCE_WEIGHTS
from ..threads import optional_module


def available() -> bool:
    return optional_module("OpenEXR") is not None


def luminance_chroma(path) -> bool:
    """Whether this single- or multi-part EXR's first colour part is luminance/chroma (header only);
    False when the OpenEXR package is missing."""
    OpenEXR = optional_module("OpenEXR")
    if OpenEXR is None:
        return False
    for part in OpenEXR.File(str(path), header_only=True).parts:
        names = {getattr(c, "name", str(c)) for c in part.header.get("channels", [])}
        if {"R", "G", "B"} <= names:
            return False
        if {"Y", "RY", "BY"} <= names:
            return True
    return False


def read_luminance_chroma(path):
    """A generator: the (height, width) of the data window first, then (H, W, 3) float32 RGB."""
    import OpenEXR

    parts = OpenEXR.File(str(path)).parts
    part = next(p for p in parts if {"Y", "RY", "BY"} <= set(p.channels))
    (x0, y0), (x1, y1) = part.header["dataWindow"]
    h, w = int(y1 - y0 + 1), int(x1 - x0 + 1)
    yield h, w
    yield _luminance_chroma_to_rgb(part.channels, h, w)


def _luminance_chroma_to_rgb(channels, h: int, w: int) -> np.ndarray:
    """OpenEXR's luminance/chroma (Y, RY = (R - Y) / Y, BY = (B - Y) / Y; chroma often subsampled) -> RGB
    with Rec.709 weights (the CONVENTIONS.md primaries)."""
    y = np.asarray(channels["Y"].pixels, dtype=np.float32)

    def full(name):
        c = channels[name]
        a = np.asarray(c.pixels, dtype=np.float32)
        a = np.repeat(np.repeat(a, int(c.ySampling), axis=0), int(c.xSampling), axis=1)
        return a[:h, :w]

    r = y * (1.0 + full("RY"))
    b = y * (1.0 + full("BY"))
    wr, wg, wb = (float(v) for v in LUMINANCE_WEIGHTS)
    g = (y - wr * r - wb * b) / wg
    return np.stack([r, g, b], axis=-1)
