import sys
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from panolight_core.camera.color import SRGB8_TO_LINEAR
from panolight_core.errors import ImageError, PanoLightWarning
from panolight_core.io import hdr as hdr_codec
from panolight_core.io import read_image, sniff_format, write_image, write_srgb8
from panolight_core.io.read_raw import read_raw


@pytest.fixture
def pano(rng):
    img = (rng.random((16, 32, 3)) * 4.0).astype(np.float32)
    img[3, 5] = [1e4, 2e3, 1e2]  # HDR peak
    return img


@pytest.mark.parametrize("ext,kw,tol", [("exr", {}, 0.0), ("exr", {"half": True}, 1e-3), ("hdr", {}, 1 / 128)])
def test_hdr_round_trips(tmp_path, pano, ext, kw, tol):
    p = write_image(tmp_path / f"a.{ext}", pano, **kw)
    back = read_image(p)
    assert back.dtype == np.float32 and back.shape == pano.shape
    # EXR half: relative per value; RGBE: 8-bit mantissas share one exponent, so error ~ pixel max / 256
    scale = pano.max(axis=-1, keepdims=True) if ext == "hdr" else np.abs(pano)
    assert np.all(np.abs(back - pano) <= tol * scale + 1e-6)


@pytest.mark.parametrize("ext,bits,tol", [("png", 8, 0.5 / 255 * 13), ("png", 16, 1e-4), ("jpg", 8, 0.25)])
def test_ldr_round_trips_are_srgb_linearised(tmp_path, rng, ext, bits, tol):
    ramp = np.linspace(0, 1, 32, dtype=np.float32)
    ldr = np.stack(np.broadcast_arrays(ramp[None, :], ramp[:16, None] * 2, 0.5 * np.ones((16, 32), np.float32)), -1)
    ldr = np.clip(ldr, 0, 1) if ext == "jpg" else rng.random((16, 32, 3)).astype(np.float32)
    back = read_image(write_image(tmp_path / f"a.{ext}", ldr, bit_depth=bits))
    np.testing.assert_allclose(back, ldr, atol=tol)
    if ext != "jpg":
        assert np.abs(back - ldr).mean() < tol / 4


def test_radiance_rle_scanlines_decode(pano):
    """Encode new-style RLE scanlines by hand (runs and literals) and decode them."""
    img = np.zeros((2, 16, 3), dtype=np.float32)
    img[:, :8] = 1.0
    img[:, 8:] = np.linspace(0.1, 0.9, 8)[None, :, None]
    flat = hdr_codec.encode(img)
    header_end = flat.index(b"+X 16\n") + len(b"+X 16\n")
    rgbe = np.frombuffer(flat[header_end:], dtype=np.uint8).reshape(2, 16, 4)
    body = b""
    for y in range(2):
        body += bytes([2, 2, 0, 16])
        for ch in range(4):
            row = rgbe[y, :, ch]
            body += bytes([128 + 8, row[0]]) + bytes([8]) + row[8:].tobytes()
    np.testing.assert_allclose(hdr_codec.decode(flat[:header_end] + body), hdr_codec.decode(flat))
    with pytest.raises(ValueError, match="truncated|corrupt"):
        hdr_codec.decode(flat[:header_end] + body[:-5])


def test_missing_empty_directory_and_unknown(tmp_path):
    with pytest.raises(ImageError, match="not found") as e:
        read_image(tmp_path / "nope.exr")
    assert "nope.exr" in str(e.value)
    (tmp_path / "empty.exr").write_bytes(b"")
    with pytest.raises(ImageError, match="empty"):
        read_image(tmp_path / "empty.exr")
    with pytest.raises(ImageError, match="directory"):
        read_image(tmp_path)
    (tmp_path / "notes.exr").write_text("hello, not an image")
    with pytest.raises(ImageError, match="not a supported image"):
        read_image(tmp_path / "notes.exr")
    for brand in (b"heic", b"mif1", b"avif"):  # a phone's default format: said what it is and what to do
        (tmp_path / "IMG_0001.HEIC").write_bytes(b"\x00\x00\x00\x18ftyp" + brand + b"\x00" * 64)
        with pytest.raises(ImageError, match=r"IMG_0001.HEIC: a HEIF \(HEIC\) or AVIF photo.*as JPEG with its EXIF"):
            read_image(tmp_path / "IMG_0001.HEIC")


def test_content_not_extension_decides(tmp_path, pano):
    png = write_image(tmp_path / "a.png", np.clip(pano, 0, 1))
    renamed = tmp_path / "really_png.exr"
    renamed.write_bytes(png.read_bytes())
    assert sniff_format(renamed) == "png"
    np.testing.assert_allclose(read_image(renamed), read_image(png))


@pytest.mark.parametrize("ext", ["exr", "hdr", "png", "jpg"])
def test_truncated_files(tmp_path, pano, ext):
    p = write_image(tmp_path / f"a.{ext}", np.clip(pano, 0, 1) if ext in ("png", "jpg") else pano)
    data = p.read_bytes()
    cut = tmp_path / f"cut.{ext}"
    cut.write_bytes(data[: len(data) // 2])
    with pytest.raises(ImageError, match="corrupt or truncated") as e:
        read_image(cut)
    assert str(cut) in str(e.value)


def test_not_2_to_1_and_zero_and_absurd_sizes(tmp_path):
    p = write_image(tmp_path / "square.exr", np.ones((8, 8, 3), np.float32))
    with pytest.raises(ImageError, match="2:1"):
        read_image(p)
    assert read_image(p, equirect=False).shape == (8, 8, 3)
    (tmp_path / "zero.hdr").write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 0 +X 0\n")
    with pytest.raises(ImageError, match="zero size"):
        read_image(tmp_path / "zero.hdr")
    (tmp_path / "huge.hdr").write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 100000 +X 200000\n" + b"\0" * 64)
    with pytest.raises(ImageError, match="larger than supported"):
        read_image(tmp_path / "huge.hdr")


def test_nonfinite_rejected_or_repaired(tmp_path, pano):
    bad = pano.copy()
    bad[0, 0, 0] = np.nan
    bad[1, 1] = np.inf
    bad[2, 2, 1] = -np.inf
    p = write_image(tmp_path / "bad.exr", bad)
    with pytest.raises(ImageError, match="3 pixel.*NaN or Inf"):
        read_image(p)
    with pytest.warns(PanoLightWarning, match="replaced NaN/Inf in 3 pixel"):
        fixed = read_image(p, nonfinite="repair")
    assert np.all(np.isfinite(fixed))
    assert fixed[0, 0, 0] == 0 and fixed[2, 2, 1] == 0 and fixed[1, 1, 0] == pano.max()


def test_negative_radiance_clamped_with_warning_or_rejected(tmp_path, pano):
    neg = pano.copy()
    neg[4, 4] = -0.5
    p = write_image(tmp_path / "neg.exr", neg)
    with pytest.warns(PanoLightWarning, match="clamped negative radiance to 0 in 1 pixel"):
        img = read_image(p)
    assert img.min() == 0
    with pytest.raises(ImageError, match="negative radiance"):
        read_image(p, negative="error")


def test_clean_file_gives_no_warning(tmp_path, pano):
    p = write_image(tmp_path / "ok.exr", pano)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        read_image(p)


def test_write_errors_and_atomicity(tmp_path, pano):
    with pytest.raises(ImageError, match="unknown image extension"):
        write_image(tmp_path / "a.tiff", pano)
    with pytest.raises(ImageError, match="does not exist"):
        write_image(tmp_path / "missing" / "a.exr", pano)
    with pytest.raises(ImageError, match="shape"):
        write_image(tmp_path / "a.exr", np.zeros((4, 4)))
    with pytest.raises(ImageError, match="bit_depth"):
        write_image(tmp_path / "a.jpg", pano, bit_depth=16)
    assert sorted(p.name for p in tmp_path.iterdir()) == []  # no partial files left behind


def _exr_parts(path, parts):
    import OpenEXR

    with OpenEXR.File([OpenEXR.Part({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage,
                                     **head}, ch, name=name) for name, head, ch in parts]) as f:
        f.write(str(path))
    return path


def test_multipart_exr_uses_the_panorama_part_and_says_so(tmp_path):
    import warnings

    import numpy as np

    from panolight_core.errors import PanoLightWarning
    from panolight_core.io import read_image

    pano = np.random.default_rng(1).random((8, 16, 3)).astype(np.float32)
    disp = ((0, 0), (15, 7))
    path = _exr_parts(tmp_path / "multi.exr", [
        ("mask", {"displayWindow": disp, "dataWindow": ((0, 0), (3, 3))}, {"Y": np.zeros((4, 4), np.float32)}),
        ("beauty", {"displayWindow": disp, "dataWindow": disp}, {"RGB": pano})])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        got = read_image(path)
    np.testing.assert_array_equal(got, pano)
    assert any(isinstance(w.message, PanoLightWarning) and "using part 1 ('beauty'" in str(w.message) for w in caught)


def test_cropped_exr_is_refused(tmp_path):
    import numpy as np
    import pytest

    from panolight_core.errors import ImageError
    from panolight_core.io import read_image

    path = _exr_parts(tmp_path / "crop.exr", [
        ("crop", {"displayWindow": ((0, 0), (31, 15)), "dataWindow": ((0, 0), (15, 7))},
         {"RGB": np.ones((8, 16, 3), np.float32)})])
    with pytest.raises(ImageError, match="crop.exr: .*is a crop of its display window"):
        read_image(path)


def test_luminance_chroma_exr_keeps_its_colour(tmp_path):
    import numpy as np
    import OpenEXR

    from panolight_core.camera.color import LUMINANCE_WEIGHTS
    from panolight_core.io import read_image

    rgb = (np.random.default_rng(2).random((8, 16, 3)) + 0.1).astype(np.float32)
    y = (rgb @ LUMINANCE_WEIGHTS.astype(np.float32)).astype(np.float32)
    ch = {"Y": y, "RY": (rgb[..., 0] - y) / y, "BY": (rgb[..., 2] - y) / y}
    with OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}, ch) as f:
        f.write(str(tmp_path / "yc.exr"))
    np.testing.assert_allclose(read_image(tmp_path / "yc.exr"), rgb, rtol=1e-5, atol=1e-6)


def test_16bit_png_is_ldr_for_the_estimators(tmp_path):
    import numpy as np
    import png

    from panolight_core.estimators import estimate
    from panolight_core.io import read_image

    rng = np.random.default_rng(3)
    v8 = rng.integers(0, 200, (32, 64, 3)).astype(np.uint8)
    v8[5:8, 10:14] = 255  # a clipped lamp
    v16 = v8.astype(np.uint16) * 257
    path = tmp_path / "p16.png"
    with open(path, "wb") as f:
        png.Writer(64, 32, bitdepth=16, greyscale=False).write(f, v16.reshape(32, -1).tolist())
    got = read_image(path, ldr_as_uint8=True)
    assert got.dtype == np.uint8
    np.testing.assert_array_equal(got, v8)
    a, b = estimate(got, 2, "sources"), estimate(v8, 2, "sources")  # the same lighting as the 8-bit picture
    np.testing.assert_allclose(a.coeffs, b.coeffs)


@pytest.mark.parametrize("orientation", [1, 3, 6])
def test_exif_orientation_is_applied(tmp_path, orientation):
    from PIL import Image

    upright = (np.random.default_rng(4).random((16, 32, 3)) * 255).astype(np.uint8)
    # what a camera stores: the picture turned, plus a tag saying how to turn it upright (6: 90 deg clockwise)
    stored = {1: upright, 3: upright[::-1, ::-1], 6: np.rot90(upright, 1)}[orientation]
    im = Image.fromarray(np.ascontiguousarray(stored))
    exif = im.getexif()
    exif[0x0112] = orientation
    im.save(tmp_path / "o.png", exif=exif)
    np.testing.assert_array_equal(read_image(tmp_path / "o.png", ldr_as_uint8=True), upright)


def test_a_header_claiming_a_huge_image_is_refused_before_decoding(tmp_path):
    import struct
    import zlib

    # a 100-byte PNG whose header claims 16000 x 8000 (a decompression bomb): refused from the header
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    ihdr = struct.pack(">IIBBBBB", 16000, 8000, 8, 2, 0, 0, 0)
    path = tmp_path / "bomb.png"
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"\0" * 10))
                     + chunk(b"IEND", b""))
    with pytest.raises(ImageError, match="bomb.png: image is 16000 x 8000 = 128 megapixels, above the decode budget"):
        read_image(path, max_megapixels=100)
    with pytest.raises(ImageError, match="bomb.png: "):  # within the budget, the truncated data is refused
        read_image(path)


def test_preflight_needs_no_decoder_and_catches_what_blender_would_misread(tmp_path):
    from PIL import Image

    from panolight_core.io.images import preflight

    ok = tmp_path / "ok.jpg"
    Image.fromarray(np.full((8, 16, 3), 99, np.uint8)).save(ok)
    preflight(ok)
    (tmp_path / "cut.jpg").write_bytes(ok.read_bytes()[:-50])
    with pytest.raises(ImageError, match="cut.jpg: the JPEG is truncated"):
        preflight(tmp_path / "cut.jpg")
    disp = ((0, 0), (15, 7))
    multi = _exr_parts(tmp_path / "multi.exr", [
        ("a", {"displayWindow": disp, "dataWindow": disp}, {"RGB": np.ones((8, 16, 3), np.float32)}),
        ("b", {"displayWindow": disp, "dataWindow": disp}, {"RGB": np.ones((8, 16, 3), np.float32)})])
    with pytest.raises(ImageError, match="multi.exr: a multi-part EXR"):
        preflight(multi)
    preflight(write_image(tmp_path / "single.exr", np.ones((8, 16, 3), np.float32)))


@pytest.mark.parametrize("size,message", [((16384, 32768), "above the decode budget"),
                                          ((8192, 16384), "cannot decode HDR pixels")])
def test_a_small_hdr_claiming_a_huge_size_is_refused(tmp_path, size, message):
    h, w = size
    path = tmp_path / "claim.hdr"
    path.write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n" + f"-Y {h} +X {w}\n".encode() + b"\x02\x02\x40\x00" * 4)
    with pytest.raises(ImageError, match=f"claim.hdr: .*{message}"):
        read_image(path)


def test_srgb8_pixels_are_written_as_they_are(tmp_path):
    y, x = np.mgrid[0:16, 0:32]
    px = np.stack([x * 8, y * 16, 255 - x * 8], axis=-1).astype(np.uint8)  # smooth: JPEG keeps it closely
    back = read_image(write_srgb8(tmp_path / "a.png", px), ldr_as_uint8=True)
    assert np.array_equal(back, px)
    jpg = read_image(write_srgb8(tmp_path / "a.jpg", px, quality=100), ldr_as_uint8=True)
    assert jpg.dtype == np.uint8 and np.abs(jpg.astype(int) - px).mean() < 3
    for bad, path, msg in ((px.astype(np.float32), "b.png", "uint8"), (px, "b.exr", ".png or .jpg"),
                           (px[..., :2], "b.png", "uint8"), (px, "missing/b.png", "does not exist")):
        with pytest.raises(ImageError, match=msg):
            write_srgb8(tmp_path / path, bad)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.jpg", "a.png"]  # no temporary files left


def test_large_images_are_read_by_row_blocks_with_the_same_pixels(tmp_path):
    """More rows than one block (io.checks.BLOCK_ROWS): PNG and EXR read block by block into one array."""
    from PIL import Image

    from panolight_core.io.checks import BLOCK_ROWS

    y, x = np.mgrid[0:BLOCK_ROWS + 44, 0:2 * (BLOCK_ROWS + 44)]
    px = np.stack([x % 256, y % 256, (x + y) % 256], -1).astype(np.uint8)
    Image.fromarray(px).save(tmp_path / "big.png")
    assert np.array_equal(read_image(tmp_path / "big.png", ldr_as_uint8=True), px)
    hdr = (px / 7.0).astype(np.float32)
    assert np.array_equal(read_image(write_image(tmp_path / "big.exr", hdr)), hdr)


@pytest.mark.parametrize("options", [{"quality": 90}, {"quality": 95, "subsampling": 0},
                                     {"quality": 75, "subsampling": 1}, {"quality": 85, "progressive": True}])
def test_jpegs_decode_to_pillows_pixels_with_or_without_simplejpeg(tmp_path, monkeypatch, options):
    """simplejpeg (the fast path) and OpenImageIO (Blender's reader) give Pillow's pixels exactly."""
    from PIL import Image

    rng = np.random.default_rng(3)
    px = (rng.random((33, 66, 3)) * 255).astype(np.uint8)
    px[:10] = np.linspace(0, 255, 66).astype(np.uint8)[None, :, None]  # a ramp up to clipped white
    path = tmp_path / "a.jpg"
    Image.fromarray(px).save(path, **options)
    with Image.open(path) as im:
        expected = np.asarray(im.convert("RGB"))
    fast = read_image(path, ldr_as_uint8=True)
    monkeypatch.setitem(sys.modules, "simplejpeg", None)  # not installed: OpenImageIO decodes
    slow = read_image(path, ldr_as_uint8=True)
    assert np.array_equal(fast, expected) and np.array_equal(slow, expected)
    assert np.array_equal(read_image(path), SRGB8_TO_LINEAR[expected])


def test_jpegs_simplejpeg_does_not_take_go_to_openimageio_and_corrupt_ones_are_refused(tmp_path):
    from PIL import Image

    grey = tmp_path / "grey.jpg"
    Image.fromarray(np.full((8, 16), 77, np.uint8), "L").save(grey)
    assert np.array_equal(read_image(grey, ldr_as_uint8=True), np.full((8, 16, 3), 77, np.uint8))
    cmyk = tmp_path / "cmyk.jpg"
    Image.new("CMYK", (16, 8), (0, 0, 0, 0)).save(cmyk)
    assert np.all(read_image(cmyk, ldr_as_uint8=True) >= 250)  # no ink: white
    ok = tmp_path / "ok.jpg"
    Image.fromarray((np.random.default_rng(0).random((64, 128, 3)) * 255).astype(np.uint8)).save(ok)
    data = ok.read_bytes()
    (tmp_path / "cut.jpg").write_bytes(data[:len(data) // 2])  # refused, never padded with grey
    with pytest.raises(ImageError, match="cut.jpg: cannot decode JPEG pixels"):
        read_image(tmp_path / "cut.jpg")


def test_radiance_files_read_by_openimageio_equal_radiances_own_decoding(tmp_path):
    """OpenImageIO decodes RGBE without Radiance's half-step offset; the reader adds it, so its pixels
    equal the numpy decoder's (Radiance's convention) bit for bit, RLE and flat, zeros and tiny values."""
    import OpenImageIO as oiio

    rng = np.random.default_rng(9)
    img = (rng.random((64, 128, 3)) * 10.0 ** rng.integers(-20, 6, (64, 128, 1))).astype(np.float32)
    img[:4] = 0.0
    img[10, 10] = [5e4, 1e-3, 0.0]
    path = tmp_path / "rle.hdr"
    out = oiio.ImageOutput.create(str(path))
    out.open(str(path), oiio.ImageSpec(128, 64, 3, "float"))
    out.write_image(img)
    out.close()
    np.testing.assert_array_equal(read_image(path), hdr_codec.decode(path.read_bytes()))
    flat = write_image(tmp_path / "flat.hdr", img)
    np.testing.assert_array_equal(read_image(flat), hdr_codec.decode(flat.read_bytes()))


def test_a_luminance_chroma_exr_without_the_openexr_package_is_refused_not_misread(tmp_path, monkeypatch):
    """Blender has OpenImageIO but not the OpenEXR package: such a file is refused at Load, with the remedy."""
    import OpenEXR

    from panolight_core.io import images, read_exr

    y = np.full((8, 16), 0.5, np.float32)
    with OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                      {"Y": y, "RY": np.zeros_like(y), "BY": np.zeros_like(y)}) as f:
        f.write(str(tmp_path / "yc.exr"))
    np.testing.assert_allclose(read_image(tmp_path / "yc.exr"), 0.5, rtol=1e-6)  # the CLI has OpenEXR
    monkeypatch.setattr(read_exr, "available", lambda: False)
    monkeypatch.setattr(read_exr, "luminance_chroma", lambda path: False)
    for read in (images.preflight, read_image):
        with pytest.raises(ImageError, match="yc.exr: a luminance/chroma .* needs the OpenEXR package"):
            read(tmp_path / "yc.exr")


def _write_oiio(path, pixels, names):
    import OpenImageIO as oiio

    h, w, c = pixels.shape
    spec = oiio.ImageSpec(w, h, c, "float" if pixels.dtype == np.float32 else "uint8")
    spec.channelnames = tuple(names)
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), spec) and out.write_image(pixels) and out.close()


def test_a_two_channel_exr_that_is_not_grey_and_alpha_is_refused(tmp_path):
    """An (R, G) EXR was read as grey from R alone, exit 0, no warning."""
    rg = np.random.default_rng(0).random((16, 32, 2)).astype(np.float32)
    _write_oiio(tmp_path / "rg.exr", rg, ("R", "G"))
    with pytest.raises(ImageError, match=r"rg.exr: .*channels .*'G', 'R'"):
        read_image(tmp_path / "rg.exr")
    _write_oiio(tmp_path / "ya.exr", rg, ("Y", "A"))  # grey + alpha is grey
    with pytest.warns(PanoLightWarning, match="alpha channel was ignored"):
        img = read_image(tmp_path / "ya.exr")
    np.testing.assert_array_equal(img, np.repeat(rg[..., :1], 3, axis=2))


@pytest.mark.parametrize("alpha", ["zero", "ramp"])
def test_png_alpha_is_not_a_lighting_weight(tmp_path, alpha):
    """A PNG's pixels were multiplied by alpha: alpha 0 gave black lighting, a ramp a third of the light."""
    from PIL import Image

    rgba = np.zeros((16, 32, 4), np.uint8)
    rgba[..., :3] = np.random.default_rng(1).integers(0, 256, (16, 32, 3))
    rgba[..., 3] = 0 if alpha == "zero" else np.linspace(0, 255, 32).astype(np.uint8)[None, :]
    Image.fromarray(rgba, "RGBA").save(tmp_path / "a.png")
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        img = read_image(tmp_path / "a.png", ldr_as_uint8=True)
        lin = read_image(tmp_path / "a.png")
    np.testing.assert_array_equal(img, rgba[..., :3])
    np.testing.assert_allclose(lin, SRGB8_TO_LINEAR[rgba[..., :3]], rtol=1e-6)
    msgs = [str(w.message) for w in said if issubclass(w.category, PanoLightWarning)]
    assert msgs == [f"{tmp_path / 'a.png'}: its alpha channel was ignored: a panorama's alpha is not a lighting "
                    f"weight, so its colours are used as they are"] * 2


def test_large_hdr_files_are_kept_packed_with_their_exact_values(tmp_path, pano, monkeypatch):
    """Above ``packed_above`` megapixels a Radiance file is held as RGBE bytes (4 per pixel), a half EXR
    as half floats (6), each read back as the float32 array would be; an EXR whose values no code holds is
    left in its file and read again by rows at each pass (issue 43: a 16K .hdr of black pixels peaked at 1.95
    GB as float32, and a float32 EXR's pixels alone are 1.6 GB)."""
    from panolight_core.io import read_oiio
    from panolight_core.packed import PackedImage

    monkeypatch.setattr(read_oiio, "BLOCK_ROWS", 24)  # several row blocks, the last one short
    big = np.repeat(np.repeat(pano, 8, axis=0), 8, axis=1)  # 128 x 256
    cases = {"hdr": (write_image(tmp_path / "a.hdr", big), "rgbe", 4),
             "half": (write_image(tmp_path / "a.exr", big, half=True), "half", 6),
             "float": (write_image(tmp_path / "b.exr", big), "file", 0)}
    for path, kind, per_pixel in cases.values():
        plain = read_image(path)
        packed = read_image(path, packed_above=0.0)
        assert read_image(path, packed_above=1.0).__class__ is np.ndarray  # 32 K pixels: not above 1 MP
        assert isinstance(packed, PackedImage) and packed.kind == kind
        assert packed.nbytes == big.shape[0] * big.shape[1] * per_pixel
        np.testing.assert_array_equal(np.asarray(packed).view(np.int32), plain.view(np.int32))


@pytest.mark.parametrize("half", [True, False])
def test_a_packed_exr_is_checked_and_repaired_like_the_float_array(tmp_path, pano, half):
    """Half floats are repaired in place; a float32 EXR left in its file is scanned once, and every later read
    applies the same repairs (NaN and -Inf to 0, +Inf to the largest finite value, negatives to 0)."""
    bad = pano.astype(np.float16).astype(np.float32) if half else pano + np.float32(1e-4)
    bad[0, 0, 0], bad[1, 1], bad[2, 2, 1], bad[4, 4, 2] = np.nan, np.inf, -np.inf, -0.5
    p = write_image(tmp_path / "bad.exr", bad, half=half)
    with pytest.raises(ImageError, match="3 pixel.*NaN or Inf"):
        read_image(p, packed_above=0.0)
    with pytest.warns(PanoLightWarning) as caught:
        fixed = read_image(p, nonfinite="repair", packed_above=0.0)
    said = " ".join(str(w.message) for w in caught)
    assert "replaced NaN/Inf in 3 pixel" in said and "clamped negative radiance to 0 in 1 pixel" in said
    with pytest.warns(PanoLightWarning):
        plain = read_image(p, nonfinite="repair")
    assert fixed.kind == ("half" if half else "file")
    np.testing.assert_array_equal(np.asarray(fixed), plain)
    assert fixed[1:2].max() == bad[np.isfinite(bad)].max() == fixed.peak() and fixed[4:5].min() == 0.0
    rows, cols = np.array([0, 1, 4, 9]), np.array([0, 1, 4, 3])
    np.testing.assert_array_equal(fixed[rows, cols], plain[rows, cols])


def test_a_file_read_again_at_each_pass_is_refused_once_changed(tmp_path, pano):
    """A float32 EXR left in its file (packed_above): rewritten between two passes, it is refused in one line
    naming it, never read as another picture."""
    import os

    p = write_image(tmp_path / "big.exr", pano + np.float32(1e-4))
    img = read_image(p, packed_above=0.0)
    assert img.kind == "file" and np.isfinite(img[0:4]).all()
    write_image(p, pano * 2 + np.float32(1e-4))
    os.utime(p, ns=(1, 1))  # and a different time, whatever the clock's resolution
    with pytest.raises(ImageError, match="big.exr: was changed or removed while it was being estimated"):
        img[0:4]
    # rewritten in place with its size and mtime put back (trust round 4: read as the new picture): the ctime moved
    img = read_image(p, packed_above=0.0)
    before, data = os.stat(p), p.read_bytes()
    with open(p, "r+b") as f:
        f.write(data)
    os.utime(p, ns=(before.st_atime_ns, before.st_mtime_ns))
    assert (os.stat(p).st_size, os.stat(p).st_mtime_ns) == (before.st_size, before.st_mtime_ns)
    with pytest.raises(ImageError, match="big.exr: was changed or removed while it was being estimated"):
        img[0:4]


def _dual_fisheye(equirect: np.ndarray, h: int, fov_deg: float = 190.0) -> np.ndarray:
    """(h, 2h, 3) float32: the two equidistant fisheye circles a 360 camera records of ``equirect``, front (+X) on the
    left, back (-X) on the right, black outside the circles (nearest-pixel lookups, CONVENTIONS.md's frame)."""
    eh, ew = equirect.shape[:2]
    out = np.zeros((h, 2 * h, 3), np.float32)
    y, x = np.mgrid[0:h, 0:h] + 0.5
    u, v = (x - h / 2) / (h / 2), (h / 2 - y) / (h / 2)
    r = np.hypot(u, v)
    theta = r * np.radians(fov_deg) / 2  # the angle from the lens axis
    for half, axis in ((0, 1.0), (1, -1.0)):
        side = np.sin(theta) / np.maximum(r, 1e-9)
        d = np.stack([axis * np.cos(theta), -axis * side * u, side * v], axis=-1)
        phi, polar = np.arctan2(d[..., 1], d[..., 0]), np.arccos(np.clip(d[..., 2], -1, 1))
        col = np.clip(((1 - phi / np.pi) * ew / 2).astype(int), 0, ew - 1)
        row = np.clip((polar / np.pi * eh).astype(int), 0, eh - 1)
        out[:, half * h:(half + 1) * h] = np.where((r <= 1.0)[..., None], equirect[row, col], 0.0)
    return out


def test_an_unstitched_dual_fisheye_capture_is_refused(tmp_path):
    """Two image circles on black (a Theta's or an Insta360's unstitched frame, 2:1 like a panorama) would be taken
    for a panorama and lit wrong: refused in one line, as a JPEG or as an EXR; the panorama it was made from, and a
    night panorama whose sky and ground are black, are read."""
    from panolight_core.camera import hdr_to_ldr
    from panolight_core.data import load_studio_hdri

    city = load_studio_hdri("city")
    fish = _dual_fisheye(city, 256)
    write_image(tmp_path / "fish.exr", fish)
    write_srgb8(tmp_path / "fish.jpg", hdr_to_ldr(fish, 0.0, 90))
    from panolight_core.io.dng import write_dng

    write_dng(tmp_path / "fish.dng", fish, scale=0.25)
    for name in ("fish.exr", "fish.jpg", "fish.dng"):
        with pytest.raises(ImageError, match=rf"{name}: two image circles on black: an unstitched dual-fisheye"):
            read_image(tmp_path / name)
    with pytest.raises(ImageError, match=r"fish\.dng: two image circles"):  # the job's own RAW read
        read_raw(tmp_path / "fish.dng")
    assert read_image(tmp_path / "fish.jpg", equirect=False).shape == (256, 512, 3)  # asked for as it is
    night = np.zeros((256, 512, 3), np.float32)
    night[120:136] = 0.5  # a lit horizon under a black sky, over black ground
    night[100, ::37] = 20.0  # street lamps
    write_image(tmp_path / "night.exr", night)
    assert read_image(tmp_path / "night.exr").shape == night.shape
    write_image(tmp_path / "city.exr", city)
    assert read_image(tmp_path / "city.exr").shape == city.shape


def test_a_stitcher_s_tiff_is_read_as_its_png_would_be_and_a_float_one_as_linear_light(tmp_path, pano):
    """Hugin writes TIFF panoramas by default, and they were refused ("a plain TIFF?"). An 8- or 16-bit TIFF reads as
    the same picture's PNG (sRGB codes; 16 bits rounded to 8 where codes are asked for), a float TIFF as linear light,
    bit for bit; a TIFF under a camera RAW's name is still a RAW."""
    import tifffile

    from panolight_core.io import is_hdr
    from panolight_core.io.checks import RAW_FORMAT, TIFF_FORMAT

    codes = read_image(write_image(tmp_path / "p.png", np.clip(pano, 0, 1)), ldr_as_uint8=True)
    tifffile.imwrite(tmp_path / "p8.tif", codes, photometric="rgb")
    tifffile.imwrite(tmp_path / "p16.tiff", codes.astype(np.uint16) * 257, photometric="rgb", byteorder=">")
    tifffile.imwrite(tmp_path / "pf.tif", pano.astype(np.float32), photometric="rgb")
    for name in ("p8.tif", "p16.tiff"):
        assert sniff_format(tmp_path / name) == TIFF_FORMAT and not is_hdr(tmp_path / name)
        assert np.array_equal(read_image(tmp_path / name, ldr_as_uint8=True), codes)
        np.testing.assert_allclose(read_image(tmp_path / name), SRGB8_TO_LINEAR[codes], rtol=1e-6)
    assert is_hdr(tmp_path / "pf.tif") and np.array_equal(read_image(tmp_path / "pf.tif"), pano.astype(np.float32))
    (tmp_path / "p8.dng").write_bytes((tmp_path / "p8.tif").read_bytes())
    assert sniff_format(tmp_path / "p8.dng") == RAW_FORMAT


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=200), st.sampled_from([b"II*\x00", b"MM\x00*"]))
def test_a_tiff_header_of_any_bytes_is_float_or_not_never_an_error(tmp_path_factory, body, magic):
    """The float test reads a TIFF's first directory by hand (Blender sets the colour space before decoding): any
    bytes after the magic give True or False, never an exception."""
    from panolight_core.io.checks import tiff_is_float

    path = tmp_path_factory.mktemp("tiff") / "x.tif"
    path.write_bytes(magic + body)
    assert tiff_is_float(path) in (True, False)
