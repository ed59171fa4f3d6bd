"""Checks on image files and pixels that need no decoder library (numpy only: they run inside a stock
Blender too): what a file is (by content), whether its size fits the decode budget, whether a JPEG's
data can hold the size it claims, and the validation every float pixel goes through."""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from ..camera.color import LUMINANCE_WEIGHTS, SRGB8_TO_LINEAR
from ..errors import ImageError, PanoLightWarning
from ..packed import repair
from ..sh.grid import MAX_SIDE  # larger images are refused as absurd

MAX_PIXELS = 1 << 29  # 32768 x 16384: no size above this is read at all
DEFAULT_MAX_MEGAPIXELS = 140.0  # the decode budget: 16384 x 8192 (134 MP, the largest common HDRI) fits
HDR_FORMATS = ("exr", "hdr")
LDR_FORMATS = ("png", "jpeg")
RAW_FORMAT = "raw"  # a camera RAW (io.read_raw): linear, its sensor's white the ceiling
TIFF_FORMAT = "tiff"  # a TIFF picture (a stitcher's output, Hugin's default): 8/16-bit sRGB as a PNG, float as linear
PICTURE_FORMATS = LDR_FORMATS + (TIFF_FORMAT,)  # formats whose integer samples are sRGB codes (a float TIFF's: light)
TIFF_EXTENSIONS = (".tif", ".tiff")  # a file starting like a TIFF is a picture under these names; a camera RAW (a DNG,
# NEF, CR2 ...: TIFF containers too) under its own
RAW_EXTENSIONS = (".dng", ".cr2", ".cr3", ".crw", ".nef", ".nrw", ".arw", ".srf", ".sr2", ".raf", ".orf", ".rw2",
                  ".pef", ".srw", ".3fr", ".iiq", ".erf", ".kdc", ".mos", ".mrw", ".x3f")  # batch's folder scan
# a RAW's first bytes: TIFF's (DNG, CR2, NEF, ARW, PEF, SRW ...), Olympus', Panasonic's, Fujifilm's and CR3's box
_TIFF_MAGIC = (b"II*\x00", b"MM\x00*")
_RAW_MAGIC = _TIFF_MAGIC + (b"IIRO", b"IIRS", b"MMOR", b"IIU\x00", b"FUJIFILM")
_HEIF_BRANDS = (b"heic", b"heix", b"hevc", b"hevx", b"heim", b"heis", b"mif1", b"msf1", b"avif", b"avis")  # ISO BMFF
BLOCK_ROWS = 256  # row blocks for full-resolution passes: temporaries stay a few MB at any width
# a JPEG codes every 8 x 8 luma block with at least one bit (its DC difference, even in progressive
# scans): fewer bytes than pixels / 512 cannot hold the picture; half that is refused as corrupt
JPEG_MIN_PIXELS_PER_BYTE = 1024


def file_state(path) -> tuple | None:
    """What tells a file's content changed without reading it: (device, inode, size, mtime ns, ctime ns); None
    when it cannot be stat'ed. The ctime moves on every write, also one whose writer put the mtime back."""
    import os

    try:
        st = os.stat(path)
    except OSError:
        return None
    return st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns


def sniff_format(path) -> str:
    """'exr' | 'hdr' | 'png' | 'jpeg' | 'raw' (a TIFF-like or camera RAW file, which io.read_raw decodes or refuses)
    from the file's first bytes; raises ImageError otherwise."""
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
    if head.startswith(_TIFF_MAGIC) and p.suffix.lower() in TIFF_EXTENSIONS:
        return TIFF_FORMAT
    if head.startswith(_RAW_MAGIC) or head[4:12] == b"ftypcrx ":
        return RAW_FORMAT
    if head[4:8] == b"ftyp" and head[8:12] in _HEIF_BRANDS:
        raise ImageError(p, "a HEIF (HEIC) or AVIF photo, a phone's default format, which PanoLight does not decode: "
                            "save or export it as JPEG with its EXIF (an iPhone: Settings > Camera > Formats > Most "
                            "Compatible), or shoot RAW (DNG)")
    raise ImageError(p, f"not a supported image (OpenEXR, Radiance .hdr, PNG, JPEG, TIFF or a camera RAW); starts "
                        f"with {head[:8]!r}")


def is_hdr(path) -> bool:
    """True for OpenEXR / Radiance files and float TIFFs (by content): files whose values are linear light."""
    fmt = sniff_format(path)
    return fmt in HDR_FORMATS or (fmt == TIFF_FORMAT and tiff_is_float(path))


TIFF_MAX_ENTRIES = 4096  # a first directory with more entries than this is no picture's


def tiff_is_float(path) -> bool:
    """Whether a TIFF's first image holds floating-point samples (its SampleFormat tag, SHORT, says 3: IEEE float),
    read from the header (numpy only: Blender sets a float TIFF's colour space before decoding it). False for integer
    samples and for anything the header does not say plainly (a short or malformed directory)."""
    try:
        with open(path, "rb") as f:
            head = f.read(8)
            if len(head) < 8 or head[:4] not in _TIFF_MAGIC:
                return False
            order = "little" if head[:2] == b"II" else "big"
            f.seek(int.from_bytes(head[4:8], order))
            count = int.from_bytes(f.read(2), order)
            if not 0 < count <= TIFF_MAX_ENTRIES:
                return False
            entries = f.read(12 * count)
            for k in range(len(entries) // 12):
                entry = entries[12 * k:12 * k + 12]
                if int.from_bytes(entry[:2], order) != 339:  # SampleFormat
                    continue
                if int.from_bytes(entry[2:4], order) != 3:  # not SHORT: not a header PanoLight reads
                    return False
                value = entry[8:10]
                if int.from_bytes(entry[4:8], order) > 2:  # one per sample, more than fit inline: at the offset
                    f.seek(int.from_bytes(entry[8:12], order))
                    value = f.read(2)
                return int.from_bytes(value, order) == 3
    except (OSError, ValueError, OverflowError):
        return False
    return False


def check_size(path, h: int, w: int, equirect: bool, max_megapixels: float = DEFAULT_MAX_MEGAPIXELS):
    """ImageError unless (h, w) is a size worth decoding: not zero, within the decode budget
    (``max_megapixels``) and MAX_PIXELS, and 2:1 when ``equirect``."""
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


FISHEYE_DARK = 0.02  # a pixel under this share of the image circles' median luminance is black (the lens' shadow)
FISHEYE_SAMPLE = 128  # the test reads about this many rows (and twice as many columns)


def dual_fisheye(pixels: np.ndarray) -> bool:
    """True when a 2:1 image (H, W, 3: uint8 sRGB or float linear) is two side-by-side fisheye circles on black (an
    unstitched 360 capture: a Theta's or an Insta360's dual-fisheye DNG or .insp, 2:1 like a panorama): almost every
    pixel outside both circles (diameter H, centred on each half) black, almost none inside. A night panorama's
    black sky is inside the circles too, so it never passes. Reads every (H / FISHEYE_SAMPLE)-th row and column."""
    h, w = pixels.shape[:2]
    if w != 2 * h or h < 16:
        return False
    step = max(1, h // FISHEYE_SAMPLE)
    sample = np.asarray(pixels[::step, ::step])
    lum = (SRGB8_TO_LINEAR[sample] if sample.dtype == np.uint8 else sample.astype(np.float32)) @ LUMINANCE_WEIGHTS
    y = (np.arange(sample.shape[0]) * step + 0.5)[:, None] - h / 2.0
    x = np.arange(sample.shape[1]) * step + 0.5
    r = np.minimum(np.hypot(y, x[None, :] - h / 2.0), np.hypot(y, x[None, :] - 1.5 * h)) / (h / 2.0)
    inside, outside = r < 0.9, r > 1.05  # the rims left out: a lens' circle is a little smaller or larger than H
    ref = float(np.median(lum[inside]))
    if not ref > 0:
        return False
    dark = lum < FISHEYE_DARK * ref
    return bool(dark[outside].mean() > 0.98 and dark[inside].mean() < 0.05)


def check_stitched(path, pixels: np.ndarray) -> None:
    """ImageError naming ``path`` when its pixels are an unstitched dual-fisheye capture (``dual_fisheye``)."""
    if dual_fisheye(pixels):
        raise ImageError(path, "two image circles on black: an unstitched dual-fisheye capture, not an "
                               "equirectangular panorama; stitch it first (the camera maker's app or stitcher)")


def check_jpeg_data(path, h: int, w: int) -> None:
    """ImageError when a JPEG's file is too small for the size its frame header claims (a patched or
    truncated header: decoders would pad the missing picture with grey)."""
    size = Path(path).stat().st_size
    if size * JPEG_MIN_PIXELS_PER_BYTE < h * w:
        raise ImageError(path, f"the JPEG claims {w} x {h} pixels but holds only {size} bytes, too few for that "
                               f"picture (corrupt or truncated file)")


def sanitise_pixels(path, img: np.ndarray) -> np.ndarray:
    """The float-pixel validation of an image not read from a file (Blender's own pixels, in the add-on), as
    ``read_image`` validates files by default: NaN/Inf refused, negative radiance clamped (a warning); ``path``
    names the source in messages. Returns float32 (H, W, 3), repaired in a copy (the caller's array is not
    changed)."""
    return _sanitise(path, np.array(img, dtype=np.float32, copy=True), "error", "clamp")


def _sanitise(path, img, nonfinite: str, negative: str):
    """Row block by row block, in place (img is this reader's own array): no full-size temporary. A
    ``packed.RowFile`` is scanned the same way and told the repairs its later reads apply."""
    n_bad = n_neg = 0
    top, low = -np.inf, 0.0
    for r in range(0, img.shape[0], BLOCK_ROWS):
        b = img[r:r + BLOCK_ROWS]
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
        warnings.warn(f"{path}: replaced NaN/Inf in {n_bad} pixel(s) (NaN, -Inf -> 0; +Inf -> {top:g})",
                      PanoLightWarning, stacklevel=3)
    if n_neg:
        if negative == "error":
            raise ImageError(path, f"{n_neg} pixel(s) have negative radiance (minimum {low:g})")
        warnings.warn(f"{path}: clamped negative radiance to 0 in {n_neg} pixel(s) (minimum was {low:g})",
                      PanoLightWarning, stacklevel=3)
    fix = ((top if n_bad else None), bool(n_neg))
    if not isinstance(img, np.ndarray):  # a packed.RowFile: its reads apply the repairs decided here
        img.repair, img.top = fix, (max(float(top), 0.0) if np.isfinite(top) else 0.0)
    elif n_bad or n_neg:
        for r in range(0, img.shape[0], BLOCK_ROWS):
            repair(img[r:r + BLOCK_ROWS], *fix)
    return img
