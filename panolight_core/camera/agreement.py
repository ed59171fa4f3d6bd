"""Whether a bracket set's frames show one still scene at the exposures they are listed at (numpy only: Blender runs it
too).

Two frames are compared over blocks both hold well exposed (``block_codes``: the brightest channel's mean over a grid
AGREE_GRID_WIDTH wide). Whatever curve the camera applied, a still scene's block is never darker in the frame exposed
more, the two rank their blocks alike, and a step between neighbouring blocks keeps its sign (``Agreement``). A pair
that breaks them cannot be merged (``_verdict``); a frame that breaks them with its set is left out where the set
holds without it (``consistent_frames``); a frame that is the same picture as another is one picture listed twice
(``same_picture``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import PanoLightError

AGREE_GRID_WIDTH = 128  # ``frame_agreement`` compares the frames' mean codes over blocks, a grid this wide (8 x 8
# pixels of a 1024-wide frame): a residual of the alignment (a pixel or two: what a hand-held set keeps) put 84-127
# of 818 still pairs against each other pixel by pixel (docs/studies/captures.md)
AGREE_CODES = (20, 200)  # ... where both frames hold the block within these codes (by its brightest channel): a
# JPEG rings 10-20 codes round a clipped patch, which put a dark studio's still +4 frame below its +2 frame on 23 %
# of the pixels compared up to 235 (1 % up to 200)
MIN_RANK_LEVELS = 16  # the rank test reads frames holding at least this many distinct block means there
ORDER_NOISE_CODES = 8  # a block contradicts the exposures' order when the frame exposed more holds it this many codes
# darker than the one exposed less (or the less exposed this much brighter): beyond JPEG's noise of a few codes


@dataclass(frozen=True)
class Agreement:
    """How two frames of a set agree with their exposures' order, over the blocks both see well exposed
    (AGREE_CODES, by the brightest channel's mean; ``compared`` of them). Whatever curve the camera applied, a still
    scene's pixel is never darker in the frame exposed more, and the two frames rank their blocks alike:
    ``contradicting`` is the share that runs against the order (frames listed in another order than their
    exposures), ``rank_correlation`` Spearman's of their block means (another scene: near 0; None where either frame
    holds fewer than MIN_RANK_LEVELS distinct means there, too few to rank: a flat wall), and ``crossing`` the share
    of neighbouring blocks whose step both frames resolve (ORDER_NOISE_CODES each) that the two take opposite ways
    (unrelated pictures: half; None where fewer than CROSSING_MIN_STEPS steps are resolved in both), and ``step_codes``
    the median move of a block from the frame exposed less to the one exposed more, in codes (None: none compared)."""

    contradicting: float
    rank_correlation: float | None
    compared: int
    crossing: float | None = None
    step_codes: float | None = None


def _ranks(values: np.ndarray) -> tuple[np.ndarray, int]:
    """(the rank of each of ``values`` among them, ties given their mean rank; how many distinct values)."""
    _, inverse, counts = np.unique(values, return_inverse=True, return_counts=True)
    return ((np.cumsum(counts) - counts) + (counts - 1) / 2.0)[inverse], counts.size


def block_codes(frame: np.ndarray) -> np.ndarray:
    """(h, w) float32: the mean of an (H, W, 3) uint8 frame's brightest channel over square blocks, a grid
    AGREE_GRID_WIDTH wide, read on every s-th pixel (4 x 4 of them a block; a small frame: its pixels)."""
    s = max(1, frame.shape[1] // (4 * AGREE_GRID_WIDTH))
    top = np.maximum(np.maximum(frame[::s, ::s, 0], frame[::s, ::s, 1]), frame[::s, ::s, 2])
    k = max(1, top.shape[1] // AGREE_GRID_WIDTH)
    h, w = top.shape[0] // k, top.shape[1] // k
    top = top[:h * k, :w * k].astype(np.uint16)  # k x k x 255 fits: the grid row is under 1024 samples, k <= 7
    cols = sum(top[:, i::k] for i in range(1, k)) + top[:, 0::k]  # strided slices: numpy sums short axes slowly
    sums = sum(cols[i::k] for i in range(1, k)) + cols[0::k]
    return sums.astype(np.float32) / np.float32(k * k)


def frame_agreement(reference: np.ndarray, frame: np.ndarray, ratio: float) -> Agreement:
    """The ``Agreement`` of ``frame`` with ``reference`` (both (H, W, 3) uint8 codes, aligned), exposed ``ratio``
    times as much, over their ``block_codes``."""
    return block_agreement(block_codes(reference), block_codes(frame), ratio)


def _crossing(a: np.ndarray, b: np.ndarray, both: np.ndarray) -> float | None:
    """``Agreement.crossing`` of two frames' (h, w) block codes ``a`` and ``b`` over the blocks ``both`` compare: the
    steps between neighbouring blocks (across and down) that both frames resolve, and the share they take opposite
    ways. Whatever curve bends each frame, a still scene's step keeps its sign; where the darker frame's toe or the
    brighter one's shoulder flattens it, the step is not resolved and says nothing (the rank test is blind to that)."""
    seen = crossed = 0
    for axis in (0, 1):
        da, db = np.diff(a, axis=axis), np.diff(b, axis=axis)
        pair = (both[:-1] & both[1:]) if axis == 0 else (both[:, :-1] & both[:, 1:])
        sure = pair & (np.abs(da) >= ORDER_NOISE_CODES) & (np.abs(db) >= ORDER_NOISE_CODES)
        seen += int(sure.sum())
        crossed += int((sure & ((da > 0) != (db > 0))).sum())
    return crossed / seen if seen >= CROSSING_MIN_STEPS else None


def block_agreement(a: np.ndarray, b: np.ndarray, ratio: float) -> Agreement:
    """``frame_agreement`` of two frames' ``block_codes`` ``a`` and ``b`` (``b`` exposed ``ratio`` times as much)."""
    lo, hi = AGREE_CODES
    both = (a >= lo) & (a <= hi) & (b >= lo) & (b <= hi)
    crossing = _crossing(a, b, both)
    a, b = a[both], b[both]
    if a.size == 0:
        return Agreement(0.0, None, 0)
    contra = float(((b < a - ORDER_NOISE_CODES) if ratio > 1.0 else (b > a + ORDER_NOISE_CODES)).mean())
    step = float(np.median(b - a if ratio > 1.0 else a - b))
    (ra, na), (rb, nb) = _ranks(a), _ranks(b)
    if min(na, nb) < MIN_RANK_LEVELS:
        return Agreement(contra, None, int(a.size), crossing, step)
    ra -= ra.mean()
    rb -= rb.mean()
    return Agreement(contra, float(ra @ rb) / float(np.sqrt((ra @ ra) * (rb @ rb))), int(a.size), crossing, step)


MIN_AGREE_BLOCKS = 150  # fewer blocks than this seen well exposed in both frames: no agreement test
BAD_SET_CONTRADICTING = 0.25  # two frames neighbours in exposure whose blocks run against its order over more than
# this share (a still pair's most: 0.07, two pixels off; a reversed one's 1.00) ...
BAD_SET_RANK = 0.4  # ... or whose blocks rank correlate less than this are refused. Measured over the real HDRs'
# sets, right and wrong, through four camera curves (training/experiments/bracket_agreement.py): a still pair's
# lowest is 0.65, 0.51 a pixel off, 0.42 two off (0.5 refused two of those 1,776), another scene's median 0.05 ...
BAD_SET_CROSSING = 0.25  # ... unless their resolved neighbouring steps (``Agreement.crossing``) keep their sign
# (a share this small crossing: halfway from a still set's 0.00-0.04 on real tripod and phone sets, 0.17 beside a
# moving fountain, to unrelated pictures' 0.5) and STILL_CONTRADICTING at most of their blocks runs against the
# exposures' order. Such a pair is one still scene whose blocks rank unlike only because the darker frame's toe and
# the brighter one's shoulder squeeze what both expose "well" into a few codes (a night set 3.3 stops apart: 0.40).
STILL_CONTRADICTING = 0.01  # a still pair, aligned, has no block darker in the frame exposed more (0.000 in 1,936
# pairs through four curves; 0.0009 in the night set); a studio relit between two frames darkens 1.8-17 % of them
CROSSING_MIN_STEPS = 40  # fewer resolved steps: no verdict from them. At 40, unrelated pictures' 0.5 lies 3.2
# standard deviations (binomial) above BAD_SET_CROSSING
FLAT_STEP_CODES = 4.0  # two neighbours whose blocks move less than this many codes per stop their exposures are apart
# (the median block) are one exposure listed as two: over 6,643 still pairs of the real HDRs, one and two stops apart
# through four curves, a stop moved 11.3 codes or more, and 8.9 in a real film set's toe; four real sets whose camera
# undid its steps (auto ISO) moved -5.4 to +1.6 codes over a listed stop


def other_scene(agree: Agreement) -> bool:
    """Whether a pair's ``Agreement`` says the two frames show two scenes (or one whose light changed between
    them): their blocks rank unlike (BAD_SET_RANK), and they are not a still pair squeezed by its curve (steps that
    keep their sign, BAD_SET_CROSSING, and no block against the order, STILL_CONTRADICTING)."""
    squeezed = (agree.crossing is not None and agree.crossing <= BAD_SET_CROSSING
                and agree.contradicting <= STILL_CONTRADICTING)
    return (agree.compared >= MIN_AGREE_BLOCKS and agree.rank_correlation is not None
            and agree.rank_correlation < BAD_SET_RANK and not squeezed)


def one_scene(agree: Agreement) -> bool:
    """Whether a pair's ``Agreement`` shows the two frames to be one scene, not merely fails to tell them apart:
    compared (MIN_AGREE_BLOCKS), ranking alike (BAD_SET_RANK: not a squeezed pair's pass; a studio relit, 4 stops apart,
    ranks at 0.30 with its steps kept), its resolved steps keeping their sign (two scenes alike in layout can rank
    alike, 0.66, while 35 % of their steps cross), and in the exposures' order (BAD_SET_CONTRADICTING)."""
    return (agree.compared >= MIN_AGREE_BLOCKS and agree.rank_correlation is not None
            and agree.rank_correlation >= BAD_SET_RANK and agree.crossing is not None
            and agree.crossing <= BAD_SET_CROSSING and agree.contradicting <= BAD_SET_CONTRADICTING)


def _verdict(agree: Agreement, darker: str, brighter: str, stops: float) -> str | None:
    """Why a pair of neighbours in exposure (``brighter`` exposed ``stops`` more than ``darker``) cannot be merged, in
    one line, or None: its blocks run against the exposures' order (BAD_SET_CONTRADICTING: listed in another order than
    their exposures), do not move with them (FLAT_STEP_CODES: one exposure listed as two), or it shows two scenes
    (``other_scene``), where at least MIN_AGREE_BLOCKS compare."""
    if agree.compared < MIN_AGREE_BLOCKS:
        return None
    pair = f"{brighter} (exposed {stops:.3g} stops more than {darker})"
    if agree.contradicting > BAD_SET_CONTRADICTING:
        return (f"{pair} is darker than {darker} over {100 * agree.contradicting:.0f} % of what both expose well: the "
                f"exposures are not the frames' (give them in the files' order with --evs, or check the EXIF)")
    if agree.step_codes is not None and agree.step_codes < FLAT_STEP_CODES * stops:
        return (f"{pair} reads the same exposure as {darker}: what both expose well moves {agree.step_codes:+.1f} "
                f"codes between them, where a stop moves 9 or more: the exposures are not the frames' (a camera's auto ISO "
                f"or exposure compensation can undo a bracket's steps: give the exposures with --evs, or check the "
                f"EXIF)")
    if not other_scene(agree):
        return None
    if agree.crossing is not None and agree.crossing <= BAD_SET_CROSSING:  # a still place, its light changed
        why = (f", and {100 * agree.contradicting:.0f} % of its patches darker in the frame exposed more): another "
               f"scene from the same place, or its light changed between the two (a studio relit, a lamp switched)")
    else:
        steps = "" if agree.crossing is None else (f", and {100 * agree.crossing:.0f} % of the steps both resolve "
                                                    f"between neighbouring patches run opposite ways")
        why = f"{steps}): a set grouped across two scenes, or a camera moved further than the alignment reaches"
    return (f"{pair} does not show the scene {darker} shows (the two rank their pixels alike with "
            f"{agree.rank_correlation:.2f} correlation, a still set's 0.9 or more{why}")


def consistent_frames(frames, rel: np.ndarray, names=None) -> tuple[list[int], list[Agreement], list[dict]]:
    """Which of the (aligned) 8-bit ``frames`` (``rel``: relative exposures) make one set: (the kept frames'
    indices in exposure order, the ``Agreement`` of each pair of kept neighbours, darker first, and the frame left
    out: [{"frame": index, "why": one line}] or []). One frame of a failing pair is left out where that alone makes
    the set hold: no pair of the rest fails (``_verdict``) nor crosses its resolved steps, and where it had a neighbour
    on each side, those two are shown to be one scene (``one_scene``): an untested gap vouches for nothing.
    PanoLightError with the set's first failing pair where no one frame does, or two would (frames listed in reverse,
    a set of two, two halves that each hold, two wrong frames)."""
    names = [f"frame {i + 1}" for i in range(len(frames))] if names is None else [str(n) for n in names]
    codes = [block_codes(f) for f in frames]
    cache = {}

    def agreement(i, j):
        if (i, j) not in cache:
            cache[i, j] = block_agreement(codes[i], codes[j], float(rel[j] / rel[i]))
        return cache[i, j]

    def failing(chain) -> dict:
        """{(i, j): why} of the chain's neighbours that cannot be merged."""
        out = {}
        for i, j in zip(chain[:-1], chain[1:]):
            why = _verdict(agreement(i, j), names[i], names[j], math.log2(float(rel[j] / rel[i])))
            if why is not None:
                out[i, j] = why
        return out

    def clean(chain) -> bool:
        """No pair fails, nor crosses its resolved steps (a frame of another scene alike in layout can pass its
        rank test with one neighbour, 0.53-0.66, while 35-39 % of their steps cross)."""
        return not failing(chain) and not any(
            agreement(i, j).compared >= MIN_AGREE_BLOCKS and (agreement(i, j).crossing or 0.0) > BAD_SET_CROSSING
            for i, j in zip(chain[:-1], chain[1:]))

    kept = [int(i) for i in np.argsort(rel, kind="stable")]
    bad = failing(kept)
    if bad:
        first = next(iter(bad.values()))
        if len(kept) <= 2:
            raise PanoLightError(first)
        fits = []
        for k in dict.fromkeys(x for pair in bad for x in pair):
            n = kept.index(k)
            rest = kept[:n] + kept[n + 1:]
            if clean(rest) and (n in (0, len(kept) - 1) or one_scene(agreement(kept[n - 1], kept[n + 1]))):
                fits.append(k)
        if len(fits) != 1:
            raise PanoLightError(first)
        (k,) = fits
        why = next(w for pair, w in bad.items() if k in pair)
        kept.remove(k)
        return kept, [agreement(i, j) for i, j in zip(kept[:-1], kept[1:])], [{"frame": k, "why": why}]
    return kept, [agreement(i, j) for i, j in zip(kept[:-1], kept[1:])], []


SAME_PICTURE_CODES = 1.0  # two frames whose blocks differ by less than this (median, in codes) are one picture: a
# stop apart, a mid-tone moves some 30 codes; a JPEG saved twice moves under one


def same_picture(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether two (aligned) 8-bit frames are one picture (their ``block_codes`` within SAME_PICTURE_CODES, median over
    at least MIN_AGREE_BLOCKS blocks both hold well exposed): what three public sets list under several exposures."""
    ca, cb = block_codes(a), block_codes(b)
    lo, hi = AGREE_CODES
    both = (ca >= lo) & (ca <= hi) & (cb >= lo) & (cb <= hi)
    return int(both.sum()) >= MIN_AGREE_BLOCKS and float(np.median(np.abs(ca[both] - cb[both]))) < SAME_PICTURE_CODES
