"""Resampling equirect images (area averaging in linear space)."""
from __future__ import annotations

import numpy as np

from .. import threads
from ..packed import PackedImage
from ..sh.grid import pixel_coordinates
from . import clipped_mask


def area_downsample(img: np.ndarray, height: int, width: int | None = None) -> np.ndarray:
    """Area-average an (H, W, C) image to (height, width, C) float64 (as is if H <= height).

    width defaults to 2 height (an equirect panorama). img may be a ``packed.PackedImage``.

    Integer factors add strided slices (numpy reduces short strided axes slowly); other sizes use
    block means over rounded boundaries.
    """
    h, w = img.shape[:2]
    width = 2 * height if width is None else width
    if isinstance(img, PackedImage):  # read by row blocks: the same sums in the same order
        return np.asarray(img, np.float64) if h <= height else area_downsample_rows(img, height, _as_is, width)
    if h <= height:
        return img.astype(np.float64)
    if h % height == 0 and w % width == 0:
        fy, fx = h // height, w // width
        acc_t = np.float64 if img.dtype == np.float64 else np.float32
        r = img.reshape(height, fy, w, -1)
        rows = r[:, 0].astype(acc_t)
        for i in range(1, fy):
            rows += r[:, i]
        c = rows.reshape(height, width, fx, -1)
        out = c[:, :, 0].astype(np.float64)
        for i in range(1, fx):
            out += c[:, :, i]
        return out / (fy * fx)
    return _area_blocks(img, height, width, None)


def _as_is(block: np.ndarray) -> np.ndarray:
    return block


def block_starts(n: int, blocks: int) -> np.ndarray:
    """(blocks + 1,) the first row (column) of each of ``blocks`` area-average blocks of n rows (columns), and n."""
    return np.linspace(0, n, blocks + 1).astype(int)


def _area_blocks(img: np.ndarray, height: int, width: int, transform) -> np.ndarray:
    """Block means over rounded boundaries (sizes that are not whole multiples), a few output rows at a
    time: only a slab of ``transform(img)`` (or of img) exists in float64 at once, never the whole image
    (a 16000 x 8000 JPEG peaked at 5.4 GB the whole-image way). The same sums in the same order."""
    h, w = img.shape[:2]
    ys, xs = block_starts(h, height), block_starts(w, width)
    step = max(1, (BLOCK_PIXELS // 4) // (w * max(1, -(-h // height))))  # output rows per slab (~24 MB float64)

    def slab(k0):
        k1 = min(height, k0 + step)
        block = img[ys[k0]:ys[k1]]
        block = (block if transform is None else transform(block)).astype(np.float64)
        rows = np.add.reduceat(block, ys[k0:k1] - ys[k0], axis=0) / np.diff(ys[k0:k1 + 1])[:, None, None]
        return np.add.reduceat(rows, xs[:-1], axis=1) / np.diff(xs)[None, :, None]

    return np.concatenate(threads.map_ordered(slab, range(0, height, step)), axis=0)


BLOCK_PIXELS = 1 << 22  # pixels per row block of the block-wise passes (4 M: 16K panoramas in 32 blocks)


def row_blocks(height: int, width: int, multiple: int = 1):
    """(r0, r1) row ranges covering ``height`` rows of ``width`` pixels in blocks of about BLOCK_PIXELS,
    each a multiple of ``multiple`` rows (the rows one work-map row averages) except perhaps the last."""
    step = max(multiple, (BLOCK_PIXELS // max(width, 1)) // multiple * multiple)
    return [(r, min(height, r + step)) for r in range(0, height, step)]


def area_downsample_rows(img: np.ndarray, height: int, transform, width: int | None = None) -> np.ndarray:
    """``area_downsample(transform(img), height, width)`` computed by row blocks, so ``transform`` (a
    per-pixel map, e.g. sRGB -> linear) never makes a full-resolution copy; the same numbers (each
    output row averages the same rows in the same order), whole-number factors or not."""
    h, w = img.shape[:2]
    width = 2 * height if width is None else width
    if h <= height:
        return area_downsample(transform(img), height, width)
    if h % height or w % width:
        return _area_blocks(img, height, width, transform)
    fy = h // height
    parts = threads.map_ordered(lambda rows: area_downsample(transform(img[rows[0]:rows[1]]), (rows[1] - rows[0]) // fy,
                                                              width), row_blocks(h, w, fy))
    return np.concatenate(parts, axis=0)


LUT_PASS_PIXELS = 1 << 18  # area_mean_lut's pass size (see there)


def area_mean_lut(img: np.ndarray, height: int, lut: np.ndarray) -> np.ndarray:
    """``area_downsample(lut[img], height)`` for a uint8 (H, W, C) image and a float32 (256,) table (sRGB
    -> linear), without the full-size float image: each output row's input rows are looked up and summed
    one at a time, in area_downsample's order, so the numbers are the same to the bit. Twice as fast on
    large panoramas (the float32 temporaries stay in cache)."""
    h, w = img.shape[:2]
    width = 2 * height
    if h <= height or h % height or w % width:
        return area_downsample_rows(img, height, lambda block: lut[block])
    fy, fx = h // height, w // width
    r = img.reshape(height, fy, w, -1)
    out = np.empty((height, width, r.shape[-1]))
    # output rows per pass: float32 temporaries of about 64 K pixels x fy stay in cache, and an 8K panorama
    # makes 16 passes for the threads to share (8K: 0.16 -> 0.06 s on 2 CPUs against 4 M-pixel passes)
    step = max(1, LUT_PASS_PIXELS // (4 * w))

    def rows_of(k0):
        k1 = min(height, k0 + step)
        rows = lut[r[k0:k1, 0]]
        tmp = np.empty_like(rows)
        for i in range(1, fy):
            np.take(lut, r[k0:k1, i], out=tmp)
            rows += tmp
        c = rows.reshape(k1 - k0, width, fx, -1)
        acc = c[:, :, 0].astype(np.float64)
        for i in range(1, fx):
            acc += c[:, :, i]
        out[k0:k1] = acc / (fy * fx)

    threads.map_ordered(rows_of, range(0, height, step))  # each pass writes its own rows of out
    return out


CLIP_REFERENCE_HEIGHT = 512
"""Rows at which clipping is judged: the training panoramas' (1024 x 512). In a panorama more than twice as
tall, a clipped pixel counts only inside a pixel of that grid at least REFERENCE_MIN_FRACTION clipped
(``reference_clipped``), one a camera of that resolution would have clipped had that part been 4x the clip
level or more. So a lone clipped pixel of an 8K photo (a white wall's edge, a sunlit speck of rock) makes no
region: the per-source trees never saw one, and a region's excess poured into one pixel of a 1000-pixel work
cell is a 1000x firefly in ``hdr.exr``. Up to twice as tall one pixel is a quarter: nothing changes there."""
REFERENCE_MIN_FRACTION = 0.25


def block_of(n: int, blocks: int) -> np.ndarray:
    """(n,) the block (of ``blocks`` area-average blocks, ``block_starts``) each of n rows holds."""
    return np.searchsorted(block_starts(n, blocks), np.arange(n), side="right") - 1


def _reference_height(height: int) -> int:
    """Rows of the grid clipping is judged on for a work map of ``height`` rows: CLIP_REFERENCE_HEIGHT, or the
    work map's own rows if it has more."""
    return max(height, CLIP_REFERENCE_HEIGHT)


def _judged_as_is(H: int, W: int, height: int) -> bool:
    """Whether every clipped pixel of an (H, W) panorama is REFERENCE_MIN_FRACTION or more of its pixel of a
    ``height``-row grid (up to 2x its rows at a quarter): then each counts as it is."""
    return -(-H // height) * -(-W // (2 * height)) * REFERENCE_MIN_FRACTION <= 1.0


def reference_clipped(ldr: np.ndarray, work_height: int = 0) -> np.ndarray | None:
    """(h, 2 h, 2) bool, h = ``_reference_height(work_height)``: the pixels of that grid at least
    REFERENCE_MIN_FRACTION of whose area is clipped in any / every channel (``clipped_mask``) in ``ldr`` (uint8
    (H, W, 3)), what ``clipped_fractions`` judged a work map of ``work_height`` rows by; None when each clipped
    pixel of ``ldr`` counts as it is (``_judged_as_is``: no more than twice the rows)."""
    H, W = ldr.shape[:2]
    height = _reference_height(work_height)
    if _judged_as_is(H, W, height):
        return None
    return _pixel_fractions(ldr, height) >= REFERENCE_MIN_FRACTION


def clipped_pixels(block: np.ndarray, r0: int, H: int, reference: np.ndarray | None,
                   all_channels: bool = False) -> np.ndarray:
    """(n, W) bool: the pixels of rows r0 .. r0 + n (``block`` uint8 (n, W, 3)) of an H-row panorama that
    ``clipped_mask`` marks and whose pixel of ``reference`` (``reference_clipped``; None: each pixel is its
    own) is clipped too: the pixels ``hdr.exr`` fills."""
    mask = clipped_mask(block, all_channels)
    if reference is None:
        return mask
    h, w = reference.shape[:2]
    n, W = mask.shape
    rows = reference[block_of(H, h)[r0:r0 + n], :, int(all_channels)]  # (n, w): each row's reference row
    if W % w == 0:
        return mask & np.repeat(rows, W // w, axis=1)
    return mask & rows[:, block_of(W, w)]


def clipped_fractions(ldr: np.ndarray, height: int) -> np.ndarray:
    """(height, 2 height, 2) float64: the fraction of each cell's pixels with any channel / every channel
    at 254 or more (``clipped_mask``), ``ldr`` uint8 (H, W, 3); in a panorama more than twice as tall as
    CLIP_REFERENCE_HEIGHT (and ``height``) only those inside a pixel of that grid that ``reference_clipped``
    marks (``clipped_pixels``: the pixels hdr.exr fills)."""
    H, W = ldr.shape[:2]
    ref_height = _reference_height(height)
    if _judged_as_is(H, W, ref_height):
        return _pixel_fractions(ldr, height)
    fractions = _pixel_fractions(ldr, ref_height)  # the reference pixels under a quarter clipped count for none
    return area_downsample(np.where(fractions >= REFERENCE_MIN_FRACTION, fractions, 0.0), height)


def _pixel_fractions(ldr: np.ndarray, height: int) -> np.ndarray:
    """``clipped_fractions`` of every pixel. Whole-number factors count pixels by row blocks on every thread;
    other sizes average the masks as ``area_downsample`` does (the same numbers: the counts are exact either
    way)."""
    H, W = ldr.shape[:2]
    width = 2 * height
    if H <= height or H % height or W % width:
        return area_downsample_rows(ldr, height, lambda block: np.stack(
            [clipped_mask(block), clipped_mask(block, all_channels=True)], -1).astype(np.float32))
    fy, fx = H // height, W // width

    def counts(rows):
        block = ldr[rows[0]:rows[1]]
        n = (rows[1] - rows[0]) // fy
        c0, c1, c2 = block[..., 0], block[..., 1], block[..., 2]
        out = []
        for m in (np.maximum(np.maximum(c0, c1), c2), np.minimum(np.minimum(c0, c1), c2)):
            per_row = (m >= 254).view(np.uint8).reshape(n, fy, W).sum(axis=1, dtype=np.uint32)
            out.append(per_row.reshape(n, width, fx).sum(axis=-1, dtype=np.int64))
        return np.stack(out, -1)

    return np.concatenate(threads.map_ordered(counts, row_blocks(H, W, fy))) / (fy * fx)


def sample_equirect(img: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """Bilinear lookup of an (H, W, C) equirect map (CONVENTIONS.md frame, pixel centres at +0.5) at
    (..., 3) unit directions -> (..., C) float64; columns wrap around, rows clamp at the poles."""
    h, w = img.shape[:2]
    y, x = pixel_coordinates(directions, h, w)
    y = np.clip(y, 0.0, h - 1.0)
    x0, y0 = np.floor(x).astype(np.int64), np.minimum(np.floor(y).astype(np.int64), h - 2 if h > 1 else 0)
    fx, fy = (x - x0)[..., None], (y - y0)[..., None]
    x0, x1 = x0 % w, (x0 + 1) % w
    y1 = np.minimum(y0 + 1, h - 1)
    top = img[y0, x0] * (1 - fx) + img[y0, x1] * fx
    bottom = img[y1, x0] * (1 - fx) + img[y1, x1] * fx
    return top * (1 - fy) + bottom * fy
