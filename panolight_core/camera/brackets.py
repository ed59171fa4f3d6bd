"""Merging a bracket set: several 8-bit exposures of one scene (or camera RAWs) -> one linear HDR panorama (numpy
only: Blender runs it too).

Each frame is decoded through the set's own camera curve where it explains the frames better than sRGB
(``camera.response``: Debevec and Malik's, recovered from three or more 8-bit frames), else through sRGB
(EVALUATION.md's camera), and divided by its relative exposure. The frames' logarithms are averaged (Debevec and
Malik's ln E = sum w (g(Z) - ln t) / sum w: a short frame's noisy dark code, hundreds of times the others' reading,
moves a log average by its small weight's share, where a linear average made it a firefly), each weighed by the
noise weight (``camera.weights``) of the pixel's **worst** channel, so a pixel clipped in one channel of a frame
takes nothing from that frame (a clipped channel averaged in makes a dark sun or a magenta halo). A pixel clipped in
every frame is clipped: it takes the darkest frame's channels, those it clipped at that frame's white (a lower
bound), which makes the merged file an HDR that clips its own sun at exactly its ceiling (``camera.ceiling``),
channel by channel as a file clipped there does, and the restoration weighs it as for any such file. (Every channel at the white made a sunset's red-clipped
aureole part of a white plateau wider than the sun's, and drew the key light off the sun.)

What moves between the frames (a person, a leaf, a wave) is the reference frame's alone: a frame gives nothing to a
pixel whose radiance it sees GHOST_RATIO off the reference's where both see it well exposed. Nor to one where it sees
it well exposed GHOST_RATIO off the weighted median of the frames that do (``weights.outlying_frames``): a speck of
dust or a hot pixel on one frame, where the reference is too dark to judge (a speck on the darkest of five frames
came out at 63x the wall round it, now 1.0x).

Hand-held frames are aligned first (``align_shift``: Ward's median threshold bitmaps, the panorama's columns
turned round and its rows shifted: a 360 camera turned or tipped a little between frames; a tilt that bends the
horizon is not undone).

Units: the reference frame's white is 1 (the frame whose exposure is the set's median: the ev-0 JPEG of a
{-2, 0, +2} set), so the merged panorama is in the same units as that JPEG's estimate; the ceiling is the
reference's exposure over the darkest frame's (4 for {-2, 0, +2}), times the curve's code 255 (1 for sRGB; a
recovered curve puts its code 250 where sRGB does, ``camera.response``).
"""
from __future__ import annotations

import math
import warnings

import numpy as np

from .. import threads
from ..errors import PanoLightError, PanoLightWarning
from .agreement import block_agreement, block_codes, consistent_frames
from .blend import Blend
from .color import SRGB8_TO_LINEAR, gray8
from .response import SRGB, recover_response

MIN_EXPOSURE_STEP = 2.0 ** (1.0 / 8.0)  # two frames whose exposures differ less than an eighth of a stop are one
# exposure: a camera's nominal third-stop steps are 1.25-1.28x (1/250 to 1/200 s: a third of a stop at 1.26 had
# refused them), a phone's exposure-compensation series steps a quarter or a sixth, and EXIF rounds one exposure
# by under 3 %
BLOCK_ROWS = 64  # rows per block of the merge's per-pixel passes (a multiple of blend.RING_BLOCK): a 2K panorama's
# block temporaries (1.5 MB) stay in cache and in the allocator's heap; 256-row blocks (6 MB each, fresh pages from the
# system) took 3.98-4.75x one JPEG's time for a 3-frame set against 3.03-3.54x (bench_captures, session 55)


def exposure(time_s: float, f_number: float, iso: float) -> float:
    """A frame's relative exposure: ExposureTime x ISO / FNumber^2 (cameras change the ISO inside a bracket, so
    the time alone is not the exposure). PanoLightError for a value that is not a positive finite number."""
    for name, value in (("ExposureTime", time_s), ("FNumber", f_number), ("ISO", iso)):
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise PanoLightError(f"{name} {value!r} is not a positive number")
    return float(time_s) * float(iso) / float(f_number) ** 2


def one_exposure(a: float, b: float) -> bool:
    """Whether two relative exposures are one (within MIN_EXPOSURE_STEP of each other)."""
    return max(a, b) / min(a, b) < MIN_EXPOSURE_STEP


def told_apart(exposures) -> bool:
    """Whether no two of the positive ``exposures`` are one (``one_exposure``)."""
    s = np.sort(np.asarray(exposures, dtype=np.float64))
    return bool(np.all(s[1:] / s[:-1] >= MIN_EXPOSURE_STEP))


def check_exposures(exposures) -> np.ndarray:
    """(n,) float64 relative exposures, each pair at least MIN_EXPOSURE_STEP apart; else PanoLightError."""
    e = np.asarray(exposures, dtype=np.float64)
    if e.ndim != 1 or e.size < 2 or not np.all(np.isfinite(e)) or np.any(e <= 0):
        raise PanoLightError(f"a bracket set needs two or more positive exposures, got {list(exposures)}")
    if not told_apart(e):
        raise PanoLightError("two frames of the set have exposures less than an eighth of a stop apart "
                             f"(relative exposures {', '.join(f'{v:.4g}' for v in e)}): a bracket set's exposures "
                             f"must differ (give them with --evs if the files' EXIF is wrong: a phone compensating "
                             f"beyond its shutter and ISO records one exposure for frames its exposure bias set "
                             f"apart)")
    return e


ALIGN_LEVELS = 6  # the alignment's pyramid: shifts up to 2^6 - 1 = 63 pixels each way at its finest level ...
ALIGN_MAX_WIDTH = 1024  # ... which is at most this wide: a larger set is aligned to within a pixel of this grid (0.35
# degrees: nothing the lighting shows), and its shift scaled up
MTB_EXCLUDE = 4  # a pixel within this many codes of its frame's median is left out of the bitmaps' comparison
ALIGN_CODES = (20, 235)  # the bitmaps' threshold stays inside these codes in both frames: a frame mostly clipped
# has its median on the clip, and Ward's median bitmap of it is noise (a still set's +4 frame moved 1-63 rows in
# 44 of the 105 real scenes that way)
ALIGN_MIN_GAIN = 0.8  # ... and a shift is taken only where it leaves at most this share of the unmoved mismatch
ALIGN_MAX_ROWS = 8  # a frame tipped at most this many rows of the alignment's grid (2.8 degrees at 1024 wide): a hand
# turns a 360 camera round its axis far more than it tips it, and a still set's lantern-lit studio found 47


def _halve(g: np.ndarray) -> np.ndarray:
    h, w = (g.shape[0] // 2) * 2, (g.shape[1] // 2) * 2
    g = g[:h, :w].astype(np.uint16)
    return ((g[0::2, 0::2] + g[1::2, 0::2] + g[0::2, 1::2] + g[1::2, 1::2]) >> 2).astype(np.uint8)


def _bitmaps(g: np.ndarray, threshold: int):
    """A threshold bitmap of a grey image and its exclusion mask (pixels near the threshold)."""
    return g > threshold, np.abs(g.astype(np.int16) - threshold) > MTB_EXCLUDE


def _code(value: float) -> int:
    """The 8-bit sRGB code of a linear value."""
    return int(np.clip(np.searchsorted(SRGB8_TO_LINEAR, np.float32(value)), 0, 255))


def _median_code(grey: np.ndarray) -> int:
    """``int(np.median(grey))`` of uint8 ``grey``, read from its histogram (no sort)."""
    below = np.cumsum(np.bincount(grey.ravel(), minlength=256))
    lo, hi = np.searchsorted(below, [(grey.size - 1) // 2, grey.size // 2], side="right")
    return int(lo + hi) // 2


def _thresholds(median_code: int, ratio: float) -> tuple[int, int]:
    """The codes of one radiance in the reference and in a frame ``ratio`` times as exposed (through the sRGB
    curve): the reference's median code (Ward's), moved so that the frame's code, then the reference's, stays
    inside ALIGN_CODES."""
    lo, hi = (float(SRGB8_TO_LINEAR[c]) for c in ALIGN_CODES)
    level = float(SRGB8_TO_LINEAR[median_code])
    level = min(max(level, lo / ratio), hi / ratio)
    level = min(max(level, lo), hi)
    return _code(level), _code(level * ratio)


def shift_frame(a: np.ndarray, dy: int, dx: int) -> np.ndarray:
    """``a`` moved by dy rows (the edge rows repeated: the poles do not wrap) and dx columns (round the panorama)."""
    out = np.roll(a, dx, axis=1)
    if dy > 0:
        out = np.concatenate([np.repeat(out[:1], dy, axis=0), out[:-dy]], axis=0)
    elif dy < 0:
        out = np.concatenate([out[-dy:], np.repeat(out[-1:], -dy, axis=0)], axis=0)
    return out


class AlignmentReference:
    """A set's reference frame ((H, W, 3) uint8 sRGB) as the alignment reads it, made once for all its frames: the
    grid (every ``scale``-th pixel, at most ALIGN_MAX_WIDTH wide), Ward's grey there halved up to ``levels`` times
    (finest first, none under 16 pixels) and its median code."""

    def __init__(self, reference: np.ndarray, levels: int = ALIGN_LEVELS):
        self.scale = 1
        while reference.shape[1] > self.scale * ALIGN_MAX_WIDTH:  # a large set: every scale-th pixel
            self.scale *= 2
        self.levels = levels
        self.pyramid = self.grey_pyramid(reference)
        self.median = _median_code(self.pyramid[0])

    def grey_pyramid(self, frame: np.ndarray) -> list[np.ndarray]:
        pyramid = [gray8(frame[::self.scale, ::self.scale])]
        while len(pyramid) < self.levels and min(pyramid[-1].shape) >= 16:
            pyramid.append(_halve(pyramid[-1]))
        return pyramid

    def shift_of(self, frame: np.ndarray, ratio: float = 1.0) -> tuple[int, int]:
        """``align_shift`` of ``frame`` onto this reference."""
        t_ref, t_frame = _thresholds(self.median, ratio)
        dy = dx = 0
        for level, (ref, cur) in reversed(list(enumerate(zip(self.pyramid, self.grey_pyramid(frame))))):
            dy, dx = 2 * dy, 2 * dx
            mismatch = _Mismatch(_bitmaps(ref, t_ref), _bitmaps(cur, t_frame))
            best = None  # the shift so far first: a move must do strictly better (a flat sky ties everywhere)
            limit = ALIGN_MAX_ROWS >> level  # the rows' reach on this level's grid (level 0 the finest)
            for ty, tx in [(dy, dx)] + [(dy + a, dx + b) for a in (-1, 0, 1) for b in (-1, 0, 1)
                                        if (a or b) and abs(dy + a) <= limit]:
                cost = mismatch(ty, tx)
                if best is None or cost < best[0]:
                    best = (cost, ty, tx)
            _, dy, dx = best
        if best[0] > ALIGN_MIN_GAIN * mismatch(0, 0):  # no shift explains the two frames better than none
            return 0, 0
        return self.scale * dy, (self.scale * dx) % frame.shape[1]


_POPCOUNT = np.array([bin(i).count("1") for i in range(256)], dtype=np.uint8)


class _Mismatch:
    """Ward's mismatch of a frame's threshold bitmap and exclusion mask (``cur``) moved by (ty, tx) (``shift_frame``:
    the edge rows repeated, the columns round the panorama) against the reference's (``ref``): the pixels where the
    bitmaps differ and neither is excluded. Bit-packed along the rows, each column move packed once: the same count as
    ``((rb ^ shift_frame(cb, ty, tx)) & re & shift_frame(ce, ty, tx)).sum()`` in an eighth of the bytes."""

    def __init__(self, ref, cur):
        (rb, re), (self.cb, self.ce) = ref, cur
        self.rb, self.re = np.packbits(rb, axis=1), np.packbits(re, axis=1)
        self.rows = rb.shape[0]
        self.moved = {}  # tx -> the frame's packed bitmap and mask turned tx columns

    def __call__(self, ty: int, tx: int) -> int:
        if tx not in self.moved:
            self.moved[tx] = (np.packbits(np.roll(self.cb, tx, axis=1), axis=1),
                              np.packbits(np.roll(self.ce, tx, axis=1), axis=1))
        cb, ce = self.moved[tx]
        if ty:  # row r of the moved frame is its row r - ty, the edge rows repeated
            rows = np.clip(np.arange(self.rows) - ty, 0, self.rows - 1)
            cb, ce = cb[rows], ce[rows]
        return int(np.take(_POPCOUNT, (self.rb ^ cb) & self.re & ce).sum(dtype=np.int64))


def align_shift(reference: np.ndarray, frame: np.ndarray, ratio: float = 1.0) -> tuple[int, int]:
    """(dy, dx) pixels that move ``frame`` onto ``reference`` (both (H, W, 3) uint8 sRGB, exposures of one scene):
    Ward's median threshold bitmaps compared over an image pyramid, one pixel each way per level, the columns round
    the panorama (a 360 camera turned in the hand), the rows within ALIGN_MAX_ROWS of where they were; on a grid at
    most ALIGN_MAX_WIDTH wide. (0, 0) for a frame mostly clipped white or black, and where no shift matches the
    frames better than none by ALIGN_MIN_GAIN. A set's frames share one ``AlignmentReference``."""
    return AlignmentReference(reference).shift_of(frame, ratio)


def kept_shift(reference_codes: np.ndarray, frame: np.ndarray, ratio: float, shift: tuple) -> tuple[int, int]:
    """``shift`` (an ``align_shift`` of ``frame`` onto the reference frame, whose ``block_codes`` are
    ``reference_codes``; ``frame`` exposed ``ratio`` times as much) where it measurably improves how the two agree,
    else (0, 0): moved, the frame's blocks must rank more like the reference's than unmoved (``block_agreement``'s
    correlation). A still tripod pair 4 stops apart was moved 16 rows and 10
    columns by the bitmaps, and then refused as two scenes, though unmoved it agreed (0.60)."""
    if tuple(shift) == (0, 0):
        return 0, 0
    moved = block_agreement(reference_codes, block_codes(shift_frame(frame, *shift)), ratio).rank_correlation
    still = block_agreement(reference_codes, block_codes(frame), ratio).rank_correlation
    if moved is not None and still is not None and moved <= still:
        return 0, 0
    return int(shift[0]), int(shift[1])


def _without(left_out: list[dict], frames, e: np.ndarray, names, **options) -> tuple[np.ndarray, dict]:
    """``merge_brackets`` of ``frames`` (at exposures ``e``) less those ``left_out`` (``consistent_frames``), each
    said in a warning; its record speaks of every frame given: the reference's index, each one's stops, each left out
    (``left_out``: frame index and why) and a shift of None for it."""
    out = {d["frame"] for d in left_out}
    keep = [i for i in range(len(frames)) if i not in out]
    label = [f"frame {i + 1}" for i in range(len(frames))] if names is None else [str(n) for n in names]
    for d in left_out:
        warnings.warn(PanoLightWarning(f"{label[d['frame']]}: left out of the merge, the set holding without it: "
                                       f"{d['why']}"), stacklevel=3)
    merged, info = merge_brackets([frames[i] for i in keep], e[keep], names=[label[i] for i in keep], **options)
    if "left_out" in info:  # aligned again about another reference, the rest would leave out one more: no set holds
        raise PanoLightError(left_out[0]["why"])
    ref = keep[info["reference"]]
    info.update(reference=ref, stops=[round(math.log2(float(v / e[ref])), 4) for v in e],
                left_out=[{"frame": d["frame"], "why": d["why"]} for d in left_out])
    if "shifts" in info:
        shifts = dict(zip(keep, info["shifts"]))
        info["shifts"] = [shifts.get(i) for i in range(len(frames))]
    return merged, info


_CODE_EDGES = ((SRGB8_TO_LINEAR[1:].astype(np.float64) + SRGB8_TO_LINEAR[:-1]) / 2).astype(np.float32)


def linear_codes(frame: np.ndarray) -> np.ndarray:
    """(H, W, 3) uint8: the nearest 8-bit sRGB code of each linear value of a float frame whose white is 1 (a camera
    RAW's: io.read_raw), 255 at 1 and above: what the merge's weights, ghost test and alignment read."""
    out = np.empty(frame.shape, np.uint8)
    for r in range(0, frame.shape[0], BLOCK_ROWS):
        out[r:r + BLOCK_ROWS] = np.searchsorted(_CODE_EDGES, frame[r:r + BLOCK_ROWS])
    return out


def merge_brackets(frames, exposures, align: bool = True, ghosts: bool = True, response: bool = True, names=None
                   ) -> tuple[np.ndarray, dict]:
    """Merge 8-bit sRGB frames (each (H, W, 3) uint8, one scene), or linear float32 frames whose white is 1 (camera
    RAWs, ``io.read_raw``: weighed, tested for ghosts and aligned by their nearest sRGB codes, ``linear_codes``, and
    averaged in their own linear values), taken at relative ``exposures`` into a float32
    (H, W, 3) linear HDR (units: the reference frame's white is 1) and what was done: the reference frame (index),
    each frame's exposure over the reference's (in stops), the ceiling, the share of pixels clipped in every frame
    and, with ``align``, each frame's (dy, dx) shift onto the reference (``align_shift``: a hand-held set). With
    ``ghosts`` a frame gives nothing to a pixel it sees GHOST_RATIO brighter or darker than the reference frame does
    where both see it well exposed (``sure_codes``): what moved between the frames is the reference frame's alone.
    With ``response`` 8-bit frames are decoded through their own camera curve where it explains them better than
    sRGB (``camera.response.recover_response``; the record's ``response`` says which and why), else sRGB. A frame
    that contradicts its set (its exposures' order, or another scene) is left out where the set holds without it,
    said in a warning and the record's ``left_out``; where none can be, the set is refused, named by ``names`` (file
    names; else their numbers), before anything is merged (``consistent_frames``; the record's ``agreement``)."""
    e = check_exposures(exposures)
    given = list(frames)
    shapes = {np.asarray(f).shape for f in frames}
    kinds = {np.asarray(f).dtype for f in frames}
    if len(frames) != e.size or len(shapes) != 1 or kinds not in ({np.dtype(np.uint8)}, {np.dtype(np.float32)}):
        raise PanoLightError(f"a bracket set is frames of one size, all 8-bit or all linear float32, one per exposure "
                             f"(got {len(frames)} frames of shapes {sorted(shapes)} and types "
                             f"{sorted(map(str, kinds))}, {e.size} exposures)")
    linear = [np.asarray(f) for f in frames] if kinds == {np.dtype(np.float32)} else None
    frames = [linear_codes(f) for f in linear] if linear is not None else frames
    ref = int(np.argsort(e)[(e.size - 1) // 2])
    grid = AlignmentReference(frames[ref]) if align else None
    shifts = threads.map_ordered(lambda i: grid.shift_of(frames[i], e[i] / e[ref]) if align and i != ref
                                 else (0, 0), range(len(frames)))
    if any(tuple(s) != (0, 0) for s in shifts):  # each move checked against the reference's blocks, made once
        ref_codes = block_codes(frames[ref])
        shifts = [kept_shift(ref_codes, f, e[i] / e[ref], s) for i, (f, s) in enumerate(zip(frames, shifts))]
    frames = [f if (dy, dx) == (0, 0) else shift_frame(f, dy, dx) for f, (dy, dx) in zip(frames, shifts)]
    if linear is not None:
        linear = [f if (dy, dx) == (0, 0) else shift_frame(f, dy, dx) for f, (dy, dx) in zip(linear, shifts)]
    rel = e / e[ref]
    _, agreement, left_out = consistent_frames(frames, rel, names)
    if left_out:  # merged again without them: the reference and the alignment may have been theirs
        return _without(left_out, given, e, names, align=align, ghosts=ghosts, response=response)
    curve = recover_response(frames, rel, ref) if response and linear is None else SRGB
    ceiling = float(curve.table[255] / rel.min())  # the darkest frame's white: above every value a frame holds
    blend = Blend(frames, linear, rel, ref, curve, ghosts, ceiling)
    h = frames[0].shape[0]
    out = np.empty(frames[0].shape, np.float32)
    clipped = sum(threads.map_ordered(lambda r: blend.merge_rows(out, r, min(h, r + BLOCK_ROWS)),
                                      range(0, h, BLOCK_ROWS)))
    return out, {"reference": ref, "stops": [round(math.log2(k), 4) for k in rel], "ceiling": ceiling,
                 **({"response": curve.describe()} if linear is None else {}),
                 "clipped_in_every_frame": clipped / float(out.shape[0] * out.shape[1]),
                 "agreement": [{"contradicting": round(a.contradicting, 4), "compared": a.compared,
                                "rank_correlation": (None if a.rank_correlation is None
                                                     else round(a.rank_correlation, 4)),
                                "crossing": None if a.crossing is None else round(a.crossing, 4),
                                "step_codes": None if a.step_codes is None else round(a.step_codes, 2)}
                               for a in agreement],
                 **({"shifts": [[int(dy), int(dx)] for dy, dx in shifts]} if align else {})}
