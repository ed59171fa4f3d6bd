"""8-bit pictures to file bytes: what the camera model saves (its JPEG round trip) and the writers use."""
from __future__ import annotations

import numpy as np


def encode_srgb8(rgb8: np.ndarray, fmt: str = "png", quality: int = 95) -> bytes:
    """(H, W, 3) uint8 display-referred sRGB -> PNG or JPEG (fmt "png" | "jpeg", JPEG quality) file bytes."""
    import io as _bytes_io

    from PIL import Image

    if fmt not in ("png", "jpeg"):
        raise ValueError(f"8-bit formats are png and jpeg, got {fmt!r}")
    buf = _bytes_io.BytesIO()
    # PNG level 1: 3x faster than the default 6 for a fifth more bytes (previews, figures)
    kw = {"quality": int(quality)} if fmt == "jpeg" else {"compress_level": 1}
    Image.fromarray(np.ascontiguousarray(rgb8, dtype=np.uint8), "RGB").save(buf, format=fmt.upper(), **kw)
    return buf.getvalue()
