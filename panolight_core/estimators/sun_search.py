"""Where the visible sky puts a sun the photo does not show (retouched out, veiled, not clipped): the clear-sky
position that best fits the sky (``search_sun``), and the tests that say whether to trust it (``SunSearch.found``).

Every candidate position's sky comes from the tabulated Hosek-Wilkie model (``sky``), all P positions x T
turbidities in one gather, scored by ``sky.fit_rows`` as ``sky.fit_clear_sky`` scores one. Work maps: (h, 2h, 3)
linear, clip units (1 = white), Blender world frame (Z up; CONVENTIONS.md). numpy only.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import sh
from ..camera.color import LUMINANCE_WEIGHTS
from .sky import (
    CLEAR_RMS,
    MIN_BLUENESS,
    MIN_SKY_SR,
    OCCLUDER_LOG,
    SkyFit,
    SkyTable,
    fit_clear_sky,
    fit_rows,
    load_sky_table,
    sky_cells,
)

SEARCH_ROWS, REFINE_ROWS = 16, 32  # rows of the coarse search's map (11 degree cells) and of its refinement's
SEARCH_STEP_DEG, REFINE_STEP_DEG = 7.5, 2.5  # the candidate suns' spacing (elevation; azimuth at the horizon x 1.5)
HIDDEN_MIN_SKY_SR = 1.5  # a sun found from the sky alone rests on at least this much visible sky (sr), a quarter
# of the upper hemisphere: small patches of sky between buildings fit a sun anywhere (docs/keylight.md)
HIDDEN_MAX_CONTRAST = 0.65  # ... and on a sky that singles its position out: the best position's score at most this
# share of the median position's (an overcast, grey or night sky fits every position nearly alike)
HIDDEN_MIN_ELEVATION_DEG = 5.0  # ... above this elevation (a sky at the horizon is mostly occluded or hazy)
AT_THE_HORIZON = "at the horizon"  # how that refusal begins: the one that leaves the position itself trusted
HIDDEN_MIN_COLOUR_MATCH = 0.0  # ... and whose colour varies as a clear sky's does: the correlation of log(blue/red)
# observed and modelled over the sky is positive (bluer away from the sun and the horizon). A white ceiling with
# a window passed every other test at ev -2 with -0.27; the real suns' skies found with their sun hidden: 0.31-0.94
# but one (-0.24), docs/keylight.md
DIRECTION_68_SCORE_MARGIN = 0.2  # a found sun's direction is uncertain over every coarse position scoring within
# this share of the best: over the real suns found with their sun hidden (docs/keylight.md), the farthest such
# position's angle covered the error for 68 % (17 of 25; median radius 10 degrees; a sharp sky 2.5, a long ridge
# of equal fits 20-30)
NO_SKY = (f"no open sky to fit (no {180.0 / SEARCH_ROWS:g}-degree patch of sky above the horizon without clipped "
          "pixels: a canopy or a sky clipped all over)")
SUN_PATCH_DEG = 3.0  # the cells around a found sun that tell whether it is seen (sky) or behind an occluder


@dataclass(frozen=True)
class SunSearch:
    """Where the visible sky puts a sun it does not show: the best-fitting sun position (unit (3,), Blender
    world frame), the clear-sky fit there (``fit_clear_sky`` on the whole work map), ``contrast`` (the best
    position's score over the median position's on the coarse grid: small when the sky singles the position
    out) and ``seen`` (the cells within SUN_PATCH_DEG of it are clipped or at least as bright as the median
    sky: the sun is retouched out, veiled or glaring, not behind a building or a tree, which would put the
    camera in its shade)."""

    direction: np.ndarray
    fit: SkyFit
    contrast: float
    seen: bool
    colour_match: float = 1.0  # ``colour_match``: how the sky's colour varies against the model's (-1..1)
    direction_68_deg: float = REFINE_STEP_DEG  # the direction's 68 % radius: the farthest coarse position whose
    # score is within DIRECTION_68_SCORE_MARGIN of the best, at least the refinement's step

    @property
    def elevation_deg(self) -> float:
        return sh.elevation_deg(self.direction)

    @property
    def found(self) -> bool:
        """A sun the sky shows: a clear fit (the cloudiness gate, its colour test included) on at least
        HIDDEN_MIN_SKY_SR of sky whose colour varies as the model's (HIDDEN_MIN_COLOUR_MATCH), a position the
        sky singles out (HIDDEN_MAX_CONTRAST), above HIDDEN_MIN_ELEVATION_DEG: no ``refusals``."""
        return not self.refusals()

    def refusals(self) -> list[str]:
        """Why the sky does not show a sun here, one phrase per failed test (empty: ``found``)."""
        f, out = self.fit, []
        if f.rms > CLEAR_RMS:
            out.append(f"the sky is not clear (residual {f.rms:.2f} > {CLEAR_RMS})")
        if f.blueness < MIN_BLUENESS:
            out.append(f"the sky is not blue (blue/red {f.blueness:.2f} of a clear sky's < {MIN_BLUENESS})" if f.blueness > 0
                       else "the sky shows no colour (a grey picture cannot tell a sky from a grey wall)")
        if f.sky_sr < max(HIDDEN_MIN_SKY_SR, MIN_SKY_SR):
            out.append(_too_little_sky(f.sky_sr))
        if self.contrast > HIDDEN_MAX_CONTRAST:
            out.append(_no_position_stands_out(self.contrast))
        if self.elevation_deg < HIDDEN_MIN_ELEVATION_DEG:
            out.append(f"{AT_THE_HORIZON} ({self.elevation_deg:.1f} deg < {HIDDEN_MIN_ELEVATION_DEG})")
        if not self.colour_match > HIDDEN_MIN_COLOUR_MATCH:
            out.append(f"the sky's colour does not vary as a clear sky's (correlation {self.colour_match:.2f})")
        return out


@dataclass(frozen=True)
class NoSun:
    """A search that stopped before fitting a sun (``search_sun``): too little sky, no open sky at all, or none
    that singles a position out. ``reason`` is the phrase ``refusals`` gives, in ``SunSearch.refusals``'s words."""

    reason: str
    found = False

    def refusals(self) -> list[str]:
        return [self.reason]


def _too_little_sky(sky_sr: float) -> str:
    return f"too little sky ({sky_sr:.2f} sr < {HIDDEN_MIN_SKY_SR})"


def _no_position_stands_out(contrast: float, limit: float = HIDDEN_MAX_CONTRAST) -> str:
    return f"no position stands out (best score {contrast:.2f} of the median's > {limit:g})"


def sun_candidates(step_deg: float, centre=None, reach_deg: float | None = None) -> np.ndarray:
    """(P, 3) unit sun positions above the horizon, ``step_deg`` apart in elevation (from step / 2) and about
    1.5 x that in azimuth at the horizon (wider apart toward the zenith); with ``centre`` (3,) only those
    within ``reach_deg`` of it, on a grid centred there."""
    if centre is None:
        elevations = np.arange(step_deg / 2.0, 90.0, step_deg)
        azimuth0 = 0.0
    else:
        c = np.asarray(centre, dtype=np.float64)
        e0 = sh.elevation_deg(c)
        k = math.ceil(reach_deg / step_deg)
        elevations = e0 + step_deg * np.arange(-k, k + 1)
        elevations = elevations[(elevations > 0.0) & (elevations < 90.0)]
        azimuth0 = math.degrees(math.atan2(c[1], c[0]))
    out = []
    for e in elevations:
        da = 1.5 * step_deg / max(math.cos(math.radians(e)), 0.1)
        n = max(int(round(360.0 / da)), 1)
        if centre is None:
            az = azimuth0 + np.arange(n) * 360.0 / n
        else:
            m = min(math.ceil(1.5 * reach_deg / da), n // 2)
            az = azimuth0 + da * np.arange(-m, m + 1)
        ce = math.cos(math.radians(e))
        a = np.radians(az)
        out.append(np.stack([ce * np.cos(a), ce * np.sin(a), np.full(a.shape, math.sin(math.radians(e)))], axis=-1))
    suns = np.concatenate(out) if out else np.zeros((0, 3))
    if centre is not None and suns.size:
        suns = suns[suns @ c >= math.cos(math.radians(reach_deg)) - 1e-9]
    return suns


def _coarse(rad: np.ndarray, usable: np.ndarray, clipped: np.ndarray, rows: int):
    """The work maps area-averaged to ``rows`` x 2 rows cells: radiance, usable (every cell in the block
    usable) and clipped (more than half of the block clipped)."""
    h, w = usable.shape
    rows = min(rows, h)
    re = np.round(np.linspace(0, h, rows + 1)).astype(int)
    ce = np.round(np.linspace(0, w, 2 * rows + 1)).astype(int)
    n = np.diff(re)[:, None] * np.diff(ce)[None, :]

    def mean(a):
        return np.add.reduceat(np.add.reduceat(a, re[:-1], axis=0), ce[:-1], axis=1) / (n if a.ndim == 2 else n[..., None])
    return mean(np.asarray(rad, dtype=np.float64)), mean(usable.astype(np.float64)) > 0.999, mean(clipped.astype(np.float64)) > 0.5


def _visible_sky_sr(rad: np.ndarray, usable: np.ndarray) -> float:
    """The solid angle (sr) of usable cells above MIN_SKY_ELEVATION_DEG: the most sky any fit can rest on."""
    _, omega, _, upper, _, _ = sky_cells(rad, usable, usable)
    return float(omega[upper & usable].sum())


def _position_scores(rad, usable, clipped, suns, table: SkyTable, turbidities: slice = slice(None)):
    """((P,) each candidate sun's best score over the table's turbidities (``sky.fit_rows``, the sRGB curve;
    inf where no sky is seen), (P,) the index of that turbidity)."""
    dirs, omega, lum, _, obs, cen = sky_cells(rad, usable, clipped)
    if obs.sum() < 16 or suns.shape[0] == 0:
        return np.full(suns.shape[0], np.inf), np.zeros(suns.shape[0], int)
    n_obs = int(obs.sum())
    model = table.sky_luminance_suns(np.concatenate([dirs[obs], dirs[cen]]), suns, turbidities)  # (P, T, N)
    lm = np.log(np.maximum(model, 1e-12)).reshape(-1, model.shape[-1])
    score = fit_rows(np.log(lum[obs]), lm[:, :n_obs], lm[:, n_obs:], omega[obs], omega[cen], contrast=False)[-1]
    score = score.reshape(suns.shape[0], -1)
    return score.min(axis=1), score.argmin(axis=1) + (turbidities.start or 0)


def position_scores(rad: np.ndarray, usable: np.ndarray, clipped: np.ndarray, suns: np.ndarray) -> np.ndarray:
    """(P,) the score of a clear sky with the sun at each of ``suns`` (P, 3) against the work maps averaged to
    SEARCH_ROWS (lower fits better, inf where no sky is seen): the landscape ``search_sun`` walks, for pictures."""
    return _position_scores(*_coarse(rad, usable, clipped, SEARCH_ROWS), suns, load_sky_table())[0]


def search_sun(rad: np.ndarray, usable: np.ndarray, clipped: np.ndarray,
               max_contrast: float | None = HIDDEN_MAX_CONTRAST) -> SunSearch | NoSun:
    """Locate a sun from the sky alone: the position whose clear sky best fits the visible sky (a coarse grid
    over the whole sky at SEARCH_ROWS, refined at REFINE_ROWS within 1.5 coarse steps of the best, over the
    coarse best turbidity and its neighbours), fitted there on the whole work map. rad (h, 2h, 3) linear work
    map (clip units), usable / clipped (h, 2h) bool as ``fit_clear_sky`` takes them. ``SunSearch.found`` says
    whether to trust it. ``NoSun``, saying why, when less than HIDDEN_MIN_SKY_SR of sky is seen, when no sky is
    seen at all, or (``max_contrast``; a study passes None to see every fit) when no position is singled out: the
    answer ``found`` would give, sooner."""
    table = load_sky_table()
    if max_contrast is not None:
        visible = _visible_sky_sr(rad, usable)
        if visible < HIDDEN_MIN_SKY_SR:
            return NoSun(_too_little_sky(visible))
    suns = sun_candidates(SEARCH_STEP_DEG)
    scores, turbidity = _position_scores(*_coarse(rad, usable, clipped, SEARCH_ROWS), suns, table)
    finite = np.isfinite(scores)
    if not finite.any():
        return NoSun(NO_SKY)
    i = int(np.argmin(scores))
    contrast = float(scores[i] / max(float(np.median(scores[finite])), 1e-12))
    if max_contrast is not None and contrast > max_contrast:
        return NoSun(_no_position_stands_out(contrast, max_contrast))
    best = suns[i]
    close = suns[finite][scores[finite] <= (1.0 + DIRECTION_68_SCORE_MARGIN) * scores[i]]
    fine = sun_candidates(REFINE_STEP_DEG, best, 1.5 * SEARCH_STEP_DEG)
    near = slice(max(int(turbidity[i]) - 1, 0), int(turbidity[i]) + 2)
    fine_scores = _position_scores(*_coarse(rad, usable, clipped, REFINE_ROWS), fine, table, near)[0]
    if np.isfinite(fine_scores).any():
        best = fine[int(np.argmin(fine_scores))]
    fit = fit_clear_sky(rad, usable, clipped, best, table)
    if fit is None:
        return NoSun(NO_SKY)
    spread = float(np.degrees(np.arccos(np.clip(close @ best, -1.0, 1.0))).max())
    return SunSearch(best, fit, contrast, _seen(rad, usable, clipped, best), colour_match(rad, usable, fit, best, table),
                     max(spread, REFINE_STEP_DEG))


def colour_match(rad: np.ndarray, usable: np.ndarray, fit: SkyFit, sun, table: SkyTable | None = None) -> float:
    """The solid-angle weighted correlation (-1..1) of log(blue/red) observed and of the fitted model's, over the
    usable sky cells above MIN_SKY_ELEVATION_DEG within OCCLUDER_LOG of the fitted sky's luminance (its median
    offset): a clear sky is bluer away from the sun and the horizon, a ceiling or a wall does not follow it.
    0 where the model's colour does not vary over those cells."""
    table = table or load_sky_table()
    dirs, omega, _, upper, _, _ = sky_cells(rad, usable, usable)
    cells = usable & upper & (rad.min(axis=-1) > 1e-4)
    if cells.sum() < 16:
        return 0.0
    j = int(np.argmin(abs(table.turbidities - fit.turbidity)))
    model = table.sky_radiance(dirs[cells], np.asarray(sun, dtype=np.float64), j)[0]
    obs = rad[cells]
    log_ratio = np.log(obs @ LUMINANCE_WEIGHTS) - np.log(np.maximum(model @ LUMINANCE_WEIGHTS, 1e-30))
    keep = log_ratio - np.median(log_ratio) > OCCLUDER_LOG
    o = np.log(obs[keep, 2] / obs[keep, 0])
    m = np.log(np.maximum(model[keep, 2], 1e-30) / np.maximum(model[keep, 0], 1e-30))
    wt = omega[cells][keep]
    do, dm = o - (o * wt).sum() / wt.sum(), m - (m * wt).sum() / wt.sum()
    norm = math.sqrt(float((do ** 2 * wt).sum() * (dm ** 2 * wt).sum()))
    return float((do * dm * wt).sum() / norm) if norm > 0 else 0.0


def _seen(rad, usable, clipped, sun) -> bool:
    """Whether the cells within SUN_PATCH_DEG of ``sun`` show sky: any clipped, or a mean luminance at least
    the median of the usable sky above MIN_SKY_ELEVATION_DEG (an occluder in front of the sun is darker)."""
    dirs, _, lum, upper, _, _ = sky_cells(rad, usable, clipped)
    near = dirs @ np.asarray(sun, dtype=np.float64) >= math.cos(math.radians(max(SUN_PATCH_DEG, 90.0 / usable.shape[0])))
    if (near & clipped).any():
        return True
    sky = usable & upper
    if not (near & usable).any() or not sky.any():
        return False
    return float(lum[near & usable].mean()) >= float(np.median(lum[sky]))
