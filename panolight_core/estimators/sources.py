"""Per-source energy: how much light each clipped region of an LDR panorama really holds.

An 8-bit panorama keeps nothing above its clip level, so the energy of a sun or a lamp has to be
predicted from what the picture does show. A region is a connected set of work-map cells (128 rows,
seam- and pole-aware) holding pixels at 254/255 in all three channels. ``region_features`` measures
what the LDR shows of it: clipped area and extent, elevation, how many channels clipped around it,
its glare (ring luminance at four angular distances, the power-law exponent fitted on it and the
physical model's gain, ``highlights.power_law_gain``) and the scene around it (exposure statistics,
sky brightness and colour, lit/shadow contrast, the other regions). A learned model
(``models/sources.safetensors``: gradient-boosted trees exported to arrays, trained on real HDR
panoramas by ``training/source_energy.py``) maps them to the log of the region's energy ratio
r = true energy / energy its cells hold, as a mean mu and a spread sigma (the uncertainty).

Which value to report. m-RMSE punishes an over-estimate without bound and an under-estimate at most
by the source's energy: for a dominant source the error is |r_hat / r - 1|, smallest in expectation
at log r_hat = mu - sigma^2 when log r ~ N(mu, sigma^2). The metric's median scaling adds more (a
bright enough estimate drags the median of an lmax-2 map to zero), so ``choose_shrink`` decides per
scene under the metric itself: log r_hat = max(mu - c sigma^2, 0) with the c of lowest expected error
over truths drawn from the predictive distribution. Never below 1: clipping only hides light.

The excess (r - 1) x held goes into the region's cells by ``Regions.share`` (their clipped area,
shaped by ``Regions.shape_exponents``), white in the camera's balance, so the recovered work map holds
exactly r x held in the region; ``fill_full_resolution`` puts the same energy into the full-resolution
clipped pixels, shaped like a source (a compact region peaks along its glare's power law; a wide one
is filled evenly). Work maps: radiance (h, 2h, 3) linear in clip units (1 = white), Blender world
frame (CONVENTIONS.md).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

import numpy as np

from .. import sh
from ..camera.color import LUMINANCE_WEIGHTS, SRGB8_TO_LINEAR
from ..camera.resample import area_mean_lut, clipped_fractions
from ..errors import PanoLightError
from .highlights import CORE_RADIUS, MAX_EXPONENT, _ring_fit, label_blobs, power_law_gain

WORK_HEIGHT = 128  # rows of the source work map (1.4 degree cells): a 0.5 degree sun still marks its cells
MAX_REGIONS = 48  # regions modelled, largest clipped area first; smaller speckles keep the clip level
RING_EDGES_DEG = (0.0, 2.0, 5.0, 10.0, 20.0)  # rings beyond the region's edge, degrees
SHAPE_MAX_EXTENT_DEG = 10.0  # regions up to this radius are shaped by their glare's power law
WIDE_CONCENTRATION = 0.0  # profile exponent of wider regions (0: an even fill)
MODEL_PATH = Path(__file__).resolve().parents[1] / "models" / "sources.safetensors"
FEATURES = (
    "log_clipped_sr", "log_region_sr", "elevation", "log_any_over_all_clipped", "full_cells",
    "compactness", "log_extent_deg", "ring0", "ring1", "ring2", "ring3", "ring_falloff", "exponent",
    "log_power_law_gain", "ring_saturation", "ring_blue_red", "log_held_mean", "share_of_clipped",
    "rank", "log_regions", "log_scene_clipped", "log_median", "log_mean", "log_upper_lower",
    "sky_blue_red", "log_lower_contrast", "log_brightest_ring_elsewhere", "log_scene_over_held",
    "log_upper_over_held",
)


def work_maps(ldr: np.ndarray, height: int = WORK_HEIGHT):
    """uint8 sRGB (H, W, 3) -> (radiance (h, 2h, 3) float64 linear, any-channel clipped fraction (h, 2h),
    all-channels clipped fraction (h, 2h)), area-averaged; h = min(height, H)."""
    a = np.asarray(ldr)
    if a.dtype != np.uint8 or a.ndim != 3 or a.shape[-1] != 3:
        raise PanoLightError(f"source energy needs (H, W, 3) uint8 sRGB pixels, got {a.dtype} {a.shape}")
    h = min(height, a.shape[0])
    # by row blocks: a 16K panorama has no room for full-resolution float copies
    rad = area_mean_lut(a, h, SRGB8_TO_LINEAR)
    fr = clipped_fractions(a, h)
    return rad, fr[..., 0], fr[..., 1]


@dataclass
class Regions:
    """Clipped regions of a work map: labels (h, w) int (-1 outside), and per region (n,) arrays:
    clipped solid angle (sr), held luminance energy (clip units x sr, over the region's cells), unit
    centre direction (n, 3), excess colour (n, 3, luminance 1), glare exponent p, features (n, F);
    share (h, w): each cell's share of its region's excess energy: its clipped solid angle weighted by
    the region's profile (``shape_exponents``).

    The excess colour is white in the camera's balance, as the clipped pixels are: given each region's
    true energy, white scores m-RMSE 0.35 mean / 0.30 median on the 50 real HDRs at ev 0, the glare
    ring's colour 0.41 / 0.33 (a sun's ring is blue sky)."""

    labels: np.ndarray
    clipped_sr: np.ndarray
    held: np.ndarray
    centre: np.ndarray
    color: np.ndarray
    exponent: np.ndarray
    features: np.ndarray
    share: np.ndarray

    @property
    def count(self) -> int:
        return int(self.held.size)

    def shape_exponents(self) -> np.ndarray:
        """(n,) exponent q of the profile max(t, t_core)^-q around its centre that each region's excess
        follows (in the work map and in ``fill_full_resolution``): its glare's p for a compact region
        (extent <= SHAPE_MAX_EXTENT_DEG, a sun or lamp), WIDE_CONCENTRATION for a wide one."""
        extent = 10.0 ** self.features[:, FEATURES.index("log_extent_deg")]
        return np.where(extent <= SHAPE_MAX_EXTENT_DEG, self.exponent, WIDE_CONCENTRATION)


def _log10(v, floor=1e-6):
    return math.log10(max(float(v), floor))


def region_features(rad: np.ndarray, frac_any: np.ndarray, frac_all: np.ndarray,
                    max_regions: int = MAX_REGIONS) -> Regions:
    """Find the clipped regions of work maps (``work_maps``) and measure their features (FEATURES).

    A region is a connected set of cells holding pixels clipped in all three channels: a blue sky that
    clipped only in blue stays out of the sun's region (measured: the all-channel regions, given their
    true energy, score m-RMSE 0.41 mean / 0.33 median on the 50 real HDRs at ev 0, against 0.67 / 0.40
    for any-channel regions)."""
    frac = frac_all
    h, w = frac.shape
    labels, count = label_blobs(frac > 0)
    dirs = sh.pixel_directions(h, w)
    omega = sh.pixel_solid_angles(h, w)
    lum = rad @ LUMINANCE_WEIGHTS
    cell_deg = 180.0 / h
    if count == 0:
        empty = np.zeros((0,))
        return Regions(labels, empty, empty, np.zeros((0, 3)), np.zeros((0, 3)), empty,
                       np.zeros((0, len(FEATURES))), np.zeros((h, w)))
    m = labels >= 0
    lab = labels[m]
    wc = (omega * frac)[m]
    clipped_sr = np.bincount(lab, wc, count)
    order = np.argsort(-clipped_sr)
    keep = order[:max_regions]
    remap = np.full(count, -1)
    remap[keep] = np.arange(keep.size)
    labels = np.where(m, remap[np.maximum(labels, 0)], -1)
    m = labels >= 0
    lab = labels[m]
    n = keep.size
    clipped_sr = clipped_sr[keep]
    region_sr = np.bincount(lab, omega[m], n)
    held = np.bincount(lab, (lum * omega)[m], n)
    any_sr = np.bincount(lab, (omega * frac_any)[m], n)
    full_sr = np.bincount(lab, (omega * (frac >= 0.999))[m], n)
    wcm = (omega * frac)[m]
    centre = np.stack([np.bincount(lab, wcm * dirs[m][:, i], n) for i in range(3)], -1)
    norms = np.linalg.norm(centre, axis=1, keepdims=True)
    centre = np.where(norms > 0, centre / np.maximum(norms, 1e-30), np.array([0.0, 0.0, 1.0]))

    # scene statistics (the same for every region)
    total_sr = 4.0 * math.pi
    upper = dirs[..., 2] > 0.05
    lower = dirs[..., 2] < -0.05
    clear = frac == 0
    mean_lum = float((lum * omega).sum() / total_sr)
    median_lum = float(np.median(lum))
    up_mean = float((lum * omega)[upper].sum() / max(omega[upper].sum(), 1e-12))
    lo_mean = float((lum * omega)[lower].sum() / max(omega[lower].sum(), 1e-12))
    sky = upper & clear
    sky_rgb = (rad[sky] * omega[sky][:, None]).sum(0) if sky.any() else np.ones(3)
    lo_lum = lum[lower & clear]
    lo_contrast = (np.percentile(lo_lum, 90) / max(np.percentile(lo_lum, 10), 1e-4)) if lo_lum.size > 8 else 1.0
    scene_clipped = float(clipped_sr.sum())
    scene = [math.log10(count), _log10(scene_clipped / total_sr), _log10(median_lum), _log10(mean_lum),
             _log10(up_mean / max(lo_mean, 1e-6)), sky_rgb[2] / max(sky_rgb[0], 1e-9), _log10(lo_contrast)]

    feats = np.zeros((n, len(FEATURES)))
    color = np.ones((n, 3))  # the excess is white (luminance 1): see Regions
    exponent = np.zeros(n)
    ring0_all = np.zeros(n)
    inside_angles = []
    for i in range(n):
        c = centre[i]
        ang = np.arccos(np.clip(dirs @ c, -1.0, 1.0))
        inside = labels == i
        extent = float(ang[inside].max()) + math.radians(0.5 * cell_deg)
        inside_angles.append((inside, ang[inside]))
        rings = []
        ring_rgb = None
        for k in range(4):
            lo_a = extent + math.radians(RING_EDGES_DEG[k])
            hi_a = extent + math.radians(RING_EDGES_DEG[k + 1]) + math.radians(cell_deg)
            sel = (ang > lo_a) & (ang < hi_a) & clear
            if sel.sum() >= 2:
                om = omega[sel]
                rings.append(float((lum[sel] * om).sum() / om.sum()))
                if ring_rgb is None:
                    ring_rgb = (rad[sel] * om[:, None]).sum(0) / om.sum()
            else:
                rings.append(rings[-1] if rings else 1.0)
        fit = (ang > extent) & (ang < max(3.0 * extent, extent + math.radians(3 * cell_deg))) & clear & (lum > 0)
        p = float(np.clip(_ring_fit(ang[fit], lum[fit], omega[fit]), 0.0, MAX_EXPONENT)) if fit.sum() >= 3 else 0.0
        exponent[i] = p
        ring_color = np.ones(3)
        if ring_rgb is not None and float(ring_rgb @ LUMINANCE_WEIGHTS) > 0:
            ring_color = ring_rgb / float(ring_rgb @ LUMINANCE_WEIGHTS)
        ring0_all[i] = rings[0]
        gain = power_law_gain(clipped_sr[i], p)
        sat = float(ring_color.max() / max(ring_color.min(), 1e-3))
        feats[i, :17] = [
            _log10(clipped_sr[i]), _log10(region_sr[i]), c[2], _log10(any_sr[i] / max(clipped_sr[i], 1e-12)),
            full_sr[i] / max(region_sr[i], 1e-12), clipped_sr[i] / (math.pi * extent ** 2),
            math.log10(math.degrees(extent)), *[_log10(r, 1e-4) for r in rings],
            _log10(rings[3], 1e-4) - _log10(rings[0], 1e-4), p, math.log10(gain), math.log10(sat),
            ring_color[2] / max(ring_color[0], 1e-3), _log10(held[i] / max(region_sr[i], 1e-12)),
        ]
    clipped_share = clipped_sr / max(scene_clipped, 1e-12)
    scene_e = float((lum * omega).sum())
    upper_e = float((lum * omega)[upper].sum())
    for i in range(n):
        others = np.delete(ring0_all, i)
        feats[i, 17:] = [clipped_share[i], min(i, 10), *scene, _log10(others.max() if others.size else 1e-4, 1e-4),
                         _log10(scene_e / max(held[i], 1e-12)), _log10(upper_e / max(held[i], 1e-12))]
    regions = Regions(labels, clipped_sr, held, centre, color, exponent, feats, np.zeros((h, w)))
    q = regions.shape_exponents()
    t_floor = max(CORE_RADIUS, math.radians(0.5 * cell_deg))
    for i, (cells, ang_in) in enumerate(inside_angles):
        wt = (omega * frac)[cells] * np.maximum(ang_in, t_floor) ** (-q[i])
        regions.share[cells] = wt / max(float(wt.sum()), 1e-300)
    return regions


# --- the learned model: regression trees as arrays -------------------------------------------------

@dataclass(frozen=True)
class TreeEnsemble:
    """Gradient-boosted regression trees as flat arrays (nodes of all trees concatenated).

    feature (N,) int (-1 at leaves), threshold (N,), left/right (N,) int (absolute node indices),
    value (N,) (leaf outputs, already multiplied by the learning rate), roots (T,) int; prediction =
    base + sum over trees of the leaf reached (x[feature] <= threshold goes left)."""

    feature: np.ndarray
    threshold: np.ndarray
    left: np.ndarray
    right: np.ndarray
    value: np.ndarray
    roots: np.ndarray
    base: float

    def predict(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=np.float64)
        if x.shape[0] == 0:
            return np.zeros(0)
        node = np.repeat(self.roots[None, :], x.shape[0], 0)  # (n, T)
        rows = np.arange(x.shape[0])[:, None]
        for _ in range(64):
            f = self.feature[node]
            inner = f >= 0
            if not inner.any():
                break
            go_left = x[rows, np.maximum(f, 0)] <= self.threshold[node]
            node = np.where(inner, np.where(go_left, self.left[node], self.right[node]), node)
        return self.base + self.value[node].sum(axis=1)


@dataclass(frozen=True)
class SourceModel:
    """mean: trees for mu = E[log r]; spread: trees for E|log r - mu| (sigma = sqrt(pi/2) x it)."""

    mean: TreeEnsemble
    spread: TreeEnsemble
    shrink: float
    features: tuple
    meta: dict
    path: Path

    def predict(self, feats: np.ndarray):
        """(n, F) features -> (mu, sigma, reported log ratio), each (n,), natural log."""
        mu = self.mean.predict(feats)
        sigma = math.sqrt(math.pi / 2.0) * np.maximum(self.spread.predict(feats), 0.02)
        return mu, sigma, np.maximum(mu - self.shrink * sigma ** 2, 0.0)


def ensemble_arrays(prefix: str, e: TreeEnsemble) -> dict:
    """Arrays to store an ensemble (safetensors names ``prefix.*``)."""
    return {f"{prefix}.feature": e.feature.astype(np.int32), f"{prefix}.threshold": e.threshold.astype(np.float64),
            f"{prefix}.left": e.left.astype(np.int32), f"{prefix}.right": e.right.astype(np.int32),
            f"{prefix}.value": e.value.astype(np.float64), f"{prefix}.roots": e.roots.astype(np.int32),
            f"{prefix}.base": np.array([e.base], dtype=np.float64)}


def _ensemble(t: dict, prefix: str, path: Path) -> TreeEnsemble:
    try:
        parts = {k: t[f"{prefix}.{k}"] for k in ("feature", "threshold", "left", "right", "value", "roots", "base")}
    except KeyError as exc:
        raise PanoLightError(f"{path}: not a PanoLight source-energy model (missing tensor {exc.args[0]})") from None
    n = parts["feature"].size
    for k in ("threshold", "left", "right", "value"):
        if parts[k].shape != (n,):
            raise PanoLightError(f"{path}: source-energy model tensor {prefix}.{k} has the wrong shape")
    inner = parts["feature"] >= 0
    kids = np.concatenate([parts["left"][inner], parts["right"][inner], parts["roots"]])
    if kids.size and (kids.min() < 0 or kids.max() >= n) or parts["feature"].max(initial=-1) >= len(FEATURES):
        raise PanoLightError(f"{path}: source-energy model has node or feature indices out of range")
    return TreeEnsemble(parts["feature"].astype(np.int64), parts["threshold"], parts["left"].astype(np.int64),
                        parts["right"].astype(np.int64), parts["value"], parts["roots"].astype(np.int64),
                        float(parts["base"][0]))


@lru_cache(maxsize=4)
def load_source_model(path=MODEL_PATH) -> SourceModel:
    """The source-energy model in ``path`` (safetensors, no pickle); PanoLightError naming the file."""
    import json

    from .nn.safetensors_np import load_shipped

    path = Path(path)
    tensors, meta = load_shipped(path, "source-energy model")
    feats = tuple(json.loads(meta.get("features", "[]")))
    if feats != FEATURES:
        raise PanoLightError(f"{path}: the model was trained on other features than this PanoLight computes "
                             f"(retrain it with training/source_energy.py)")
    return SourceModel(_ensemble(tensors, "mean", path), _ensemble(tensors, "spread", path),
                       float(meta.get("shrink", 1.0)), feats, dict(meta), path)


# --- recovery ---------------------------------------------------------------------------------------

def fill_regions(rad: np.ndarray, regions: Regions, log_ratio: np.ndarray, keys=()) -> np.ndarray:
    """Work map with each region's excess (r - 1) x held added to its cells by ``Regions.share``, in
    the region's colour, less the energy of the region's key light (``keys``), which is not in the map.
    Returns a new (h, w, 3) map."""
    out = np.array(rad, dtype=np.float64, copy=True)
    if regions.count == 0:
        return out
    excess = (np.exp(np.asarray(log_ratio, dtype=np.float64)) - 1.0) * regions.held
    for k in keys:
        excess[k.region] = max(excess[k.region] - k.energy, 0.0)
    m = regions.labels >= 0
    lab = regions.labels[m]
    omega = sh.pixel_solid_angles(*regions.labels.shape)
    out[m] += (excess[lab] * regions.share[m] / omega[m])[:, None] * regions.color[lab]
    return out


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
    fill = FullResolutionFill(np.nonzero(clipped), clipped.shape, excess, centres, exponents, labels, points)
    fill.apply(out, 0, clipped)
    return out


class FullResolutionFill:
    """``fill_full_resolution`` split into a plan, made from the clipped pixels' coordinates (ys, xs) of an
    (H, W) panorama, and ``apply`` to any row block of the linearised panorama, in place."""

    def __init__(self, clipped_yx, shape, excess: np.ndarray, centres=(), exponents=(), labels=None, points=()):
        H, W = shape
        h, w = excess.shape[:2]
        self.clipped_yx_cache = clipped_yx
        self.shape, self.work_shape = (H, W), (h, w)
        has = excess.max(axis=-1) > 0
        self.pixels = None  # (ys, xs, add (n, 3) float32) for region pixels
        self.cells = []  # (r0, r1, c0, c1, excess (3,) float32) of the other cells
        self.points = self._splats(points)  # (ys, xs, add (n, 3) float32) of the key lights
        if not has.any():
            return
        in_region = np.zeros((h, w), bool) if labels is None else (labels >= 0) & (labels < len(centres))
        if in_region.any():
            cell_sr = sh.pixel_solid_angles(h, w)
            n = len(centres)
            lab = labels[in_region]
            energy = np.stack([np.bincount(lab, (excess[..., c] * cell_sr)[in_region], n) for c in range(3)], -1)
            ys, xs = clipped_yx
            pl = labels[(ys * h) // H, (xs * w) // W]
            keep = pl >= 0
            ys, xs, pl = ys[keep], xs[keep], pl[keep]
            if ys.size:
                d = sh.grid.directions_at(ys, xs, H, W)
                t = np.arccos(np.clip(np.einsum("ij,ij->i", d, np.asarray(centres, dtype=np.float64)[pl]), -1.0,
                                      1.0))
                wt = np.maximum(t, CORE_RADIUS) ** (-np.asarray(exponents, dtype=np.float64)[pl])
                om = sh.row_solid_angles(H, W)[ys]
                norm = np.bincount(pl, wt * om, n)
                got = norm > 0
                scale = np.where(got, 1.0 / np.maximum(norm, 1e-300), 0.0)
                self.pixels = (ys, xs, (energy[pl] * (wt * scale[pl])[:, None]).astype(np.float32))
                in_region &= got[np.maximum(labels, 0)]  # a region without a clipped pixel falls back to its cells
        ys_full = (np.arange(H) * h) // H  # work row of each full row
        xs_full = (np.arange(W) * w) // W
        row0, row1 = np.searchsorted(ys_full, np.arange(h)), np.searchsorted(ys_full, np.arange(h), side="right")
        col0, col1 = np.searchsorted(xs_full, np.arange(w)), np.searchsorted(xs_full, np.arange(w), side="right")
        for y, x in zip(*np.nonzero(has & ~in_region)):
            self.cells.append((row0[y], row1[y], col0[x], col1[x], excess[y, x].astype(np.float32)))

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
        top = float(self.pixels[2].max()) if self.pixels is not None and self.pixels[2].size else 0.0
        if self.points is not None:
            top += float(self.points[2].sum(axis=0).max())
        if self.cells:
            ys, xs = self.clipped_yx_cache
            (H, W), (h, w) = self.shape, self.work_shape
            clipped = np.bincount((ys * h // H) * w + xs * w // W, minlength=h * w)
            for c_r0, c_r1, c0, c1, exc in self.cells:
                n = (c_r1 - c_r0) * (c1 - c0)
                k = clipped[(c_r0 * h // H) * w + c0 * w // W]  # the cell's clipped pixels (0: all share)
                top = max(top, float(exc.max()) * (n / k if k else 1.0))
        return top

    def apply(self, block: np.ndarray, r0: int, clipped_block: np.ndarray) -> None:
        """Add the recovered energy to rows r0 .. r0 + len(block) of the panorama: ``block`` float32
        (n, W, 3) linear, in place; ``clipped_block`` (n, W) bool, those rows' clipped pixels."""
        r1 = r0 + block.shape[0]
        for found in (self.pixels, self.points):
            if found is not None:
                ys, xs, add = found
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
        ys, xs = self.clipped_yx_cache
        sel = (ys >= c_r0) & (ys < c_r1) & (xs >= c0) & (xs < c1)
        cell = np.zeros((c_r1 - c_r0, c1 - c0), bool)
        cell[ys[sel] - c_r0, xs[sel] - c0] = True
        return cell


@dataclass
class Recovery:
    """What ``recover`` found: the recovered work map (h, 2h, 3), the plain linearised work map, the
    all-channels clipped fraction (h, 2h), the regions and, per region, mu, sigma and the reported log ratio."""

    work: np.ndarray
    base: np.ndarray
    frac: np.ndarray
    regions: Regions
    mu: np.ndarray
    sigma: np.ndarray
    log_ratio: np.ndarray
    decision: dict | None = None
    keys: list = field(default_factory=list)  # keylight.KeyLight: the compact sources, as explicit lights
    diffuse: np.ndarray | None = None  # ``work`` without the key lights (what the SH part is fitted to)

    def __post_init__(self):
        if self.diffuse is None:
            self.diffuse = self.work

    def key_points(self) -> list:
        """(unit direction (3,), RGB energy (3,)) of each key light, for the full-resolution HDRI."""
        return [(k.direction, k.energy * k.color) for k in self.keys]

    def lights(self) -> list[dict]:
        """The key lights as lighting-file light dicts, brightest first."""
        return [k.as_light() for k in sorted(self.keys, key=lambda k: -k.energy)]

    def key_exclusions(self) -> list:
        """(direction (3,), angular radius in radians) of each key light's region: the lighting model takes
        no second light there (one light per physical source)."""
        cell = math.pi / self.work.shape[0]
        return [(k.direction, math.sqrt(self.regions.clipped_sr[k.region] / math.pi) + 2 * cell) for k in self.keys]

    def region_info(self) -> list[dict]:
        """Per region, for lighting.json: direction, clipped solid angle (sr), held and recovered energy
        (luminance, clip units x sr), ratio with its 68 % interval, angular radius (extent, degrees),
        colour and glare exponent."""
        r = self.regions
        out = []
        for i in range(r.count):
            out.append({"direction": [round(float(v), 6) for v in r.centre[i]],
                        "solid_angle": float(r.clipped_sr[i]), "held_energy": float(r.held[i]),
                        "energy": float(r.held[i] * math.exp(self.log_ratio[i])),
                        "ratio": float(math.exp(self.log_ratio[i])),
                        "ratio_68": [float(math.exp(max(self.mu[i] - self.sigma[i], 0.0))),
                                     float(math.exp(self.mu[i] + self.sigma[i]))],
                        "extent_deg": float(10.0 ** r.features[i, FEATURES.index("log_extent_deg")]),
                        "color": [round(float(v), 6) for v in r.color[i]], "exponent": float(r.exponent[i])})
        return out


def recover(ldr: np.ndarray, model: SourceModel | None = None, log_ratio_fn=None,
            height: int = WORK_HEIGHT, decide: bool = True, tolerance: float | None = None,
            min_median_ratio: float | None = None, maps=None, key_lights: bool = False) -> Recovery:
    """Recover the clipped energy of a uint8 sRGB panorama with the learned model (default: the shipped
    one) or ``log_ratio_fn(regions) -> (mu, sigma, reported)`` (alternatives and oracles in evaluation).

    decide: report the energies ``choose_shrink`` picks (the expected-error optimum under the metric);
    False: the model's fixed rule, log r = mu - shrink sigma^2. maps: ``work_maps(ldr, height)`` when the
    caller already has them (the learned estimator's input at this height), so they are made once.
    key_lights: make the regions that hold a compact key source explicit lights (``keylight``); each such
    region's fill keeps only what its decided energy holds beyond its light's."""
    rad, frac, frac_all = work_maps(ldr, height) if maps is None else maps
    regions = region_features(rad, frac, frac_all)
    decision = None
    if log_ratio_fn is not None:
        mu, sigma, reported = log_ratio_fn(regions)
    else:
        mu, sigma, reported = (model or load_source_model()).predict(regions.features)
        if decide and regions.count:
            c, expected = choose_shrink(rad, regions, mu, sigma, tolerance=tolerance,
                                        min_median_ratio=min_median_ratio)
            reported = np.zeros_like(mu) if math.isinf(c) else np.maximum(mu - c * sigma ** 2, 0.0)
            decision = {"shrink": "none" if math.isinf(c) else c, "expected_error": expected}
    keys = []
    if key_lights and log_ratio_fn is None and regions.count:
        from .keylight import find_key_lights

        keys = find_key_lights(rad, frac, frac_all, regions, mu, sigma, reported)
    diffuse = fill_regions(rad, regions, reported, keys)
    work = diffuse + _key_deposits(keys, diffuse.shape) if keys else diffuse
    return Recovery(work, rad, frac_all, regions, mu, sigma, reported, decision, keys, diffuse)


def _key_deposits(keys, shape) -> np.ndarray:
    """(h, w, 3) the key lights' energy as ``Recovery.work`` holds it: each in the cell holding its direction."""
    out = np.zeros(shape)
    omega = sh.pixel_solid_angles(*shape[:2])
    for k in keys:
        y, x = sh.grid.pixel_at(k.direction, *shape[:2])
        out[y, x] += k.energy * k.color / omega[y, x]
    return out


def power_law_log_ratio(regions: Regions):
    """The physical model alone as a region ratio (the learned model's yardstick): the power law's gain
    over the clipped area, no spread."""
    gain = 10.0 ** regions.features[:, FEATURES.index("log_power_law_gain")]
    ratio = (regions.held + (gain - 1.0) * regions.clipped_sr) / np.maximum(regions.held, 1e-30)
    lr = np.log(np.maximum(ratio, 1.0))
    return lr, np.zeros_like(lr), lr


# --- the decision: the reported energies minimise the expected error under the metric itself ---------

SHRINK_CANDIDATES = (0.0, 0.25, 0.5, 1.0, 1.5, 2.0, 3.0, math.inf)  # inf: keep every region at its clip level
DECISION_SAMPLES = 64
DECISION_CORRELATION = 0.5  # how much of a region's error is shared by the scene (one exposure, one camera)
DECISION_TOLERANCE = 0.05
MIN_MEDIAN_RATIO = 0.1
_DECISION_GRID = (32, 64)


@lru_cache(maxsize=4)
def _grid_basis(h: int, w: int) -> np.ndarray:
    """(h w, 9) real SH of bands 0-2 at an (h, 2h) grid's pixel centres (the work map's, the decision's):
    made once per size, read-only."""
    y = sh.basis(sh.pixel_directions(h, w).reshape(-1, 3), 2)
    y.setflags(write=False)
    return y


def _weighted_errors(q: np.ndarray, g: np.ndarray, w: np.ndarray) -> np.ndarray:
    """EVALUATION.md's median-scaled relative RMSE for every (candidate, sample) pair.

    q (C, N, 3), g (S, N, 3) maps on a grid with weights w (N,) summing to 1 -> (C, S)."""
    med_q = np.median(q.reshape(q.shape[0], -1), axis=1)
    med_g = np.median(g.reshape(g.shape[0], -1), axis=1)
    scale = np.where(med_q[:, None] > 0, med_g[None, :] / np.where(med_q > 0, med_q, 1.0)[:, None], 1.0)
    qw = q * w[None, :, None]
    qq = (qw * q).sum(axis=(1, 2)) / 3.0
    gg = ((g * w[None, :, None]) * g).sum(axis=(1, 2)) / 3.0
    qg = (qw.reshape(q.shape[0], -1) @ g.reshape(g.shape[0], -1).T) / 3.0
    num = np.sqrt(np.maximum(scale ** 2 * qq[:, None] - 2.0 * scale * qg + gg[None, :], 0.0))
    den = (g * w[None, :, None]).sum(axis=(1, 2)) / 3.0
    return num / np.where(np.abs(den) > 0, den, np.inf)[None, :]


def choose_shrink(base: np.ndarray, regions: Regions, mu: np.ndarray, sigma: np.ndarray, seed: int = 0,
                  tolerance: float | None = None, min_median_ratio: float | None = None):
    """Pick c in SHRINK_CANDIDATES so that log r_i = max(mu_i - c sigma_i^2, 0) minimises the expected
    m-RMSE + irr-RMSE at lmax 2 when the truth is drawn from the model's own predictive distribution
    (log r_i = mu_i + sigma_i z_i, z correlated DECISION_CORRELATION across the scene's regions).

    The metric's median scaling makes over-estimates dangerous beyond the simple |r_hat/r - 1| argument
    (a bright enough source drags the median of an lmax-2 map to zero): deciding under the metric
    itself weighs that too. Of the candidates within ``tolerance`` (default DECISION_TOLERANCE, relative)
    of the lowest expected error the most conservative is taken, skipping candidates whose lmax-2 map
    has a median below ``min_median_ratio`` of its mean (MIN_MEDIAN_RATIO). base: the plain linearised
    work map.
    Returns (c, expected errors per c)."""
    tolerance = DECISION_TOLERANCE if tolerance is None else tolerance
    min_median_ratio = MIN_MEDIAN_RATIO if min_median_ratio is None else min_median_ratio
    n = regions.count
    if n == 0:
        return 0.0, {}
    from ..sh.irradiance import convolve_lambert

    h, w = regions.labels.shape
    y = _grid_basis(h, w)  # (h w, 9)
    m = (regions.labels >= 0).ravel()
    lab = regions.labels.ravel()[m]
    # SH of each region's fill per unit excess energy (white), as fill_regions spreads it
    wt = regions.share.ravel()[m]
    unit = np.stack([np.bincount(lab, wt * y[m, k], n) for k in range(9)], -1)  # (n, 9) per unit excess energy
    b = sh.project(base, 2)  # (9, 3)
    rng = np.random.default_rng(seed)
    z0 = rng.standard_normal((DECISION_SAMPLES, 1))
    z = DECISION_CORRELATION * z0 + math.sqrt(1 - DECISION_CORRELATION ** 2) * rng.standard_normal((DECISION_SAMPLES, n))
    true_lr = np.maximum(mu[None, :] + sigma[None, :] * z, 0.0)
    cand_lr = np.stack([np.zeros(n) if math.isinf(c) else np.maximum(mu - c * sigma ** 2, 0.0)
                        for c in SHRINK_CANDIDATES])

    def coeffs(lr):  # (X, n) log ratios -> (X, 9, 3)
        excess = (np.exp(lr) - 1.0) * regions.held[None, :]
        return b[None] + (excess @ unit)[:, :, None] * np.ones(3)

    gh, gw = _DECISION_GRID
    grid_y = _grid_basis(gh, gw)
    wgrid = sh.pixel_solid_angles(gh, gw).ravel() / (4.0 * math.pi)
    qc, gc = coeffs(cand_lr), coeffs(true_lr)
    err = np.zeros((len(SHRINK_CANDIDATES), DECISION_SAMPLES))
    for conv in (False, True):
        q, g = (convolve_lambert(qc), convolve_lambert(gc)) if conv else (qc, gc)
        err += _weighted_errors(np.matmul(grid_y, q), np.matmul(grid_y, g), wgrid)
    expected = err.mean(axis=1)
    # a candidate whose lmax-2 map has a median near zero (its source rings the rest of the sphere
    # down) makes the metric's median scale explode for any truth that does not share it: never report
    # one while a healthier candidate exists (the last candidate, no recovery, is the plain map)
    qmap = np.matmul(grid_y, qc)
    med = np.median(qmap.reshape(qmap.shape[0], -1), axis=1)
    mean = np.einsum("n,cnk->c", wgrid, qmap) / 3.0
    healthy = med >= min_median_ratio * np.maximum(mean, 1e-300)
    healthy[-1] = True
    pool = np.where(healthy, expected, np.inf)
    # the least energy whose expected error is within ``tolerance`` of the best: near-ties go to the
    # side where a wrong answer costs least (an over-estimate's cost is unbounded)
    ok = np.flatnonzero(pool <= pool.min() * (1.0 + tolerance) + 1e-12)
    best = int(ok.max())
    return SHRINK_CANDIDATES[best], {("none" if math.isinf(c) else f"{c:g}"): round(float(e), 6)
                                     for c, e in zip(SHRINK_CANDIDATES, expected)}

