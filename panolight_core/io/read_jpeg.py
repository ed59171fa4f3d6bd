"""The fast path for colour JPEGs: simplejpeg decodes (libjpeg-turbo, accurate DCT and upsampling, as
OpenImageIO's libjpeg) straight into one numpy array, in a third of the time of a general reader at 16K.
Strict: a decoder warning (data missing past a patched or truncated header) refuses the file."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import ImageError
from ..threads import optional_module


def decode(path) -> np.ndarray | None:
    """(H, W, 3) uint8 of a colour JPEG as stored, or None when simplejpeg is not installed or does not
    take this kind of JPEG (CMYK, grey), so that OpenImageIO reads it. ImageError for corrupt data."""
    simplejpeg = optional_module("simplejpeg")
    if simplejpeg is None:
        return None
    data = Path(path).read_bytes()
    try:
        if simplejpeg.decode_jpeg_header(data)[2] not in ("YCbCr", "RGB"):
            return None
        return simplejpeg.decode_jpeg(data, colorspace="RGB", strict=True)
    except ValueError as exc:
        raise ImageError(path, f"cannot decode JPEG pixels (corrupt or truncated file): {exc}") from None
