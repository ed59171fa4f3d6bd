"""Reading and writing panoramas: OpenEXR, Radiance .hdr, PNG (8/16 bit) and JPEG.

read_image returns (H, W, 3) float32 *linear* RGB: 8/16-bit files are sRGB-decoded, HDR files are
taken as linear Rec.709. Every failure raises ImageError naming the file and the problem.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from ..camera.color import LUMINANCE_WEIGHTS, SRGB8_TO_LINEAR, linear_to_srgb, srgb_to_linear
from ..errors import ImageError, PanoLightWarning
from ..sh.grid import MAX_SIDE  # larger images are refused as absurd
from . import hdr as _hdr
from .atomic import atomic_path

MAX_PIXELS = 1 << 29  # 32768 x 16384: no size above this is read at all
DEFAULT_MAX_MEGAPIXELS = 140.0  # the decode budget: 16384 x 8192 (134 MP, the largest common HDRI) fits
HDR_FORMATS = ("exr", "hdr")
LDR_FORMATS = ("png", "jpeg")
_EXTENSIONS = {".exr": "exr", ".hdr": "hdr", ".pic": "hdr", ".rgbe": "hdr", ".png": "png", ".jpg": "jpeg",
               ".jpeg": "jpeg"}


def sniff_format(path) -> str:
    """'exr' | 'hdr' | 'png' | 'jpeg' from the file's first bytes; raises ImageError otherwise."""
    import stat

    p = Path(path)
    try:
        st = p.stat()
        if stat.S_ISDIR(st.st_mode):
            raise ImageError(p, "is a directory, not an image file")
        if st.st_size == 0:
            raise ImageError(p, "file is empty (0 bytes)")
        with open(p, "rb") as f:
            head = f.read(16)
    except FileNotFoundError:
        raise ImageError(p, "file not found") from None
    except OSError as exc:  # a symlink loop, no permission, a name too long
        raise ImageError(p, f"cannot be opened ({exc.strerror or exc})") from None
    if head.startswith(b"\x76\x2f\x31\x01"):
        return "exr"
    if head.startswith(b"#?RADIANCE") or head.startswith(b"#?RGBE"):
        return "hdr"
    if head.startswith(b"\x89PNG\r\n\x1a\n"):
        return "png"
    if head.startswith(b"\xff\xd8\xff"):
        return "jpeg"
    raise ImageError(p, f"not a supported image (OpenEXR, Radiance .hdr, PNG or JPEG); starts with {head[:8]!r}")


def is_hdr(path) -> bool:
    """True for OpenEXR / Radiance files (by content)."""
    return sniff_format(path) in HDR_FORMATS


def _check_size(path, h: int, w: int, equirect: bool, max_megapixels: float = DEFAULT_MAX_MEGAPIXELS):
    if h <= 0 or w <= 0:
        raise ImageError(path, f"image has zero size ({w} x {h})")
    if h * w > max_megapixels * 1e6 and h * w <= MAX_PIXELS:
        raise ImageError(path, f"image is {w} x {h} = {h * w / 1e6:.0f} megapixels, above the decode budget of "
                               f"{max_megapixels:g} (raise it with --max-megapixels if the file is real)")
    if h > MAX_SIDE or w > MAX_SIDE or h * w > MAX_PIXELS:
        raise ImageError(path, f"image size {w} x {h} is larger than supported ({MAX_SIDE} per side, "
                               f"{MAX_PIXELS} pixels)")
    if equirect and w != 2 * h:
        raise ImageError(path, f"equirectangular panoramas must be 2:1 (width = 2 x height); got {w} x {h}")


def _exr_colour(names) -> str | None:
    """Which colour layout an EXR part's channel names hold: "RGB", "YC" (luminance + chroma), "Y", or None."""
    names = set(names)
    if {"R", "G", "B"} <= names:
        return "RGB"
    if {"Y", "RY", "BY"} <= names:
        return "YC"
    return "Y" if "Y" in names else None


def _exr_names(header) -> set:
    return {getattr(c, "name", str(c)) for c in header.get("channels", [])}


def _exr_window(header, key):
    (x0, y0), (x1, y1) = header[key]
    return int(x0), int(y0), int(x1), int(y1)


def _choose_exr_part(path, parts) -> int:
    """The part that holds the panorama: colour channels over the full display window, 2:1 preferred,
    then the largest. Says which (a warning) when the file has several parts; refuses crops."""
    found = []
    for i, part in enumerate(parts):
        layout = _exr_colour(_exr_names(part.header))
        if layout is None:
            continue
        x0, y0, x1, y1 = _exr_window(part.header, "dataWindow")
        w, h = x1 - x0 + 1, y1 - y0 + 1
        full = _exr_window(part.header, "dataWindow") == _exr_window(part.header, "displayWindow")
        found.append((full, w == 2 * h, w * h, -i, i, w, h, layout))
    if not found:
        names = sorted({c for p in parts for c in _exr_names(p.header)})
        raise ValueError(f"no R, G, B (or Y) channels in any part; channels are {names}")
    full, _, _, _, i, w, h, layout = max(found)
    if not full:
        x0, y0, x1, y1 = _exr_window(parts[i].header, "dataWindow")
        d = _exr_window(parts[i].header, "displayWindow")
        raise ValueError(f"its data window ({x0},{y0})-({x1},{y1}) is a crop of its display window "
                         f"({d[0]},{d[1]})-({d[2]},{d[3]}); a panorama must cover the whole sphere")
    if len(parts) > 1:
        name = parts[i].name() if callable(getattr(parts[i], "name", None)) else str(i)
        warnings.warn(PanoLightWarning(f"{path}: {len(parts)} parts; using part {i} ({name!r}, {w} x {h} "
                                       f"{layout}), the largest full-frame colour part"))
    return i


def _read_exr(path) -> np.ndarray:
    import OpenEXR

    heads = OpenEXR.File(str(path), header_only=True).parts
    i = _choose_exr_part(path, heads)
    x0, y0, x1, y1 = _exr_window(heads[i].header, "dataWindow")
    yield y1 - y0 + 1, x1 - x0 + 1  # checked against the size budget before any pixel is decoded
    layout = _exr_colour(_exr_names(heads[i].header))
    if layout == "RGB" and len(heads) == 1 and {"R", "G", "B"} <= set(_exr_names(heads[i].header)):
        yield _read_exr_rows(path, y0, y1 - y0 + 1, x1 - x0 + 1)  # scanlines by row blocks, as float32
        return
    channels = OpenEXR.File(str(path)).parts[i].channels
    if layout == "RGB":
        key = "RGB" if "RGB" in channels else "RGBA"
        src = channels[key].pixels
        if src.dtype == np.float32 and src.shape[-1] == 3:
            yield src
            return
        out = np.empty(src.shape[:2] + (3,), np.float32)  # half (or RGBA) -> float32 RGB by row blocks,
        for r in range(0, out.shape[0], _BLOCK_ROWS):      # without a second full-size temporary
            out[r:r + _BLOCK_ROWS] = src[r:r + _BLOCK_ROWS, :, :3]
        del src, channels  # the decoded half data goes before the caller holds the float copy
        yield out
    elif layout == "YC":
        yield _luminance_chroma_to_rgb(channels, y1 - y0 + 1, x1 - x0 + 1)
    else:
        yield np.repeat(channels["Y"].pixels[..., None], 3, axis=-1)


def _read_exr_rows(path, y0: int, h: int, w: int) -> np.ndarray:
    """A single-part RGB(A) EXR decoded by row blocks straight into float32 (H, W, 3): no full-size
    half-float or RGBA temporary (a 16K half EXR peaks at its float32 size, not 1.5 times it)."""
    import Imath
    import OpenEXR

    out = np.empty((h, w, 3), np.float32)
    f = OpenEXR.InputFile(str(path))
    try:
        float_type = Imath.PixelType(Imath.PixelType.FLOAT)
        for r in range(0, h, _BLOCK_ROWS):
            n = min(_BLOCK_ROWS, h - r)
            planes = f.channels(["R", "G", "B"], float_type, y0 + r, y0 + r + n - 1)
            for c, plane in enumerate(planes):
                out[r:r + n, :, c] = np.frombuffer(plane, dtype=np.float32).reshape(n, w)
    finally:
        f.close()
    return out


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


def _read_hdr(path):
    data = Path(path).read_bytes()
    h, w, _ = _hdr.parse_header(data)
    yield h, w
    yield _hdr.decode(data)


def _read_pil(path, as_uint8=False):
    """JPEG/PNG: size first (from the header, as displayed: EXIF orientation 5-8 swaps it), then pixels
    turned upright by their EXIF orientation."""
    from PIL import Image, ImageOps

    limit = Image.MAX_IMAGE_PIXELS
    Image.MAX_IMAGE_PIXELS = MAX_PIXELS  # our own budget (_check_size) decides; Pillow's check only warns
    try:
        opened = Image.open(path)
    finally:
        Image.MAX_IMAGE_PIXELS = limit
    with opened as im:
        orientation = _orientation(im)
        yield (im.width, im.height) if orientation in (5, 6, 7, 8) else (im.height, im.width)
        if im.format == "PNG" and (im.mode in ("I;16", "I;16B", "I") or _png_bit_depth(path) == 16):
            yield _read_png16(path, as_uint8)
            return
        if im.format == "JPEG" and im.mode == "RGB" and orientation in (0, 1):
            rgb = _decode_jpeg(path)
            if rgb is not None:
                yield rgb if as_uint8 else SRGB8_TO_LINEAR[rgb]
                return
        im.load()
        upright = ImageOps.exif_transpose(im) if orientation not in (0, 1) else im  # (each step is a copy)
        rgb = _pil_rgb(upright if upright.mode == "RGB" else upright.convert("RGB"))
        del upright
    yield rgb if as_uint8 else SRGB8_TO_LINEAR[rgb]


def _decode_jpeg(path) -> np.ndarray | None:
    """(H, W, 3) uint8 of an upright colour JPEG decoded by simplejpeg (libjpeg-turbo straight into one
    numpy array: a 16K panorama in a third of Pillow's time and memory; the same pixels, as both use
    libjpeg-turbo's accurate DCT and upsampling), or None when simplejpeg is not installed or refuses the
    file, so that Pillow decodes it (and words any error)."""
    try:
        import simplejpeg
    except ImportError:
        return None
    try:
        return simplejpeg.decode_jpeg(Path(path).read_bytes(), colorspace="RGB")
    except ValueError:
        return None


def _pil_rgb(im) -> np.ndarray:
    """(H, W, 3) uint8 of a loaded RGB Pillow image. Large images are copied out in row strips: numpy's
    own conversion goes through a whole-image bytes object (twice the image at its peak: a 16K JPEG
    peaks at 1.0 GB this way, 1.4 GB that way)."""
    from ..camera.resample import row_blocks

    w, h = im.size
    if w * h <= (1 << 24):
        return np.asarray(im)
    out = np.empty((h, w, 3), np.uint8)
    for r0, r1 in row_blocks(h, w):
        out[r0:r1] = np.asarray(im.crop((0, r0, w, r1)))
    return out


def _orientation(im) -> int:
    """EXIF orientation (1 = upright) read from the header alone: a PNG's eXIf chunk only when it comes
    before the pixel data (reading further would decode a possibly huge, possibly truncated image)."""
    from PIL import Image

    if im.format == "PNG":
        raw = im.info.get("exif")
        if not raw:
            return 1
        exif = Image.Exif()
        exif.load(raw)
        return int(exif.get(0x0112, 1))
    return int(im.getexif().get(0x0112, 1))


def _png_bit_depth(path) -> int:
    with open(path, "rb") as f:
        head = f.read(26)
    return head[24] if head.startswith(b"\x89PNG") and len(head) >= 25 else 8


def _read_png16(path, as_uint8: bool = False) -> np.ndarray:
    """A 16-bit PNG: display-referred sRGB, i.e. LDR with more precision. as_uint8: rounded to the 8-bit
    values the same picture saved as 8 bits would hold, so the LDR estimators find its clipped pixels;
    else float32 linear."""
    import png

    w, h, rows, info = png.Reader(filename=str(path)).asDirect()
    arr = np.vstack([np.asarray(r, dtype=np.uint16) for r in rows]).reshape(h, w, info["planes"])
    if info["planes"] in (1, 2):
        arr = np.repeat(arr[..., :1], 3, axis=-1)
    arr = arr[..., :3].astype(np.float32) / float(2 ** info["bitdepth"] - 1)
    if as_uint8:
        return np.round(arr * 255.0).astype(np.uint8)
    return srgb_to_linear(arr).astype(np.float32)


_READERS = {"exr": _read_exr, "hdr": _read_hdr, "png": _read_pil, "jpeg": _read_pil}


def read_image(path, *, equirect: bool = True, nonfinite: str = "error", negative: str = "clamp",
               ldr_as_uint8: bool = False, max_megapixels: float = DEFAULT_MAX_MEGAPIXELS) -> np.ndarray:
    """Read a panorama as (H, W, 3) float32 linear RGB.

    ldr_as_uint8: return PNG/JPEG files as their (H, W, 3) uint8 sRGB values instead (no linearisation;
    estimators that need the clipped pixels exactly use this; a 16-bit PNG is rounded to 8 bits, as it is
    display-referred LDR). Other formats are unaffected.
    equirect: require a 2:1 image. nonfinite: "error" (default) refuses NaN/Inf pixels, "repair"
    sets NaN and -Inf to 0 and +Inf to the largest finite value, with a PanoLightWarning.
    negative: "clamp" (default) sets negative radiance to 0 with a PanoLightWarning, "error" refuses it.
    The size is checked from the header before pixels are decoded: at most ``max_megapixels`` (the
    documented decode budget, DEFAULT_MAX_MEGAPIXELS) and never above MAX_PIXELS.
    """
    if nonfinite not in ("error", "repair") or negative not in ("clamp", "error"):
        raise ValueError("nonfinite must be 'error' or 'repair'; negative must be 'clamp' or 'error'")
    p = Path(path)
    fmt = sniff_format(p)
    reader = _read_pil(p, as_uint8=True) if ldr_as_uint8 and fmt in LDR_FORMATS else _READERS[fmt](p)
    try:
        h, w = next(reader)
    except ImageError:
        raise
    except Exception as exc:  # decoder libraries raise many types for bad headers
        raise ImageError(p, f"cannot read {fmt.upper()} header (corrupt or truncated file): {exc}") from None
    _check_size(p, h, w, equirect, max_megapixels)
    try:
        img = next(reader)
    except Exception as exc:
        raise ImageError(p, f"cannot decode {fmt.upper()} pixels (corrupt or truncated file): {exc}") from None
    if img.shape != (h, w, 3):
        raise ImageError(p, f"decoded shape {img.shape} does not match header size {w} x {h}")
    if img.dtype == np.uint8:
        return np.ascontiguousarray(img)
    return _sanitise(p, np.ascontiguousarray(img, dtype=np.float32), nonfinite, negative)


def sanitise_pixels(path, img: np.ndarray, nonfinite: str = "error", negative: str = "clamp") -> np.ndarray:
    """The float-pixel validation every input goes through (files here, Blender's images in the add-on):
    NaN/Inf refused ("error") or repaired ("repair"), negative radiance clamped ("clamp", a warning) or
    refused ("error"); ``path`` names the source in messages. Returns float32 (H, W, 3), repaired in a
    copy (the caller's array is not changed)."""
    return _sanitise(path, np.array(img, dtype=np.float32, copy=True), nonfinite, negative)


def preflight(path) -> None:
    """Checks that need no decoder library (they run inside a stock Blender before it opens a file):
    ImageError for a JPEG without its end marker (truncated: Blender would show grey) and for a
    multi-part EXR (Blender can crash on some; the CLI reads them part by part)."""
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


_BLOCK_ROWS = 256  # row blocks for full-resolution passes: temporaries stay a few MB at any width


def _sanitise(path, img: np.ndarray, nonfinite: str, negative: str) -> np.ndarray:
    """Row block by row block, in place (img is this reader's own array): no full-size temporary."""
    n_bad = n_neg = 0
    top, low = -np.inf, 0.0
    for r in range(0, img.shape[0], _BLOCK_ROWS):
        b = img[r:r + _BLOCK_ROWS]
        finite = np.isfinite(b)
        if not finite.all():
            n_bad += int((~finite).any(axis=-1).sum())
        if finite.any():
            top = max(top, float(b[finite].max()))
        neg = (b < 0) & finite  # -Inf is a non-finite pixel (repaired to 0), not a negative one
        if neg.any():
            n_neg += int(neg.any(axis=-1).sum())
            low = min(low, float(b[neg].min()))
    if n_bad:
        if nonfinite == "error":
            raise ImageError(path, f"{n_bad} pixel(s) contain NaN or Inf (pass nonfinite='repair' / "
                                   f"--repair-nonfinite to replace them)")
        top = top if np.isfinite(top) else 0.0
        for r in range(0, img.shape[0], _BLOCK_ROWS):
            np.nan_to_num(img[r:r + _BLOCK_ROWS], copy=False, nan=0.0, posinf=top, neginf=0.0)
        warnings.warn(f"{path}: replaced NaN/Inf in {n_bad} pixel(s) (NaN, -Inf -> 0; +Inf -> {top:g})",
                      PanoLightWarning, stacklevel=3)
    if n_neg:
        if negative == "error":
            raise ImageError(path, f"{n_neg} pixel(s) have negative radiance (minimum {low:g})")
        for r in range(0, img.shape[0], _BLOCK_ROWS):
            np.maximum(img[r:r + _BLOCK_ROWS], 0.0, out=img[r:r + _BLOCK_ROWS])
        warnings.warn(f"{path}: clamped negative radiance to 0 in {n_neg} pixel(s) (minimum was {low:g})",
                      PanoLightWarning, stacklevel=3)
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


def write_exr_rows(path, height: int, width: int, blocks, *, compression: str = "piz", half: bool = False,
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
    codec = getattr(Imath.Compression, _exr_codec(compression))
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
