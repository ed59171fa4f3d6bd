"""Radiance RGBE (.hdr) reader and writer (Greg Ward's format: new-style RLE scanlines and flat).

Orientation "-Y H +X W" (top row first) is the only one written and read; others are refused.
"""
from __future__ import annotations

import re

import numpy as np

_SIZE_RE = re.compile(rb"^-Y (\d+) \+X (\d+)$")


def parse_header(data: bytes):
    """(height, width, offset_of_pixels) from the bytes of an .hdr file. Raises ValueError."""
    if not (data.startswith(b"#?RADIANCE") or data.startswith(b"#?RGBE")):
        raise ValueError("not a Radiance HDR file (missing '#?RADIANCE' signature)")
    end = data.find(b"\n\n")
    if end < 0:
        raise ValueError("truncated header (no blank line ending it)")
    for line in data[:end].split(b"\n"):
        if line.startswith(b"FORMAT=") and line.strip() != b"FORMAT=32-bit_rle_rgbe":
            raise ValueError(f"unsupported pixel format {line.decode(errors='replace')!r} (only 32-bit_rle_rgbe)")
    nl = data.find(b"\n", end + 2)
    if nl < 0:
        raise ValueError("truncated header (no resolution line)")
    m = _SIZE_RE.match(data[end + 2:nl].strip())
    if not m:
        raise ValueError(f"unsupported resolution line {data[end + 2:nl][:40]!r} (only '-Y H +X W')")
    return int(m.group(1)), int(m.group(2)), nl + 1


def decode(data: bytes) -> np.ndarray:
    """(H, W, 3) float32 linear radiance from the bytes of an .hdr file. Raises ValueError."""
    h, w, pos = parse_header(data)
    buf = np.frombuffer(data, dtype=np.uint8)
    rgbe = np.empty((h, w, 4), dtype=np.uint8)
    for y in range(h):
        if pos + 4 > buf.size:
            raise ValueError(f"truncated pixel data at scanline {y} of {h}")
        b0, b1, b2, b3 = buf[pos:pos + 4]
        if 8 <= w < 32768 and b0 == 2 and b1 == 2 and (int(b2) << 8 | int(b3)) == w:
            pos += 4
            for ch in range(4):
                x = 0
                row = rgbe[y, :, ch]
                while x < w:
                    if pos >= buf.size:
                        raise ValueError(f"truncated pixel data at scanline {y} of {h}")
                    count = int(buf[pos])
                    pos += 1
                    if count > 128:
                        count -= 128
                        if x + count > w or pos >= buf.size:
                            raise ValueError(f"corrupt run-length data at scanline {y}")
                        row[x:x + count] = buf[pos]
                        pos += 1
                    else:
                        if count == 0 or x + count > w or pos + count > buf.size:
                            raise ValueError(f"corrupt or truncated run-length data at scanline {y}")
                        row[x:x + count] = buf[pos:pos + count]
                        pos += count
                    x += count
        else:  # flat (uncompressed) scanline
            if pos + 4 * w > buf.size:
                raise ValueError(f"truncated pixel data at scanline {y} of {h}")
            rgbe[y] = buf[pos:pos + 4 * w].reshape(w, 4)
            pos += 4 * w
    e = rgbe[..., 3].astype(np.int32)
    scale = np.where(e > 0, np.ldexp(1.0, e - 136), 0.0).astype(np.float32)  # 2^(e-128) / 256
    return (rgbe[..., :3].astype(np.float32) + 0.5) * scale[..., None] * (e[..., None] > 0)


def encode(image: np.ndarray) -> bytes:
    """Bytes of a flat (uncompressed) .hdr file for a (H, W, 3) non-negative float image."""
    img = np.asarray(image, dtype=np.float64)
    h, w = img.shape[:2]
    peak = img.max(axis=-1)
    mant, expo = np.frexp(peak)
    ok = peak >= 1e-32
    scale = np.where(ok, mant * 256.0 / np.where(ok, peak, 1.0), 0.0)
    rgbe = np.zeros((h, w, 4), dtype=np.uint8)
    rgbe[..., :3] = np.clip(np.floor(img * scale[..., None]), 0, 255).astype(np.uint8)
    rgbe[..., 3] = np.where(ok, np.clip(expo + 128, 0, 255), 0).astype(np.uint8)
    header = f"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\nSOFTWARE=PanoLight\n\n-Y {h} +X {w}\n".encode()
    return header + rgbe.tobytes()
