"""Putting a region's recovered energy back: into the work map's cells and into the full-resolution pixels.

Work maps: radiance (h, 2h, 3) linear in clip units (1 = white); full-resolution panoramas (H, W, 3) linear;
both equirectangular in the Blender world frame (CONVENTIONS.md).
"""
from __future__ import annotations

import math

import numpy as np

from ... import sh, threads
from ..highlights import CORE_RADIUS
from .regions import Regions


def fill_regions(rad: np.ndarray, regions: Regions, log_ratio: np.ndarray, keys=()) -> np.ndarray:
    """Work map with each region's excess (r - 1) x held added to its cells by ``Regions.share``, in
    the region's colour, less the energy of the region's key light (``keys``; of all the regions it stands
    for), which is not in the map.
    Returns a new (h, w, 3) map."""
    out = np.array(rad, dtype=np.float64, copy=True)
    if regions.count == 0:
        return out
    excess = (np.exp(np.asarray(log_ratio, dtype=np.float64)) - 1.0) * regions.held
    for k in keys:  # the light's energy leaves its region's fill, then its other parts' (KeyLight.parts)
        left = k.energy
        for r in (k.region, *k.parts) if k.region >= 0 else ():  # a hidden sun holds no region's energy
            take = min(excess[r], left)
            excess[r] -= take
            left -= take
    m = regions.labels >= 0
    lab = regions.labels[m]
    omega = sh.pixel_solid_angles(*regions.labels.shape)
    out[m] += (excess[lab] * regions.share[m] / omega[m])[:, None] * regions.color[lab]
    return out


def cap_log_ratios(regions, log_ratio: np.ndarray, keys) -> np.ndarray:
    """(n,) the reported log ratios of ``regions`` with each capped key light's regions (``KeyLight.cap``: a
    trusted sun) lowered, by one factor on their excess, so that together they add at most its cap: the decided
    fill of a sun's patch can otherwise hold more than the light and its fit's whole 68 % range (the trees' mean
    over a sun the sky weighs lower). The others unchanged; a new array."""
    out = np.array(log_ratio, dtype=np.float64, copy=True)
    for k in keys:
        if k.cap is None or k.region < 0:
            continue
        parts = [k.region, *k.parts]
        excess = np.expm1(out[parts]) * regions.held[parts]
        total = float(excess.sum())
        if total > k.cap:
            out[parts] = np.log1p(excess * (k.cap / total) / regions.held[parts])
    return out


def fill_with_keys(rad: np.ndarray, regions: Regions, log_ratio: np.ndarray, keys=()):
    """(diffuse, work): ``fill_regions`` (each region's fill less its key light's energy) and the same map
    with the key lights' energy deposited in their cells (``key_deposits``); both (h, w, 3)."""
    diffuse = fill_regions(rad, regions, log_ratio, keys)
    return diffuse, (diffuse + key_deposits(keys, diffuse.shape) if keys else diffuse)


def fill_full_resolution(linear: np.ndarray, clipped: np.ndarray, excess: np.ndarray,
                         centres=(), exponents=(), labels=None, points=()) -> np.ndarray:
    """Full-resolution HDR: ``linear`` (H, W, 3) plus the work map's ``excess`` (h, w, 3) put back into
    the clipped pixels (``clipped`` (H, W) bool). Returns float32 (H, W, 3). (``FullResolutionFill``
    does the same by row blocks, for panoramas with no room for a second copy.)

    Cells of a region (``labels`` (h, w) ids into ``centres`` (n, 3) and ``exponents`` (n,)): the
    region's whole excess energy (sum of excess x cell solid angle) goes into its clipped pixels with
    weight max(t, CORE_RADIUS)^-p, t the angle to its centre: a sun's disk and aureole for a steep glare,
    an even fill for a flat one (a window). Energy is exact in full-resolution solid angles; only its
    placement within the region differs from the work map. Other cells: their clipped pixels (all of
    the cell where none clipped) share the cell's excess evenly, so the cell's pixel mean gains exactly
    its excess. points: key lights (unit direction, RGB energy), each added at its exact direction.
    """
    out = np.array(linear, dtype=np.float32, copy=True)
    fill = FullResolutionFill(lambda r0, r1: clipped[r0:r1], clipped.shape, excess, (centres, exponents, labels),
                              points)
    fill.apply(out, 0, clipped)
    return out


FILL_CHUNK = 1 << 18  # clipped pixels weighed at a time (``FullResolutionFill``): ~40 MB of temporaries


class FullResolutionFill:
    """``fill_full_resolution`` split into a plan and ``apply`` to any row block of the linearised panorama, in
    place. The plan keeps a few numbers per region and per work cell, never one per clipped pixel: a 16K photo
    whose sun clipped millions of pixels costs no more than one that clipped none. ``clipped_rows(r0, r1)``
    gives the (r1 - r0, W) bool mask of the clipped pixels of rows r0..r1 of the (H, W) = ``shape`` panorama;
    the plan reads it by blocks of about FILL_CHUNK pixels, on every thread, and sums in the pixels' order (the
    same numbers as one pass over them all). ``regions``: (centres (n, 3), exponents (n,), labels (h, w) or
    None) of the per-source regions."""

    def __init__(self, clipped_rows, shape, excess: np.ndarray, regions=((), (), None), points=()):
        centres, exponents, labels = regions
        H, W = shape
        h, w = excess.shape[:2]
        self.clipped_rows = clipped_rows
        self.shape, self.work_shape = (H, W), (h, w)
        has = excess.max(axis=-1) > 0
        self.cells = []  # (r0, r1, c0, c1, excess (3,) float32) of the other cells
        self.points = self._splats(points)  # (ys, xs, add (n, 3) float32) of the key lights
        self._top = 0.0  # the largest per-pixel addition of a region's pixels
        n = len(centres)
        in_region = np.zeros((h, w), bool) if labels is None else (labels >= 0) & (labels < n)
        # what weighs a region's pixels (``_weights``), and then what each region adds per unit weight
        self._geometry = None if not (has.any() and in_region.any()) else (
            np.asarray(centres, dtype=np.float64), np.asarray(exponents, dtype=np.float64), labels)
        self._energy = self._scale = None  # (n, 3) each region's energy; (n,) 1 / its pixels' weight x solid angle
        counts = np.zeros(h * w, np.int64)  # clipped pixels per work cell
        norm, top_wt, seen = np.zeros(n), np.zeros(n), False
        step = max(1, FILL_CHUNK // max(W, 1))
        blocks = [(r, min(H, r + step)) for r in range(0, H, step)]
        for block_counts, found in threads.imap(self._plan_block, blocks):
            counts += block_counts
            if found is not None:  # the same sums, in the same order, as one bincount over every pixel
                pl, wt_om, wt = found
                seen = True
                np.add.at(norm, pl, wt_om)
                np.maximum.at(top_wt, pl, wt)
        self._counts = counts
        if seen:
            cell_sr = sh.pixel_solid_angles(h, w)
            lab = labels[in_region]
            self._energy = np.stack([np.bincount(lab, (excess[..., c] * cell_sr)[in_region], n) for c in range(3)], -1)
            got = norm > 0
            self._scale = np.where(got, 1.0 / np.maximum(norm, 1e-300), 0.0)
            if got.any():  # the largest addition: a region's energy x its largest weight x its scale
                self._top = float(((self._energy * (top_wt * self._scale)[:, None]).astype(np.float32)).max())
            in_region &= got[np.maximum(labels, 0)]  # a region without a clipped pixel falls back to its cells
        if not has.any():
            return
        ys_full = (np.arange(H) * h) // H  # work row of each full row
        xs_full = (np.arange(W) * w) // W
        row0, row1 = np.searchsorted(ys_full, np.arange(h)), np.searchsorted(ys_full, np.arange(h), side="right")
        col0, col1 = np.searchsorted(xs_full, np.arange(w)), np.searchsorted(xs_full, np.arange(w), side="right")
        for y, x in zip(*np.nonzero(has & ~in_region)):
            self.cells.append((row0[y], row1[y], col0[x], col1[x], excess[y, x].astype(np.float32)))

    def _plan_block(self, rows):
        """(clipped pixels per work cell (h w,), (labels int32, weights x solid angles, weights) of the block's
        region pixels in row-major order, or None) of rows r0..r1 (a few MB)."""
        (H, W), (h, w) = self.shape, self.work_shape
        ys, xs = np.nonzero(self.clipped_rows(*rows))
        ys += rows[0]
        counts = np.bincount((ys * h // H) * w + xs * w // W, minlength=h * w)
        if self._geometry is None:
            return counts, None
        parts = [(pl.astype(np.int32), wt * om, wt) for _, _, pl, wt, om in self._weights(ys, xs)]
        return counts, (tuple(np.concatenate(a) for a in zip(*parts)) if parts else None)

    def _weights(self, ys, xs):
        """(ys, xs, labels, weights max(t, CORE_RADIUS)^-p, row solid angles) of those of the given clipped pixels
        that lie in a region's cells, by chunks of FILL_CHUNK pixels (in their order), so that the temporaries stay a
        few tens of MB however much of the panorama clipped."""
        H, W = self.shape
        h, w = self.work_shape
        centres, exponents, labels = self._geometry
        omega = sh.row_solid_angles(H, W)
        for i in range(0, ys.size, FILL_CHUNK):
            cy, cx = ys[i:i + FILL_CHUNK], xs[i:i + FILL_CHUNK]
            pl = labels[(cy * h) // H, (cx * w) // W]
            keep = pl >= 0
            cy, cx, pl = cy[keep], cx[keep], pl[keep]
            if not cy.size:
                continue
            d = sh.grid.directions_at(cy, cx, H, W)
            t = np.arccos(np.clip(np.einsum("ij,ij->i", d, centres[pl]), -1.0, 1.0))
            wt = np.maximum(t, CORE_RADIUS) ** (-exponents[pl])
            yield cy, cx, pl, wt, omega[cy]

    def _splats(self, points):
        """Key lights (unit direction (3,), RGB energy (3,)) as pixel additions: each energy split over the
        2 x 2 pixels around its direction by bilinear weights (their weighted centre is the direction),
        divided by each pixel's solid angle, so the panorama gains exactly the light's energy there."""
        H, W = self.shape
        ys, xs, adds = [], [], []
        omega = sh.row_solid_angles(H, W)
        for d, rgb in points:
            y, x = sh.grid.pixel_coordinates(np.asarray(d, dtype=np.float64)[None], H, W)
            y = float(np.clip(y[0], 0.0, H - 1.0))
            y0, x0 = min(int(math.floor(y)), H - 2) if H > 1 else 0, int(math.floor(x[0]))
            fy, fx = y - y0, x[0] - x0
            for dy, wy in ((0, 1.0 - fy), (1, fy)):
                for dx, wx in ((0, 1.0 - fx), (1, fx)):
                    if wy * wx > 0 and y0 + dy < H:
                        ys.append(y0 + dy)
                        xs.append((x0 + dx) % W)
                        adds.append(np.asarray(rgb, dtype=np.float64) * wy * wx / omega[y0 + dy])
        if not ys:
            return None
        return np.array(ys), np.array(xs), np.array(adds, dtype=np.float32)

    def peak(self) -> float:
        """An upper bound of the energy ``apply`` adds to any one pixel (per channel, linear units)."""
        top = self._top
        if self.points is not None:
            top += float(self.points[2].sum(axis=0).max())
        if self.cells:
            (H, W), (h, w) = self.shape, self.work_shape
            for c_r0, c_r1, c0, c1, exc in self.cells:
                n = (c_r1 - c_r0) * (c1 - c0)
                k = self._counts[(c_r0 * h // H) * w + c0 * w // W]  # the cell's clipped pixels (0: all share)
                top = max(top, float(exc.max()) * (n / k if k else 1.0))
        return top

    def apply(self, block: np.ndarray, r0: int, clipped_block: np.ndarray) -> None:
        """Add the recovered energy to rows r0 .. r0 + len(block) of the panorama: ``block`` float32
        (n, W, 3) linear, in place; ``clipped_block`` (n, W) bool, those rows' clipped pixels."""
        r1 = r0 + block.shape[0]
        if self._scale is not None:
            rows, cols = np.nonzero(clipped_block)
            for ys, xs, pl, wt, _ in self._weights(rows + r0, cols):
                np.add.at(block, (ys - r0, xs), (self._energy[pl] * (wt * self._scale[pl])[:, None]).astype(np.float32))
        if self.points is not None:
            ys, xs, add = self.points
            sel = (ys >= r0) & (ys < r1)
            np.add.at(block, (ys[sel] - r0, xs[sel]), add[sel])
        for c_r0, c_r1, c0, c1, exc in self.cells:
            if c_r1 <= r0 or c_r0 >= r1:
                continue
            # the cell's pixel mean gains excess: pixel j gets excess x n_pixels x weight_j / sum(weight); the
            # weights are over the whole cell, which may span two blocks
            cell_clipped = self._cell_clipped(c_r0, c_r1, c0, c1, r0, clipped_block)
            weight = cell_clipped.astype(np.float32) if cell_clipped.any() else np.ones(cell_clipped.shape, np.float32)
            part = weight * (cell_clipped.size / weight.sum())
            a, b = max(c_r0, r0), min(c_r1, r1)
            block[a - r0:b - r0, c0:c1] += part[a - c_r0:b - c_r0][..., None] * exc

    def _cell_clipped(self, c_r0, c_r1, c0, c1, r0, clipped_block):
        r1 = r0 + clipped_block.shape[0]
        if c_r0 >= r0 and c_r1 <= r1:
            return clipped_block[c_r0 - r0:c_r1 - r0, c0:c1]
        return np.asarray(self.clipped_rows(c_r0, c_r1))[:, c0:c1]  # a cell across two blocks: its rows again


def key_deposits(keys, shape) -> np.ndarray:
    """(h, w, 3) the key lights' energy as ``Recovery.work`` holds it: each in the cell holding its direction."""
    out = np.zeros(shape)
    omega = sh.pixel_solid_angles(*shape[:2])
    for k in keys:
        y, x = sh.grid.pixel_at(k.direction, *shape[:2])
        out[y, x] += k.energy * k.color / omega[y, x]
    return out
