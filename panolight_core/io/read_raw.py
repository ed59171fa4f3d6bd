"""Camera RAW files (DNG, CR2, CR3, NEF, ARW, RAF, ORF, RW2 ...) through rawpy (LibRaw), as linear panoramas.

A RAW is read as the sensor saw it: black levels subtracted, the camera's as-shot white balance, the camera's
colour matrix into linear Rec.709 / sRGB primaries, demosaiced (LibRaw's AHD), no tone curve and no brightening.
Its pixels are float32 (H, W, 3) in **sensor-white units**: 1 is the white level of the least-amplified channel
after white balance, so a pixel the sensor clipped is exactly 1 in every channel (LibRaw's highlight mode
"clip"), the ceiling ``camera.ceiling`` finds and the restoration fills, as for an HDR file that clips its own sun.
LibRaw's automatic lowering of the white level to the picture's brightest value is turned off: the ceiling is
the camera's, not the scene's.

rawpy is an ordinary dependency of the command line; Blender does not ship it, so there a RAW is refused in one
line naming the remedy unless it was installed into Blender's Python.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import ImageError
from ..threads import optional_module
from .checks import BLOCK_ROWS, DEFAULT_MAX_MEGAPIXELS, check_size, check_stitched

WHITE_16 = 65535  # LibRaw's 16-bit output: the sensor's white after white balance (highlight mode clip)


def available() -> bool:
    """True when rawpy (LibRaw) can be imported."""
    return optional_module("rawpy") is not None


def _rawpy(path):
    try:
        import rawpy
    except ImportError:
        raise ImageError(path, "a camera RAW needs rawpy (LibRaw): pip install rawpy (in Blender, into Blender's "
                               "own Python), or convert it to a linear EXR first") from None
    return rawpy


def _reason(exc) -> str:
    """LibRaw's error, for a message: its class name and its text, if any."""
    return f"{type(exc).__name__}{': ' + str(exc) if str(exc) else ''}"


def _open(path, rawpy):
    """A rawpy.RawPy with ``path``'s header parsed (pixels not yet unpacked); ImageError for what LibRaw refuses."""
    raw = rawpy.RawPy()
    try:
        raw.open_file(str(path))
    except rawpy.LibRawFileUnsupportedError:
        raise ImageError(path, "starts like a TIFF or camera RAW, but LibRaw cannot read it as a camera RAW (a plain "
                               "TIFF?): save the panorama as OpenEXR, Radiance .hdr, PNG or JPEG") from None
    except rawpy.LibRawError as exc:
        raise ImageError(path, f"cannot read the camera RAW (corrupt or truncated file): {_reason(exc)}") from None
    return raw


def _upright_size(sizes) -> tuple[int, int]:
    """(height, width) of LibRaw's output, turned as the file's orientation says (flip 5 and 6 turn 90 degrees)."""
    h, w = int(sizes.height), int(sizes.width)
    return (w, h) if int(sizes.flip) in (5, 6) else (h, w)


def read_raw(path, *, equirect: bool = True, max_megapixels: float | None = None) -> tuple[np.ndarray, dict]:
    """(pixels, record) of the camera RAW ``path``: float32 (H, W, 3) linear Rec.709 in sensor-white units (the
    module's docstring), upright; and what lighting.json keeps of it (``source.raw``: the reader, white and black
    levels, the white balance used, the share of pixels the sensor clipped). The size is checked from the header
    before the pixels are unpacked, and with ``equirect`` (2:1) an unstitched dual-fisheye RAW is refused
    (``checks.check_stitched``). ImageError naming the file for anything LibRaw cannot read."""
    p = Path(path)
    rawpy = _rawpy(p)
    raw = _open(p, rawpy)
    try:
        h, w = _upright_size(raw.sizes)
        check_size(p, h, w, equirect, DEFAULT_MAX_MEGAPIXELS if max_megapixels is None else max_megapixels)
        if raw.num_colors < 3:
            raise ImageError(p, "a monochrome RAW: a panorama's lighting needs colour")
        try:
            raw.unpack()
            shot_wb = [float(v) for v in raw.camera_whitebalance[:3]]
            as_shot = all(v > 0 for v in shot_wb)
            rgb16 = raw.postprocess(use_camera_wb=as_shot, use_auto_wb=False, no_auto_bright=True, bright=1.0,
                                    gamma=(1, 1), output_bps=16, output_color=rawpy.ColorSpace.sRGB,
                                    highlight_mode=rawpy.HighlightMode.Clip, adjust_maximum_thr=0.0,
                                    no_auto_scale=False)
        except rawpy.LibRawError as exc:
            raise ImageError(p, f"cannot decode the camera RAW's pixels (corrupt or truncated file): "
                                f"{_reason(exc)}") from None
        record = {"reader": f"rawpy {rawpy.__version__} (LibRaw {'.'.join(map(str, rawpy.libraw_version))})",
                  "white_level": int(raw.white_level),
                  "black_level": [int(v) for v in raw.black_level_per_channel],
                  "white_balance": "as shot" if as_shot else "daylight (the file records no as-shot white balance)",
                  "multipliers": [round(v / shot_wb[1], 6) for v in shot_wb] if as_shot else None}
    finally:
        raw.close()
    if rgb16.shape != (h, w, 3):
        raise ImageError(p, f"LibRaw gave {rgb16.shape[1]} x {rgb16.shape[0]} pixels where the header says {w} x {h}")
    pixels = np.empty(rgb16.shape, np.float32)
    clipped = 0
    scale = np.float32(1.0 / WHITE_16)
    for r in range(0, h, BLOCK_ROWS):  # no second full-size temporary
        block = rgb16[r:r + BLOCK_ROWS]
        np.multiply(block, scale, out=pixels[r:r + BLOCK_ROWS], dtype=np.float32)
        clipped += int((block == WHITE_16).all(axis=-1).sum())
    if equirect:
        check_stitched(p, pixels)
    record["sensor_clipped_fraction"] = clipped / float(h * w)
    return pixels, record


def read_raw_exposure(path) -> dict | None:
    """A RAW's exposure settings as ``io.capture.read_exposure`` gives a JPEG's: {"time_s", "f_number", "iso"} (ISO
    100 where the file records none), or None when it records no shutter time and aperture (or rawpy is missing)."""
    if not available():
        return None
    import rawpy

    raw = rawpy.RawPy()
    try:
        raw.open_file(str(Path(path)))
        other = raw.other
    except rawpy.LibRawError:
        return None
    finally:
        raw.close()
    from .metadata import exposure

    tags = {"ExposureTime": other.shutter_speed, "FNumber": other.aperture, "Exif:ISOSpeedRatings": other.iso_speed,
            "Exif:DateTimeOriginal": _exif_time(getattr(other, "timestamp", None))}
    return exposure(tags.get)


def _exif_time(timestamp) -> str | None:
    """LibRaw's shot timestamp (seconds since 1970) as EXIF's "YYYY:MM:DD HH:MM:SS"; None when absent or absurd."""
    from datetime import datetime, timezone

    from .metadata import number

    seconds = number(timestamp, 1.0, 253402300799.0)  # after 1970, before year 10000
    return None if seconds is None else datetime.fromtimestamp(seconds, timezone.utc).strftime("%Y:%m:%d %H:%M:%S")
