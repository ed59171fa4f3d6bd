"""Reading panoramas with OpenImageIO, the VFX standard reader: the one path the CLI (the ``openimageio``
wheel) and Blender (the module it ships) take, so both see the same pixels.

The size is known from the header before anything is allocated; pixels are read by row blocks straight
into the one array returned (the peak is that array plus a block, whatever the format: PNG, tiled or
scanline EXR, Radiance .hdr). Quirks handled by the book:
- several subimages (multi-part EXR): the largest full-frame colour part, 2:1 preferred, said in a warning;
- a data window that is a crop of the display window: refused (a panorama covers the whole sphere);
- orientation (EXIF 1-8 of JPEG/PNG, a Radiance ``+Y`` resolution line): applied, the size is the upright one;
- integer EXR channels (UINT): their values, not OpenImageIO's normalisation to [0, 1];
- 16-bit PNG: display-referred LDR (as 8 bits for the estimators, or sRGB-decoded to linear);
- grey (Y) and grey + alpha images: the grey channel three times; two channels that are not grey + alpha
  (an R, G EXR) are refused;
- alpha: ignored, said once (a PNG's colours are read unassociated, never multiplied by alpha);
- Radiance RGBE: the half-step offset of Radiance's own decoder ((mantissa + 0.5) 2^(e - 136));
- any decoder complaint (a JPEG padded with grey past its data, a short file): refused, not kept.
"""
from __future__ import annotations

import warnings

import numpy as np

from ..camera.color import SRGB8_TO_LINEAR, srgb_to_linear
from ..errors import ImageError, PanoLightWarning
from ..packed import PackedImage, Packer
from ..threads import optional_module
from .checks import BLOCK_ROWS, PICTURE_FORMATS, file_state


def available() -> bool:
    return optional_module("OpenImageIO") is not None


class Opened:
    """An open panorama file: ``size`` (upright (height, width)), ``orientation`` (EXIF 1-8), then
    ``pixels()`` once. Close with ``close()`` (or use it as a context manager)."""

    def __init__(self, path, fmt: str):
        import OpenImageIO as oiio

        self.path, self.fmt = path, fmt
        config = oiio.ImageSpec()
        config.attribute("oiio:UnassociatedAlpha", 1)  # a PNG's colours as stored, never multiplied by alpha
        self.inp = oiio.ImageInput.open(str(path), config)
        if self.inp is None:
            raise ImageError(path, f"cannot read {fmt.upper()} header (corrupt or truncated file): "
                                   f"{_clean(oiio.geterror())}")
        try:
            self.subimage, self.spec = self._choose_subimage()
            self.channels = _colour_channels(path, self.spec)
            self.alpha = _has_alpha(self.spec)
            self.luminance_chroma = bool(self.spec.get_int_attribute("openexr:luminancechroma", 0))
            self.orientation = int(self.spec.get_int_attribute("Orientation", 1))
            if self.orientation not in range(1, 9):
                self.orientation = 1
        except BaseException:
            self.close()
            raise
        h, w = self.spec.height, self.spec.width
        self.size = (w, h) if self.orientation >= 5 else (h, w)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def close(self):
        if self.inp is not None:
            self.inp.close()
            self.inp = None

    def _choose_subimage(self):
        """(index, spec) of the part holding the panorama; refuses crops, warns when choosing among parts."""
        found, specs = [], []
        i = 0
        while self.inp.seek_subimage(i, 0):
            spec = self.inp.spec()
            specs.append(spec)
            if _colour_layout(spec.channelnames) is not None:
                full = (spec.x, spec.y, spec.width, spec.height) == \
                       (spec.full_x, spec.full_y, spec.full_width, spec.full_height)
                found.append((full, spec.width == 2 * spec.height, spec.width * spec.height, -i, i))
            i += 1
            if i > 64:
                break
        if not found:
            names = sorted({c for s in specs for c in s.channelnames})
            raise ImageError(self.path, f"no R, G, B (or Y) channels in any part; channels are {names}")
        full, _, _, _, i = max(found)
        spec = specs[i]
        if not full:
            raise ImageError(self.path, f"its data window ({spec.x},{spec.y}) {spec.width} x {spec.height} is a crop "
                                        f"of its display window ({spec.full_x},{spec.full_y}) {spec.full_width} x "
                                        f"{spec.full_height}; a panorama must cover the whole sphere")
        if len(specs) > 1:
            name = spec.get_string_attribute("name") or str(i)
            warnings.warn(PanoLightWarning(f"{self.path}: {len(specs)} parts; using part {i} ({name!r}, "
                                           f"{spec.width} x {spec.height} {_colour_layout(spec.channelnames)}), "
                                           f"the largest full-frame colour part"), stacklevel=2)
        self.inp.seek_subimage(i, 0)
        self.inp.geterror()  # cleared: the probe past the last part leaves one (a TIFF's "no such directory")
        return i, spec

    def pixels(self, as_uint8: bool = False, packed: str | None = None):
        """(H, W, 3) upright: uint8 sRGB values (8-bit files, or 16-bit PNGs rounded, with ``as_uint8``),
        else float32 linear (8/16-bit files sRGB-decoded; HDR files as stored, integer channels as their
        values). packed: "rgbe" or "half" keeps float channels as a ``packed.PackedImage`` of that code
        where every value fits it exactly (else float32, as without it)."""
        spec = self.spec
        if self.luminance_chroma:  # OpenImageIO's Python reader fails on these (or, elsewhere, misreads them)
            raise ImageError(self.path, "a luminance/chroma (Y, RY, BY) EXR, which needs the OpenEXR package to be "
                                        "read here; estimate it with 'panolight estimate', or save it as RGB")
        h, w = spec.height, spec.width
        base = str(spec.format)
        integer_ldr = self.fmt in PICTURE_FORMATS
        if integer_ldr and base == "uint8":
            kind, out_dtype = "uint8", np.uint8
        elif integer_ldr and base == "uint16":
            kind, out_dtype = "uint16", (np.uint8 if as_uint8 else np.float32)
        elif base in ("uint", "uint32"):  # an EXR's integer channels: their values
            kind, out_dtype = "uint32", np.float32
        else:
            kind, out_dtype = "float", np.float32
        blocks = self._blocks(kind, as_uint8)
        if packed and kind == "float":
            reread = self._reread(kind) if self.fmt == "exr" else None  # scanline and tiled EXRs: any rows
            with Packer(h, w, packed, reread) as sink:
                for r0, block in blocks:
                    if self.fmt == "hdr":
                        _radiance_half_step(block)
                    sink.put(r0, block)
                    if sink.done:
                        break
                out = sink.result()
            if self.orientation not in (0, 1) and isinstance(out, PackedImage):
                out = np.asarray(out)
        else:
            out = np.empty((h, w, 3), out_dtype)
            for r0, block in blocks:
                out[r0:r0 + len(block)] = block
                if self.fmt == "hdr":
                    _radiance_half_step(out[r0:r0 + len(block)])
        if self.inp.has_error:  # a warning the last block raised (libjpeg's "premature end", ...)
            raise ImageError(self.path, f"cannot decode {self.fmt.upper()} pixels (corrupt or truncated file): "
                                        f"{_clean(self.inp.geterror())}")
        if self.alpha:
            warnings.warn(PanoLightWarning(f"{self.path}: its alpha channel was ignored: a panorama's alpha is not "
                                           f"a lighting weight, so its colours are used as they are"), stacklevel=2)
        if integer_ldr and out.dtype == np.uint8 and not as_uint8:
            out = SRGB8_TO_LINEAR[out]  # the table gather makes only its output
        return upright(out, self.orientation)

    def _reread(self, kind: str):
        """rows(r0, r1) of this subimage's colour channels read again from the file by a reader of its own (what a
        ``packed.RowFile`` reads at each pass); a file changed or removed since the first read is refused in one
        line, never read as another picture."""
        path, subimage, spec, channels = self.path, self.subimage, self.spec, self.channels
        state = {}
        seen = file_state(path)

        def rows(r0: int, r1: int) -> np.ndarray:
            import OpenImageIO as oiio

            now = file_state(path)
            if now is None or now != seen:
                raise ImageError(path, "was changed or removed while it was being estimated (a panorama this large "
                                       "is read from its file at each pass): estimate it again")
            if "inp" not in state:
                state["inp"] = oiio.ImageInput.open(str(path))
            inp = state["inp"]
            block = None if inp is None else _scanlines(inp, subimage, spec, channels, r0, r1, kind)
            if block is None:
                raise ImageError(path, f"cannot read its pixels again: {_clean(oiio.geterror())}")
            return block

        return rows

    def _blocks(self, kind: str, as_uint8: bool):
        """(first row, (n, W, 3) array of its own) of the chosen subimage, in order: OpenImageIO's ``kind``
        ("uint8", "uint16" turned into 8-bit or linear float32, "uint32", "float"), colour channels only."""
        h = self.spec.height
        for r0 in range(0, h, BLOCK_ROWS):
            r1 = min(h, r0 + BLOCK_ROWS)
            block = _scanlines(self.inp, self.subimage, self.spec, self.channels, r0, r1, kind)
            if block is None or self.inp.has_error:
                raise ImageError(self.path, f"cannot decode {self.fmt.upper()} pixels (corrupt or truncated file): "
                                            f"{_clean(self.inp.geterror())}")
            yield r0, (_from_16_bits(block, as_uint8) if kind == "uint16" else block)


def _scanlines(inp, subimage: int, spec, channels, r0: int, r1: int, kind: str) -> np.ndarray | None:
    """Rows r0..r1 (of the data window) of a subimage's ``channels``, in that order, as OpenImageIO's ``kind``
    ((n, W, len(channels)), an array of its own); None when the read fails."""
    first, last = min(channels), max(channels)
    block = inp.read_scanlines(subimage, 0, spec.y + r0, spec.y + r1, 0, first, last + 1, kind)
    if block is None:
        return None
    return np.asarray(block).reshape(r1 - r0, spec.width, last - first + 1)[..., [c - first for c in channels]]


def _from_16_bits(block: np.ndarray, as_uint8: bool) -> np.ndarray:
    """16-bit LDR values -> 8-bit (rounded) or linear float32."""
    v = block.astype(np.float32) / np.float32(65535.0)
    if as_uint8:
        return np.round(v * 255.0).astype(np.uint8)
    return srgb_to_linear(v).astype(np.float32)


def _radiance_half_step(img: np.ndarray) -> None:
    """OpenImageIO decodes RGBE as mantissa 2^(e - 136); Radiance's own decoder (and the format's
    definition of a stored value as the middle of its step) adds half a step: (mantissa + 0.5) 2^(e - 136).
    The pixel's largest channel has the mantissa 128-255, so its float32 exponent field E gives the half
    step as the float of exponent field E - 8 (made from the bits: frexp/ldexp cost 2.5x the decode).
    In place, by row blocks."""
    for r in range(0, img.shape[0], BLOCK_ROWS):
        b = img[r:r + BLOCK_ROWS]
        e = np.maximum(np.maximum(b[..., 0], b[..., 1]), b[..., 2]).view(np.int32) >> 23  # sign bit is 0
        e -= 8
        np.maximum(e, 0, out=e)  # zero pixels (and steps below float32's range) get nothing
        e <<= 23
        b += e.view(np.float32)[..., None]


def upright(img: np.ndarray, orientation: int) -> np.ndarray:
    """Pixels as displayed, from the stored ones and the EXIF orientation (1-8; Pillow's exif_transpose)."""
    if orientation in (0, 1):
        return img
    view = {2: lambda a: a[:, ::-1], 3: lambda a: a[::-1, ::-1], 4: lambda a: a[::-1],
            5: lambda a: np.swapaxes(a, 0, 1), 6: lambda a: np.rot90(a, -1),
            7: lambda a: np.swapaxes(a[::-1, ::-1], 0, 1), 8: lambda a: np.rot90(a, 1)}[orientation](img)
    return np.ascontiguousarray(view)


def _colour_layout(names) -> str | None:
    names = set(names)
    if {"R", "G", "B"} <= names:
        return "RGB"
    if {"Y", "RY", "BY"} <= names:
        return "YC"
    return "Y" if "Y" in names or len(names) == 1 or (len(names) == 2 and "A" in names) else None


def _colour_channels(path, spec) -> list[int]:
    """Channel indices of R, G, B (a grey image's one channel three times)."""
    names = list(spec.channelnames)
    if {"R", "G", "B"} <= set(names):
        return [names.index(c) for c in "RGB"]
    if "Y" in names and not {"RY", "BY"} & set(names):
        return [names.index("Y")] * 3
    if len(names) == 1 or (len(names) == 2 and _has_alpha(spec)):  # grey, grey + alpha (PNG)
        return [0, 0, 0]
    raise ImageError(path, f"has channels {names}: not grey, grey + alpha or RGB, so its colours are unknown "
                           f"(PanoLight reads Y, Y + A, R G B or R G B A)")


def _has_alpha(spec) -> bool:
    """Whether the image has an alpha channel (an 'A' channel, or one the format marks as alpha)."""
    return spec.alpha_channel >= 0 or "A" in list(spec.channelnames)


def _clean(message: str) -> str:
    return " ".join(str(message).split()) or "the decoder gave no reason"
