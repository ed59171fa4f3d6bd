"""Restoring an HDR file's clipped source: the plateau ``camera.ceiling`` finds is weighed by the same per-source
and key-light machinery as a photo's clipped sun, and only its pixels change.

The file is read in clip units (the ceiling's largest channel is 1), so its plateau is what a camera's white is
to the trees. Its work maps are the file's own linear pixels, area-averaged (no 8-bit quantisation, no tone
curve), and the clipped fractions count the plateau's pixels. Every pixel off the plateau keeps its value to the
bit in ``hdr.exr`` and in the radiance the lighting model is fitted to: the recovered energy is added to the
plateau's pixels only (``fill.FullResolutionFill``), in the file's units.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ... import sh
from ...camera.ceiling import MIN_PLATEAU_CHANNELS, Ceiling, row_runs
from ...camera.resample import area_downsample, block_of, block_starts
from ...packed import PackedImage, RowFile
from ..highlights import WORK_HEIGHT
from .fill import FullResolutionFill


@dataclass(frozen=True)
class Source:
    """The HDR a recovery restores: its float pixels (H, W, 3) (an ndarray or ``packed.PackedImage``), in the
    file's units, and their ``Ceiling``. The recovery's maps and energies are in clip units: times ``level``."""

    pixels: object
    ceiling: Ceiling
    _cache: dict = field(default_factory=dict, compare=False, repr=False)  # its projections and work fractions, made once

    @property
    def level(self) -> float:
        return self.ceiling.level

    def projection(self, lmax: int) -> np.ndarray:
        """(K, 3) float64: the exact SH projection of the pixels as they are (made once per order)."""
        if lmax not in self._cache:
            self._cache[lmax] = sh.project(self.pixels, lmax).astype(np.float64)
        return self._cache[lmax]

    def plateau_rows(self, r0: int, r1: int) -> np.ndarray:
        """(r1 - r0, W) bool: the plateau pixels of rows r0..r1 (the pixels the restoration fills)."""
        return self.ceiling.row_counts(self.pixels, r0, r1) >= MIN_PLATEAU_CHANNELS

    def work_maps(self, height: int = WORK_HEIGHT):
        """(rad (h, 2h, 3) float64 in clip units, frac_any, frac_all (h, 2h)) as ``highlights.work_maps`` makes
        them of a photo: the area means of the pixels over ``level``, of the pixels with a channel at its ceiling,
        and of the plateau's pixels; h = min(height, H). The fractions read only the ceiling's rows."""
        h = min(height, self.pixels.shape[0])
        rad = area_downsample(self.pixels, h) / self.level
        fractions = self._ceiling_fractions(h)
        return rad, fractions[0], fractions[1]

    def core_fraction(self, height: int = WORK_HEIGHT) -> np.ndarray:
        """(h, 2h) the share of each work cell's pixels with every channel at its ceiling (a black channel has
        none): a plateau's core. A warm sun clips red, then green, then blue, so the plateau of two channels
        reaches out over the aureole toward the redder sky, and its core is nearer the sun."""
        return self._ceiling_fractions(min(height, self.pixels.shape[0]))[2]

    def _ceiling_fractions(self, h: int) -> np.ndarray:
        """(3, h, 2h): per work cell, the share of its pixels with a channel, MIN_PLATEAU_CHANNELS and every
        channel at the ceiling; made once per height (reads only the ceiling's rows)."""
        if ("fractions", h) in self._cache:
            return self._cache["fractions", h]
        H, W = self.pixels.shape[:2]
        w = 2 * h
        cell_pixels = np.diff(block_starts(H, h))[:, None] * np.diff(block_starts(W, w))[None, :]
        counts = np.zeros((3, h, w))
        row_cell, col_cell = block_of(H, h), block_of(W, w)
        every = sum(v > 0 for v in self.ceiling.rgb)
        for r0, r1 in row_runs(np.asarray(self.ceiling.rows, dtype=np.int64)):
            k = self.ceiling.at_ceiling(np.asarray(self.pixels[r0:r1], dtype=np.float32))
            y, x = np.nonzero(k)
            cy, cx, n = row_cell[y + r0], col_cell[x], k[y, x]
            np.add.at(counts[0], (cy, cx), 1.0)
            for level, least in ((1, MIN_PLATEAU_CHANNELS), (2, every)):
                sel = n >= least
                np.add.at(counts[level], (cy[sel], cx[sel]), 1.0)
        self._cache["fractions", h] = counts / cell_pixels
        return self._cache["fractions", h]

    def filled(self, rec, keys: bool) -> PackedImage:
        """The restored panorama in the file's units, read by row blocks: the pixels, plus on the plateau the
        energy recovery ``rec`` (a ``sources.Recovery`` of ``work_maps``) put back beyond them, with its key lights
        (``keys``: what ``hdr.exr`` holds) or without (the diffuse radiance the lighting model is fitted to)."""
        excess = np.maximum((rec.diffuse - rec.base) * self.level, 0.0)
        points = [(d, e * self.level) for d, e in rec.key_points()] if keys else []
        fill = FullResolutionFill(self.plateau_rows, self.pixels.shape[:2], excess,
                                  (rec.regions.centre, rec.regions.shape_exponents(), rec.regions.labels), points)
        return PackedImage(FilledRows(self, fill), "file")


class FilledRows(RowFile):
    """The rows of a ``Source``'s pixels with a ``FullResolutionFill`` applied: a ``packed.PackedImage`` store
    (kind "file", read by slices and gathers as a ``RowFile``), made again at each access, so no full-size copy of a
    large panorama exists. Blocks are made in parallel (no file to serialise on)."""

    def __init__(self, source: Source, fill: FullResolutionFill):
        super().__init__(None, *source.pixels.shape[:2])
        self.source, self.fill = source, fill
        pixels = source.pixels
        peak = pixels.peak() if isinstance(pixels, PackedImage) else float(np.max(pixels, initial=0.0))
        self.top = peak + fill.peak()  # an upper bound, what hdr.exr's writer needs

    def _rows(self, r0: int, r1: int) -> np.ndarray:
        block = np.array(self.source.pixels[r0:r1], dtype=np.float32)
        self.fill.apply(block, r0, self.source.plateau_rows(r0, r1))
        return block


class ClippedRows(RowFile):
    """The rows of HDR ``pixels`` whose plateau is clipped at a declared ``ceiling`` (``camera.ceiling.pointed_ceiling``:
    its pixels with MIN_PLATEAU_CHANNELS or more channels at or over it, each channel at most its ceiling): what the
    file would hold had its merge clipped its source there, as the trees saw clipped files in training. Every other
    pixel is the file's. A ``packed.PackedImage`` store (kind "file"), made again at each access (no full copy)."""

    def __init__(self, pixels, ceiling: Ceiling):
        super().__init__(None, *pixels.shape[:2])
        self.pixels, self.ceiling = pixels, ceiling
        self.rgb = np.asarray(ceiling.rgb, dtype=np.float32)

    def _rows(self, r0: int, r1: int) -> np.ndarray:
        block = np.array(self.pixels[r0:r1], dtype=np.float32)
        plateau = self.ceiling.plateau(block)
        block[plateau] = np.minimum(block[plateau], self.rgb)
        return block


def declared_source(pixels, ceiling: Ceiling) -> Source:
    """The ``Source`` of an HDR whose ``ceiling`` an artist's pointer declared (``Ceiling.declared``): its plateau
    clipped there (``ClippedRows``); a found ceiling's pixels as they are."""
    return Source(PackedImage(ClippedRows(pixels, ceiling), "file") if ceiling.declared else pixels, ceiling)
