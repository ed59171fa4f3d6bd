"""Reading and writing panoramas: OpenEXR, Radiance .hdr, PNG (8/16 bit) and JPEG; camera RAWs are read
(io.read_raw: linear, in the sensor's white).

read_image returns (H, W, 3) float32 *linear* RGB: 8/16-bit files are sRGB-decoded, HDR files are
taken as linear Rec.709. Every failure raises ImageError naming the file and the problem. Reading goes
through OpenImageIO (io.read_oiio: the same pixels as in Blender, by row blocks), with simplejpeg for
colour JPEGs (io.read_jpeg, faster), the OpenEXR package for luminance/chroma EXRs (io.read_exr) and a
numpy Radiance decoder where OpenImageIO is missing (io.hdr). The numpy-only checks are in io.checks.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..camera.codec import encode_srgb8  # noqa: F401 (also io.images' to callers)
from ..camera.color import SRGB8_TO_LINEAR, linear_to_srgb
from ..errors import ImageError
from ..packed import PackedImage
from . import hdr as _hdr
from . import read_exr, read_jpeg, read_oiio, read_raw
from .atomic import atomic_path
from .checks import (  # noqa: F401
    BLOCK_ROWS,
    DEFAULT_MAX_MEGAPIXELS,
    HDR_FORMATS,
    LDR_FORMATS,
    MAX_PIXELS,
    PICTURE_FORMATS,
    RAW_FORMAT,
    _sanitise,
    check_jpeg_data,
    check_size,
    check_stitched,
    is_hdr,
    sanitise_pixels,
    sniff_format,
)

PACKED_ABOVE_MEGAPIXELS = 64.0  # the CLI keeps larger HDR panoramas packed: a 16K one (134 MP) peaked at 1.95 GB as
# float32 and 1.1 GB packed; below it the float32 passes are a little faster, and the peak stays under 1.2 GB

_EXTENSIONS = {".exr": "exr", ".hdr": "hdr", ".pic": "hdr", ".rgbe": "hdr", ".png": "png", ".jpg": "jpeg",
               ".jpeg": "jpeg"}


def read_image(path, *, equirect: bool = True, nonfinite: str = "error", negative: str = "clamp",
               ldr_as_uint8: bool = False, max_megapixels: float = DEFAULT_MAX_MEGAPIXELS,
               packed_above: float = float("inf")):
    """Read a panorama as (H, W, 3) float32 linear RGB.

    ldr_as_uint8: return PNG/JPEG files as their (H, W, 3) uint8 sRGB values instead (no linearisation;
    estimators that need the clipped pixels exactly use this; a 16-bit PNG is rounded to 8 bits, as it is
    display-referred LDR). Other formats are unaffected.
    packed_above: return an HDR file of more than this many megapixels (read through OpenImageIO) as a
    ``packed.PackedImage`` (read by row blocks as float32) where its values fit exactly: a Radiance file's as
    RGBE bytes, an EXR's as half floats (a 16K panorama in 0.54 or 0.8 GB instead of 1.6; the whole estimate
    of a 16K .hdr takes as long, of a half EXR 2-3 s more); an EXR whose values no code holds is left in its
    file (``packed.RowFile``: read again by rows at each pass, about twice the time); other files as float32
    arrays. PACKED_ABOVE_MEGAPIXELS is the CLI's choice.
    equirect: require a 2:1 image, and refuse an unstitched dual-fisheye one (``checks.check_stitched``).
    nonfinite: "error" (default) refuses NaN/Inf pixels, "repair" sets NaN and -Inf to 0 and +Inf to the largest
    finite value, with a PanoLightWarning.
    negative: "clamp" (default) sets negative radiance to 0 with a PanoLightWarning, "error" refuses it.
    The size is checked from the header before pixels are decoded: at most ``max_megapixels`` (the
    documented decode budget, DEFAULT_MAX_MEGAPIXELS) and never above MAX_PIXELS; a JPEG whose data is
    too small for its claimed size is refused before decoding. The peak memory is the returned array
    plus a row block (the float conversion of an LDR file is one more array of its size).
    """
    if nonfinite not in ("error", "repair") or negative not in ("clamp", "error"):
        raise ValueError("nonfinite must be 'error' or 'repair'; negative must be 'clamp' or 'error'")
    p = Path(path)
    fmt = sniff_format(p)
    try:
        img = _decode(p, fmt, equirect, max_megapixels, ldr_as_uint8, packed_above)
    except (ImageError, MemoryError, KeyboardInterrupt):
        raise
    except Exception as exc:  # decoder libraries raise many types for bad files
        raise ImageError(p, f"cannot decode {fmt.upper()} pixels (corrupt or truncated file): "
                            f"{' '.join(str(exc).split())}") from None
    if equirect and not isinstance(img, PackedImage) and fmt != RAW_FORMAT:  # io.read_raw checks its own
        check_stitched(p, img)
    if img.dtype == np.uint8:
        return np.ascontiguousarray(img)
    if isinstance(img, PackedImage):  # RGBE holds only finite, non-negative values; half floats are checked in place,
        if img.kind in ("half", "file"):  # a file's rows are scanned and repaired as they are read again
            _sanitise(p, img.store, nonfinite, negative)
        return img
    return _sanitise(p, np.ascontiguousarray(img, dtype=np.float32), nonfinite, negative)


def preflight(path) -> tuple[int, int, int] | None:
    """Checks before Blender opens a file (Blender decodes it whole, with no budget of its own): the
    header's size against the decode budget, a JPEG's data against its claimed size, a JPEG without its
    end marker (truncated: Blender would show grey) and a multi-part EXR (Blender can crash on some; the
    CLI reads them part by part). The size comes from OpenImageIO where it is installed (Blender ships
    it); without it only the byte-level checks run. Returns the upright (height, width) and the EXIF
    orientation (1: as stored), or None."""
    p = Path(path)
    fmt = sniff_format(p)
    if fmt == "jpeg":
        with open(p, "rb") as f:
            f.seek(max(0, p.stat().st_size - 4096))
            tail = f.read()
        if b"\xff\xd9" not in tail:
            raise ImageError(p, "the JPEG is truncated (no end-of-image marker)")
    elif fmt == "exr":
        with open(p, "rb") as f:
            head = f.read(8)
        if len(head) == 8 and int.from_bytes(head[4:8], "little") & 0x1000:
            raise ImageError(p, "a multi-part EXR: Blender cannot always read these; estimate it with "
                                "'panolight estimate', or save its panorama part as a single-part EXR")
    if not read_oiio.available():
        return None
    with read_oiio.Opened(p, fmt) as opened:
        (h, w), orientation = opened.size, opened.orientation
        if opened.luminance_chroma and not read_exr.available():  # Blender: its chroma would be misread
            opened.pixels()  # raises ImageError, naming the file and the remedy
    check_size(p, h, w, True, DEFAULT_MAX_MEGAPIXELS)  # the decode budget's default: Blender has no option
    if fmt == "jpeg":
        check_jpeg_data(p, h, w)
    return h, w, orientation


def _decode(p: Path, fmt: str, equirect: bool, max_megapixels: float, as_uint8: bool,
            packed_above: float = float("inf")):
    if fmt == RAW_FORMAT:
        return read_raw.read_raw(p, equirect=equirect, max_megapixels=max_megapixels)[0]
    if fmt == "exr" and read_exr.luminance_chroma(p):
        reader = read_exr.read_luminance_chroma(p)
        check_size(p, *next(reader), equirect, max_megapixels)
        return next(reader)
    if not read_oiio.available():
        if fmt != "hdr":
            raise ImageError(p, f"reading {fmt.upper()} files needs OpenImageIO (pip install openimageio)")
        data = p.read_bytes()
        h, w, _ = _hdr.parse_header(data)
        check_size(p, h, w, equirect, max_megapixels)
        return _hdr.decode(data)
    with read_oiio.Opened(p, fmt) as opened:
        h, w = opened.size
        check_size(p, h, w, equirect, max_megapixels)
        if fmt == "jpeg":
            check_jpeg_data(p, h, w)
            if opened.orientation == 1:
                rgb = read_jpeg.decode(p)  # the fast path for colour JPEGs (None: OpenImageIO reads it)
                if rgb is not None:
                    return rgb if as_uint8 else SRGB8_TO_LINEAR[rgb]
        pack = fmt in HDR_FORMATS and h * w > packed_above * 1e6
        img = opened.pixels(as_uint8=as_uint8 and fmt in PICTURE_FORMATS,
                            packed=("rgbe" if fmt == "hdr" else "half") if pack else None)
    if img.shape != (h, w, 3):
        raise ImageError(p, f"decoded shape {img.shape} does not match header size {w} x {h}")
    return img


EXR_COMPRESSIONS = {"zip": "ZIP_COMPRESSION", "piz": "PIZ_COMPRESSION", "rle": "RLE_COMPRESSION",
                    "none": "NO_COMPRESSION"}  # name -> the codec's name in OpenEXR and Imath


def _exr_codec(compression: str) -> str:
    if compression not in EXR_COMPRESSIONS:
        raise ValueError(f"EXR compression must be one of {tuple(EXR_COMPRESSIONS)}, got {compression!r}")
    return EXR_COMPRESSIONS[compression]


def write_image(path, image, *, bit_depth: int = 8, half: bool = False, quality: int = 95,
                compression: str = "zip") -> Path:
    """Write (H, W, 3) linear RGB by extension: .exr (float32, or half), .hdr, .png (8/16-bit sRGB), .jpg.

    compression (EXR, all lossless): "zip" (the default, smallest on most images); "piz", twice as fast
    as zip on photographic panoramas at the same size; "rle", 3x faster than zip on smooth float32 maps
    (SH radiance, irradiance) at about the same size there (measured at 1024 x 512 and 512 x 256).

    Parent folders must exist; the file is written to a temporary name and renamed, so a failure never
    leaves a half-written file behind. Returns the path.
    """
    p = Path(path)
    fmt = _EXTENSIONS.get(p.suffix.lower())
    if fmt is None:
        raise ImageError(p, f"unknown image extension {p.suffix!r} (use .exr, .hdr, .png, .jpg)")
    img = np.asarray(image)
    if img.ndim != 3 or img.shape[-1] not in (3, 4) or 0 in img.shape:
        raise ImageError(p, f"cannot write an image of shape {img.shape}; expected (H, W, 3)")
    img = img[..., :3]
    if not p.parent.is_dir():
        raise ImageError(p, f"output folder {p.parent} does not exist")
    with atomic_path(p, p.suffix) as tmp:
        if fmt == "exr":
            import OpenEXR

            data = np.ascontiguousarray(img, dtype=np.float16 if half else np.float32)
            header = {"compression": getattr(OpenEXR, _exr_codec(compression)), "type": OpenEXR.scanlineimage}
            with OpenEXR.File(header, {"RGB": data}) as f:
                f.write(str(tmp))
        elif fmt == "hdr":
            tmp.write_bytes(_hdr.encode(np.maximum(np.nan_to_num(img.astype(np.float64)), 0.0)))
        else:
            enc = linear_to_srgb(img.astype(np.float64))
            if fmt == "png" and bit_depth == 16:
                import png

                q = np.round(enc * 65535.0).astype(np.uint16)
                png.Writer(q.shape[1], q.shape[0], bitdepth=16, greyscale=False).write(
                    open(tmp, "wb"), q.reshape(q.shape[0], -1).tolist())
            elif bit_depth == 8:
                tmp.write_bytes(encode_srgb8(np.round(enc * 255.0).astype(np.uint8), fmt, quality))
            else:
                raise ImageError(p, f"bit_depth {bit_depth} is not supported for {fmt.upper()} (8, or 16 for PNG)")
    return p


HALF_MAX = 65504.0  # the largest finite half float
HALF_MIN_NORMAL = 2.0 ** -14  # below it half floats lose precision (subnormals)


def write_exr_rows(path, height: int, width: int, blocks, *, half: bool = False,
                   check=None) -> Path:
    """Write an RGB EXR of (height, width) from ``blocks``, an iterable of (first row, (n, width, 3))
    in order, scanline by scanline: the image never exists whole in memory. Channels are float32, or half
    floats with ``half`` (the caller makes sure the values fit: HALF_MAX). ``check(block)`` may raise to
    stop (the half-written file is removed). Each block is compressed and written (OpenEXR, without the
    GIL) while the next is made. Written atomically; returns the path."""
    from concurrent.futures import ThreadPoolExecutor

    import Imath
    import OpenEXR

    p = Path(path)
    if not p.parent.is_dir():
        raise ImageError(p, f"output folder {p.parent} does not exist")
    codec = getattr(Imath.Compression, _exr_codec("piz"))  # the fast lossless codec for photographs
    header = OpenEXR.Header(int(width), int(height))
    header["compression"] = Imath.Compression(codec)
    dtype = np.float16 if half else np.float32
    if half:
        header["channels"] = {c: Imath.Channel(Imath.PixelType(Imath.PixelType.HALF)) for c in "RGB"}
    with atomic_path(p, p.suffix) as tmp, ThreadPoolExecutor(1, thread_name_prefix="panolight-exr") as writer:
        out = OpenEXR.OutputFile(str(tmp), header)
        pending = None
        try:
            expected = 0
            for r0, block in blocks:
                if r0 != expected or block.shape[1:] != (width, 3):
                    raise ValueError(f"blocks must cover rows in order with shape (n, {width}, 3)")
                if check is not None:
                    check(block)
                if pending is not None:
                    pending.result()  # one block in flight: memory stays bounded
                pending = writer.submit(_write_planes, out, block, dtype)
                expected += block.shape[0]
            if pending is not None:
                pending.result()
            if expected != height:
                raise ValueError(f"blocks covered {expected} of {height} rows")
        finally:
            if pending is not None:
                pending.exception()  # never close the file under a running write
            out.close()
    return p


def _write_planes(out, block: np.ndarray, dtype) -> None:
    """One (n, W, 3) block into an open OpenEXR.OutputFile, as its R, G and B planes of ``dtype``."""
    out.writePixels({c: np.ascontiguousarray(block[..., i], dtype=dtype) for i, c in enumerate("RGB")},
                    block.shape[0])


def write_srgb8(path, rgb8: np.ndarray, *, quality: int = 95) -> Path:
    """Write (H, W, 3) uint8 sRGB pixels as they are (previews, figures, made JPEGs) to .png or .jpg,
    atomically (temporary name, then rename). Returns the path."""
    p = Path(path)
    fmt = _EXTENSIONS.get(p.suffix.lower())
    img = np.asarray(rgb8)
    if fmt not in ("png", "jpeg"):
        raise ImageError(p, f"8-bit images are written as .png or .jpg, not {p.suffix!r}")
    if img.dtype != np.uint8 or img.ndim != 3 or img.shape[-1] != 3 or 0 in img.shape:
        raise ImageError(p, f"expected (H, W, 3) uint8 pixels, got {img.dtype} {img.shape}")
    if not p.parent.is_dir():
        raise ImageError(p, f"output folder {p.parent} does not exist")
    with atomic_path(p, p.suffix) as tmp:
        tmp.write_bytes(encode_srgb8(img, fmt, quality))
    return p
