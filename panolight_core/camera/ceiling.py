"""An HDR file's ceiling: the value at which its merge (or its sensor) clipped a source too bright for every
exposure, as most hand-merged and downloaded HDRIs shot without an ND filter clip their sun.

A clipped source is a plateau: pixels whose channels sit, to the last bits, at the file's largest value in that
channel. Real radiance has no such ties at its peak: of the 111 real HDRs in ../shared/data/hdri only the two
whose sun or lamp core overflowed half floats, and one studio's ceiling lamps, show three pixels with two or more
channels at their maxima, while a truth clipped at 2, 4 or 6 stops over its JPEG's white shows dozens to thousands
(docs/studies/captures.md). A
real un-clipped sun is a peaked disk: it has one brightest pixel, and is never taken for a plateau.

``find_ceiling`` reads the image by row blocks (a ``packed.PackedImage`` too) and returns a ``Ceiling`` or None.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .. import threads
from ..sh.grid import directions_at, row_solid_angles
from .color import LUMINANCE_WEIGHTS

CEILING_TOL = 2e-4  # a channel at (1 - this) of its largest value or above sits at the ceiling: float32 and half
# ties are exact; RGBE's 8-bit mantissas differ by at least 1/256 near the top
MIN_PLATEAU_CHANNELS = 2  # a plateau pixel has at least this many channels at their ceilings (a warm sun clips
# red and green before blue; one channel alone ties in real studios' coloured lamps)
MIN_PLATEAU_PIXELS = 3  # ... and a plateau at least this many such pixels (a clipped sun at 1024 x 512 is 1-3
# pixels at +6 stops; 2 tie by chance in 6 real un-clipped HDRs)
MIN_HEADROOM = 8.0  # the ceiling's luminance at least this times the median's: a flat or all-clipped image has
# no source to restore (a JPEG's white is 5.6x its metered median)
BLOCK_ROWS = 256
IMPLAUSIBLE = 1e12  # above any real radiance, even a sun in absolute units (about 1.6e9 cd/m^2): a plateau this
# high is an overflow or a sentinel, never a clipped source, and weighing it would leave float32's range


@dataclass(frozen=True)
class Ceiling:
    """The clip of an HDR image: rgb (3,) the per-channel ceilings (the file's units), the plateau's pixel count
    and solid angle (sr), its headroom (the ceiling's luminance over the image's median luminance), and rows: the
    rows holding a channel at its ceiling (what the later passes read: no other row has a clipped pixel)."""

    rgb: tuple
    pixels: int
    solid_angle: float
    headroom: float
    rows: tuple = ()
    declared: str = ""  # why an artist's pointer declared this ceiling (``pointed_ceiling``); "" for one found

    @property
    def level(self) -> float:
        """The clip unit: the largest channel ceiling (every pixel over it is at most 1 in every channel)."""
        return max(self.rgb)

    def at_ceiling(self, block: np.ndarray) -> np.ndarray:
        """(n, W) uint8: how many channels of each pixel of a float (n, W, 3) block sit at their ceilings."""
        top = np.asarray(self.rgb, dtype=np.float32) * np.float32(1.0 - CEILING_TOL)
        count = np.zeros(block.shape[:2], np.uint8)
        for c in range(3):
            if self.rgb[c] > 0:  # a black channel has no ceiling to sit at
                count += block[..., c] >= top[c]
        return count

    def plateau(self, block: np.ndarray) -> np.ndarray:
        """(n, W) bool: the block's plateau pixels (MIN_PLATEAU_CHANNELS or more channels at their ceilings)."""
        return self.at_ceiling(block) >= MIN_PLATEAU_CHANNELS

    def row_counts(self, pixels, r0: int, r1: int) -> np.ndarray:
        """(r1 - r0, W) uint8: ``at_ceiling`` of rows r0..r1 of ``pixels``, reading only the rows in ``rows``."""
        out = np.zeros((r1 - r0, pixels.shape[1]), np.uint8)
        rows = np.asarray(self.rows, dtype=np.int64)
        rows = rows[(rows >= r0) & (rows < r1)]
        for a, b in row_runs(rows):
            out[a - r0:b - r0] = self.at_ceiling(np.asarray(pixels[a:b], dtype=np.float32))
        return out

    @property
    def implausible(self) -> bool:
        """Whether the ceiling lies above IMPLAUSIBLE: no camera clipped there, and nothing may be restored."""
        return not self.level <= IMPLAUSIBLE

    def describe(self) -> dict:
        """For lighting.json: the ceiling per channel, the plateau's pixels and solid angle, the headroom."""
        return {"ceiling": [float(v) for v in self.rgb], "plateau_pixels": int(self.pixels),
                "plateau_sr": round(float(self.solid_angle), 8), "headroom": round(float(self.headroom), 3),
                **({"declared": self.declared} if self.declared else {})}


def row_runs(rows: np.ndarray):
    """(first, last + 1) of each run of consecutive row indices in sorted ``rows``."""
    if not rows.size:
        return []
    breaks = np.flatnonzero(np.diff(rows) > 1)
    starts = np.concatenate([[rows[0]], rows[breaks + 1]])
    ends = np.concatenate([rows[breaks], [rows[-1]]]) + 1
    return list(zip(starts.tolist(), ends.tolist()))


def row_channel_max(block: np.ndarray) -> np.ndarray:
    """(n, 3): each row's largest value per channel of an (n, W, 3) block, by halving the row (numpy reduces a
    middle axis of length W 12x slower)."""
    m = block
    while m.shape[1] > 1:
        k = m.shape[1] // 2
        head = np.maximum(m[:, :k], m[:, k:2 * k])
        if m.shape[1] % 2:
            head[:, :1] = np.maximum(head[:, :1], m[:, 2 * k:])
        m = head
    return m[:, 0]


def _blocks(height: int):
    return [(r, min(height, r + BLOCK_ROWS)) for r in range(0, height, BLOCK_ROWS)]


def find_ceiling(pixels, scan=None) -> Ceiling | None:
    """The ``Ceiling`` of float linear HDR ``pixels`` (H, W, 3) (an ndarray or a ``packed.PackedImage``), or None
    when it clips nothing: fewer than MIN_PLATEAU_PIXELS plateau pixels, or a ceiling under MIN_HEADROOM times the
    median luminance (over the pixels of every 8th row and column: a gate, not a measurement). One pass over every
    row (each row's largest value per channel, on every thread), then one over the rows that reach a ceiling.
    scan: ``scan_rows(pixels)`` when made already."""
    row_max, median = scan_rows(pixels) if scan is None else scan
    top = row_max.max(axis=0).astype(np.float64)
    if not np.all(np.isfinite(top)) or (top > 0).sum() < MIN_PLATEAU_CHANNELS:
        return None
    return _ceiling_at(pixels, row_max, top, median)


def scan_rows(pixels) -> tuple[np.ndarray, float]:
    """(each row's largest value per channel (H, 3), the median luminance of every 8th row and column)."""
    def scan(rows):
        block = np.asarray(pixels[rows[0]:rows[1]], dtype=np.float32)
        return row_channel_max(block), block[::8, ::8].reshape(-1, 3)  # BLOCK_ROWS is a multiple of 8

    parts = threads.map_ordered(scan, _blocks(pixels.shape[0]))
    return (np.concatenate([m for m, _ in parts]),
            float(np.median(np.concatenate([sample for _, sample in parts]) @ LUMINANCE_WEIGHTS)))


def _ceiling_at(pixels, row_max: np.ndarray, top: np.ndarray, median: float, declared: str = "") -> Ceiling | None:
    """The Ceiling of ``pixels`` clipped at the per-channel ``top`` (3,), given their row maxima (H, 3) and median
    luminance: its plateau counted over the rows that reach it; None under MIN_PLATEAU_PIXELS or MIN_HEADROOM."""
    h, w = pixels.shape[:2]
    reach = (row_max >= (top * (1.0 - CEILING_TOL)).astype(np.float32)) & (top > 0)  # (H, 3)
    ceiling = Ceiling(tuple(float(v) for v in top), 0, 0.0, 0.0,
                      tuple(np.flatnonzero(reach.any(axis=1)).tolist()), declared)
    omega = row_solid_angles(h, w)
    count, sr = 0, 0.0
    for a, b in row_runs(np.flatnonzero(reach.sum(axis=1) >= MIN_PLATEAU_CHANNELS)):
        per_row = ceiling.plateau(np.asarray(pixels[a:b], dtype=np.float32)).sum(axis=1)
        count += int(per_row.sum())
        sr += float(per_row @ omega[a:b])
    if count < MIN_PLATEAU_PIXELS:
        return None
    headroom = float(top @ LUMINANCE_WEIGHTS) / median if median > 0 else math.inf
    if headroom < MIN_HEADROOM:
        return None
    return replace(ceiling, pixels=count, solid_angle=sr, headroom=headroom)


POINTED_REACH_DEG = 10.0  # an artist's pointer finds the bright patch whose peak lies within this of it
POINTED_LEVEL = 0.5  # ... and declares the file clipped at this share of the patch's peak (its half-maximum)
POINTED_MAX_OVER = 1000.0  # ... unless the patch peaks above this times the median: a source the file holds whole.
# A merge without an ND filter clips at its darkest frame's white, 20-400x the median for 3-7 brackets (the shared
# files that clip their sun: 42-116x); an un-clipped sun is thousands of times it (the shared ones: 3,870-10^6x)


def pointed_ceiling(pixels, direction, scan=None) -> tuple[Ceiling | None, str]:
    """The Ceiling an artist's pointer declares where ``find_ceiling`` finds none: a downloaded HDRI resampled
    after its merge has no exact ties left on its clipped sun, only a soft bump at 10-40x the median (four of the
    six in ../shared/data/hdri that clip their sun). The brightest pixel within POINTED_REACH_DEG of unit
    ``direction`` (CONVENTIONS.md frame) is the patch's peak; the file is declared clipped at POINTED_LEVEL of it,
    channel by channel, so the plateau is the bump's top (and any pixel of the file as bright). A peak under
    2 x MIN_HEADROOM or over POINTED_MAX_OVER times the median declares nothing (no source there, or an un-clipped
    one the file holds whole). scan: ``scan_rows(pixels)`` when made already (``find_ceiling``'s). Returns (the
    Ceiling, or None, and one sentence on what was declared or why nothing was)."""
    d = np.asarray(direction, dtype=np.float64)
    d = d / np.linalg.norm(d)
    h, w = pixels.shape[:2]
    reach = math.radians(POINTED_REACH_DEG)
    polar = math.acos(float(np.clip(d[2], -1.0, 1.0)))
    r0, r1 = max(0, int((polar - reach) / math.pi * h) - 1), min(h, int((polar + reach) / math.pi * h) + 2)
    best = (-math.inf, None)  # the patch's peak: (luminance, RGB)
    cols = np.arange(w)
    for a in range(r0, r1, 64):  # the rows the cone crosses, a few at a time (a 16K file's band is 900 rows)
        b = min(r1, a + 64)
        block = np.asarray(pixels[a:b], dtype=np.float32)
        rows = np.repeat(np.arange(a, b), w)
        near = (directions_at(rows, np.tile(cols, b - a), h, w) @ d >= math.cos(reach)).reshape(b - a, w)
        lum = np.where(near, block @ LUMINANCE_WEIGHTS.astype(np.float32), -np.inf)
        y, x = np.unravel_index(int(np.argmax(lum)), lum.shape)
        if lum[y, x] > best[0]:
            best = (float(lum[y, x]), block[y, x].astype(np.float64))
    row_max, median = scan_rows(pixels) if scan is None else scan
    over = best[0] / median if median > 0 else math.inf
    if not POINTED_LEVEL * best[0] >= MIN_HEADROOM * median:
        return None, (f"there is no bright patch within {POINTED_REACH_DEG:g} deg of it (its brightest pixel is "
                      f"{max(over, 0.0):.1f}x the median; a clipped sun's is {MIN_HEADROOM / POINTED_LEVEL:g}x or "
                      f"more): the file holds no clipped sun there")
    if over > POINTED_MAX_OVER:
        return None, (f"the bright patch it points at peaks at {over:.3g}x the median: a source the file holds whole "
                      f"(a merge that clips its sun clips it under {POINTED_MAX_OVER:g}x), its light already in its "
                      f"pixels")
    why = (f"the artist's sun points at a bright patch ({over:.0f}x the median) with no exact plateau (a file "
           f"resampled after its merge): the file is taken as clipped at {POINTED_LEVEL:g} of its peak")
    ceiling = _ceiling_at(pixels, row_max, POINTED_LEVEL * best[1], median, why)
    if ceiling is None:
        return None, (f"the bright patch it points at ({over:.0f}x the median) has fewer than {MIN_PLATEAU_PIXELS} "
                      f"pixels at half its peak: a peaked source, which the file holds whole")
    return ceiling, why
