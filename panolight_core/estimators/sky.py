"""A physical clear sky: Hosek-Wilkie sky and solar radiance from one atmosphere, tabulated from Mitsuba
3.9's ``sunsky`` emitter (``training/keylight/sky_table.py``) into ``models/sky.safetensors`` and read with numpy alone.

``fit_clear_sky`` fits the model to the unclipped sky of a linear work map (camera units: 1 = the clip
level) with the sun at a given direction: a scale and a turbidity. Because the sky and the sun come from
one atmosphere, the fitted scale gives the sun's energy in the same camera units (``SkyFit.sun_energy``):
what an 8-bit photo's clipped sun cannot show, weighed from the sky it does show. Directions are unit
vectors in the Blender world frame (Z up).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property, lru_cache
from pathlib import Path

import numpy as np

from .. import sh
from ..camera.color import LUMINANCE_WEIGHTS
from ..errors import PanoLightError

MODEL_PATH = Path(__file__).resolve().parents[1] / "models" / "sky.safetensors"
MIN_SKY_ELEVATION_DEG = 3.0  # sky pixels used in the fit: above this elevation (the horizon is mostly occluded)
OCCLUDER_LOG = -0.7  # a pixel this far (natural log) below the fitted sky is an occluder (tree, building, cloud shadow)
CLEAR_RMS = 0.35  # the cloudiness gate: a fit whose sky residual is above this (natural log RMS) is not a clear sky
MIN_SKY_SR = 0.3  # ... nor one resting on less visible sky than this (sr)
MIN_BLUENESS = 0.85  # ... nor one whose kept sky is redder than this times the model's blue/red: a grey room, a
# night sky under sodium light (docs/keylight.md: 25 of 26 real suns' skies at 0.96 or bluer, the other a lamp at
# night; grey studios, a chapel and night skies at 0.41-0.82)
# The sun search (``search_sun``: a sun hidden, veiled or retouched out, located from the sky alone)
SEARCH_ROWS, REFINE_ROWS = 16, 32  # rows of the coarse search's map (11 degree cells) and of its refinement's
SEARCH_STEP_DEG, REFINE_STEP_DEG = 7.5, 2.5  # the candidate suns' spacing (elevation; azimuth at the horizon x 1.5)
HIDDEN_MIN_SKY_SR = 1.5  # a sun found from the sky alone rests on at least this much visible sky (sr), a quarter
# of the upper hemisphere: small patches of sky between buildings fit a sun anywhere (docs/keylight.md)
HIDDEN_MAX_CONTRAST = 0.65  # ... and on a sky that singles its position out: the best position's score at most this
# share of the median position's (an overcast, grey or night sky fits every position nearly alike)
HIDDEN_MIN_ELEVATION_DEG = 5.0  # ... above this elevation (a sky at the horizon is mostly occluded or hazy)
HIDDEN_MIN_COLOUR_MATCH = 0.0  # ... and whose colour varies as a clear sky's does: the correlation of log(blue/red)
# observed and modelled over the sky is positive (bluer away from the sun and the horizon). A white ceiling with
# a window passed every other test at ev -2 with -0.27; the real suns' skies found with their sun hidden: 0.31-0.94
# but one (-0.24), docs/keylight.md
SUN_PATCH_DEG = 3.0  # the cells around a found sun that tell whether it is seen (sky) or behind an occluder
CONTRAST_RANGE = (0.5, 2.5)  # a sky that fails the gate through sRGB is fitted again through a tone curve: log
# observed = s + g log model, g in this range (a camera's S-curve steepens the sky's falloff, a tone-mapped look
# flattens it), and passes when that fit's residual does with g inside the range (a grey studio's walls ask
# for g held at 0.5)


@dataclass(frozen=True)
class SkyTable:
    """sky (E, T, NTHETA, NPHI, 3) RGB radiance at view zenith theta (0..90 degrees) and azimuth from the sun
    phi (0..180 degrees) for sun elevations ``elevations`` and turbidities ``turbidities``; sun (E, T, 3)
    the solar disk's RGB energy (radiance x sr), in Mitsuba's units."""

    sky: np.ndarray
    sun: np.ndarray
    elevations: np.ndarray
    turbidities: np.ndarray

    @staticmethod
    def _bracket(grid: np.ndarray, v: float):
        v = float(np.clip(v, grid[0], grid[-1]))
        i = int(np.clip(np.searchsorted(grid, v) - 1, 0, grid.size - 2))
        return i, (v - grid[i]) / (grid[i + 1] - grid[i])

    def _at_elevation(self, table: np.ndarray, elevation_deg: float) -> np.ndarray:
        i, f = self._bracket(self.elevations, elevation_deg)
        return (1.0 - f) * table[i] + f * table[i + 1]

    @cached_property
    def sky_luminance_table(self) -> np.ndarray:
        """(E, T, NTHETA, NPHI) the sky table's luminance (bilinear interpolation commutes with it)."""
        return self.sky @ LUMINANCE_WEIGHTS

    def _interpolate(self, table: np.ndarray, dirs: np.ndarray, sun: np.ndarray, turbidity: int | None = None
                     ) -> np.ndarray:
        """(T, N, ...) ``table`` (E, T, NTHETA, NPHI, ...) at unit directions ``dirs`` (N, 3) with the sun at
        unit ``sun`` (3,): linear in elevation, bilinear in (view zenith, azimuth from the sun); 0 below the
        horizon. ``turbidity``: one table index only (T = 1)."""
        sun = np.asarray(sun, dtype=np.float64)
        elev = math.degrees(math.asin(float(np.clip(sun[2], -1.0, 1.0))))
        if turbidity is not None:
            table = table[:, turbidity:turbidity + 1]
        tab = self._at_elevation(table, elev)  # (T, NTHETA, NPHI, ...)
        nt, nph = tab.shape[1:3]
        # rows = table cells, so each corner is one contiguous gather of (N, T x channels)
        rows = np.ascontiguousarray(np.moveaxis(tab.reshape(tab.shape[0], nt * nph, -1), 0, 1)).reshape(nt * nph, -1)
        d = np.asarray(dirs, dtype=np.float64)
        x0, y0, fx, fy = _table_coordinates(d, sun[None], nt, nph)
        x0, y0, fx, fy = x0[0], y0[0], fx[0][:, None], fy[0][:, None]
        i00 = x0 * nph + y0
        out = ((1 - fx) * (1 - fy) * rows[i00] + fx * (1 - fy) * rows[i00 + nph]
               + (1 - fx) * fy * rows[i00 + 1] + fx * fy * rows[i00 + nph + 1])
        out = np.where((d[:, 2] > 0)[:, None], out, 0.0)
        return np.moveaxis(out.reshape(d.shape[0], tab.shape[0], *tab.shape[3:]), 1, 0)

    def sky_radiance(self, dirs: np.ndarray, sun: np.ndarray, turbidity: int | None = None) -> np.ndarray:
        """(T, N, 3) sky radiance for every table turbidity (or the one index ``turbidity``: T = 1) at unit
        directions ``dirs`` (N, 3) with the sun at unit ``sun`` (3,); 0 below the horizon."""
        return self._interpolate(self.sky, dirs, sun, turbidity)

    def sky_luminance(self, dirs: np.ndarray, sun: np.ndarray, turbidity: int | None = None) -> np.ndarray:
        """(T, N) the sky's luminance (``sky_radiance`` @ LUMINANCE_WEIGHTS, a third of the work)."""
        return self._interpolate(self.sky_luminance_table, dirs, sun, turbidity)

    def sky_luminance_suns(self, dirs: np.ndarray, suns: np.ndarray, turbidities: slice = slice(None)) -> np.ndarray:
        """(P, T, N) the sky's luminance at unit directions ``dirs`` (N, 3) for each of P sun positions
        ``suns`` (P, 3) (above the horizon) and every table turbidity (or those ``turbidities`` picks); 0 below
        the horizon. One gather for all of them: the sun search's P x T candidate skies."""
        suns = np.asarray(suns, dtype=np.float64)
        table = self.sky_luminance_table[:, turbidities]
        # the table at each distinct elevation once (the candidates lie on rings of equal elevation)
        heights, ring = np.unique(suns[:, 2], return_inverse=True)
        tab = np.stack([self._at_elevation(table, math.degrees(math.asin(float(np.clip(z, -1.0, 1.0)))))
                        for z in heights])  # (U, T, NT, NPH)
        u, nt_, nt, nph = tab.shape
        rows = np.ascontiguousarray(np.moveaxis(tab, 1, 3)).reshape(u * nt * nph, nt_)  # one row per table cell
        d = np.asarray(dirs, dtype=np.float64)
        x0, y0, fx, fy = _table_coordinates(d, suns, nt, nph)  # (P, N)
        i00 = (ring.reshape(-1)[:, None] * nt + x0) * nph + y0
        out = ((1 - fx) * (1 - fy))[..., None] * rows[i00] + (fx * (1 - fy))[..., None] * rows[i00 + nph] \
            + ((1 - fx) * fy)[..., None] * rows[i00 + 1] + (fx * fy)[..., None] * rows[i00 + nph + 1]
        out = np.where((d[:, 2] > 0)[None, :, None], out, 0.0)  # (P, N, T)
        return np.moveaxis(out, 2, 1)

    def sun_energy(self, elevation_deg: float) -> np.ndarray:
        """(T, 3) the solar disk's RGB energy at this elevation for every table turbidity."""
        return self._at_elevation(self.sun, elevation_deg)


def _table_coordinates(dirs: np.ndarray, suns: np.ndarray, nt: int, nph: int):
    """Table cell (x0, y0) and fractions (fx, fy), each (P, N), of unit view directions ``dirs`` (N, 3) with
    the sun at each of ``suns`` (P, 3): x over view zenith 0..90 degrees (nt rows), y over the azimuth from
    the sun 0..180 degrees (nph columns)."""
    theta = np.degrees(np.arccos(np.clip(dirs[:, 2], -1.0, 1.0)))
    phi = np.degrees(np.abs(np.arctan2(dirs[:, 1], dirs[:, 0])[None, :] - np.arctan2(suns[:, 1], suns[:, 0])[:, None]))
    phi = np.where(phi > 180.0, 360.0 - phi, phi)
    x = np.broadcast_to(np.clip(theta / 90.0 * (nt - 1), 0.0, nt - 1 - 1e-9), phi.shape)
    y = np.clip(phi / 180.0 * (nph - 1), 0.0, nph - 1 - 1e-9)
    x0, y0 = x.astype(int), y.astype(int)
    return x0, y0, x - x0, y - y0


@lru_cache(maxsize=2)
def load_sky_table(path=MODEL_PATH) -> SkyTable:
    """The tabulated clear sky in ``path`` (safetensors, no pickle); PanoLightError naming the file."""
    from .nn.safetensors_np import load_shipped

    path = Path(path)
    t, _ = load_shipped(path, "clear-sky table")
    try:
        table = SkyTable(t["sky"].astype(np.float64), t["sun"].astype(np.float64),
                         t["elevations"].astype(np.float64), t["turbidities"].astype(np.float64))
    except KeyError as exc:
        raise PanoLightError(f"{path}: not a PanoLight clear-sky table (missing tensor {exc.args[0]})") from None
    e, n = table.elevations.size, table.turbidities.size
    if table.sky.ndim != 5 or table.sky.shape[:2] != (e, n) or table.sun.shape != (e, n, 3):
        raise PanoLightError(f"{path}: clear-sky table tensors have inconsistent shapes")
    return table


@dataclass(frozen=True)
class SkyFit:
    """A clear-sky fit: scale (camera units per Mitsuba unit: the fitted sky's energy over the model's, the
    per-pixel scale when ``contrast`` is 1), turbidity, the sky residual's RMS (natural log, over the sky
    pixels kept), the solid angle of sky it rests on (sr), the sun's RGB energy in camera
    units (radiance x sr, in the model's colour: re-balancing it by the sky's observed colour made five
    real suns' colours worse, docs/keylight.md) and the kept sky's blue/red over the model's (blueness)."""

    scale: float
    turbidity: float
    rms: float
    sky_sr: float
    sun_rgb: np.ndarray
    blueness: float = 1.0
    contrast: float = 1.0  # g of log observed = s + g log model: 1 for the sRGB curve, else the tone curve's

    @property
    def luminance_clear(self) -> bool:
        """The cloudiness gate's luminance tests alone: a small residual on enough visible sky."""
        return self.rms <= CLEAR_RMS and self.sky_sr >= MIN_SKY_SR

    @property
    def clear(self) -> bool:
        """Whether the sky is clear enough to trust the fit (the cloudiness gate): its luminance tests, and a
        sky blue enough to be one."""
        return self.luminance_clear and self.blueness >= MIN_BLUENESS

    @property
    def sun_energy(self) -> float:
        """The sun's luminance energy in camera units (luminance x sr)."""
        return float(self.sun_rgb @ LUMINANCE_WEIGHTS)


def fit_clear_sky(rad: np.ndarray, usable: np.ndarray, clipped: np.ndarray, sun, table: SkyTable | None = None
                  ) -> SkyFit | None:
    """Fit the clear sky to a linear work map ``rad`` (h, 2h, 3) with the sun at unit ``sun``.

    usable (h, w) bool: cells whose value is measured (no channel clipped); clipped (h, w) bool: cells
    clipped in every channel, which the fitted sky must reach (a censored observation: its radiance is at
    least the clip level). For each table turbidity the scale is the solid-angle weighted mean log ratio
    of the sky cells above MIN_SKY_ELEVATION_DEG, after dropping occluders (cells more than OCCLUDER_LOG
    below the sky); the turbidity of lowest residual (plus the clipped cells' shortfall) wins. The kept
    cells' colour then tests that they are a sky at all: a clear sky is blue, and a dim grey room or a night
    under sodium lamps can match its luminance falloff but not its blue/red. None when the sun is below the
    horizon or no sky is visible."""
    table = table or load_sky_table()
    sun = np.asarray(sun, dtype=np.float64)
    if sun[2] <= 0:
        return None
    h, w = usable.shape
    dirs = sh.pixel_directions(h, w)
    omega = sh.pixel_solid_angles(h, w)
    upper = dirs[..., 2] > math.sin(math.radians(MIN_SKY_ELEVATION_DEG))
    lum = rad @ LUMINANCE_WEIGHTS
    obs = upper & usable & (lum > 1e-4)
    cen = upper & clipped
    if obs.sum() < 16:
        return None
    d_obs, d_cen = dirs[obs], dirs[cen]
    w_obs, w_cen = omega[obs], omega[cen]
    log_obs = np.log(lum[obs])
    model = table.sky_luminance(np.concatenate([d_obs, d_cen]), sun)  # (T, N)
    log_model = np.log(np.maximum(model, 1e-12))
    lm_obs, lm_cen = log_model[:, :obs.sum()], log_model[:, obs.sum():]
    fit = _fit_turbidities(log_obs, lm_obs, lm_cen, w_obs, w_cen, contrast=False)
    if fit is not None and fit[3] > CLEAR_RMS:  # not a clear sky as sRGB would show it: through a tone curve?
        curved = _fit_turbidities(log_obs, lm_obs, lm_cen, w_obs, w_cen, contrast=True)
        # a slope held at either bound is no camera's curve: the model does not describe this light
        if curved is not None and curved[3] <= CLEAR_RMS and CONTRAST_RANGE[0] < curved[2] < CONTRAST_RANGE[1]:
            fit = curved
    if fit is None:
        return None
    j, s, g, rms, sky_sr, keep = fit
    elev = math.degrees(math.asin(float(sun[2])))
    if g == 1.0:
        ratio = math.exp(s)
    else:  # the sun keeps its share of the sky's energy: sun / sky of the model, times the fitted sky here
        m = table.sky_luminance(dirs[upper], sun, j)[0]
        ratio = float((np.exp(s) * m ** g * omega[upper]).sum() / (m * omega[upper]).sum())
    sun_rgb = ratio * table.sun_energy(elev)[j]
    blueness = _blueness(rad[obs][keep], table.sky_radiance(d_obs[keep], sun, j)[0], w_obs[keep])
    return SkyFit(ratio, float(table.turbidities[j]), rms, sky_sr, sun_rgb, blueness, g)


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

    @property
    def elevation_deg(self) -> float:
        return math.degrees(math.asin(float(np.clip(self.direction[2], -1.0, 1.0))))

    @property
    def found(self) -> bool:
        """A sun the sky shows: a clear fit (the cloudiness gate, its colour test included) on at least
        HIDDEN_MIN_SKY_SR of sky whose colour varies as the model's (HIDDEN_MIN_COLOUR_MATCH), a position the
        sky singles out (HIDDEN_MAX_CONTRAST), above HIDDEN_MIN_ELEVATION_DEG."""
        return (self.fit.clear and self.fit.sky_sr >= HIDDEN_MIN_SKY_SR and self.contrast <= HIDDEN_MAX_CONTRAST
                and self.elevation_deg >= HIDDEN_MIN_ELEVATION_DEG and self.colour_match > HIDDEN_MIN_COLOUR_MATCH)


def sun_candidates(step_deg: float, centre=None, reach_deg: float | None = None) -> np.ndarray:
    """(P, 3) unit sun positions above the horizon, ``step_deg`` apart in elevation (from step / 2) and about
    1.5 x that in azimuth at the horizon (wider apart toward the zenith); with ``centre`` (3,) only those
    within ``reach_deg`` of it, on a grid centred there."""
    if centre is None:
        elevations = np.arange(step_deg / 2.0, 90.0, step_deg)
        azimuth0 = 0.0
    else:
        c = np.asarray(centre, dtype=np.float64)
        e0 = math.degrees(math.asin(float(np.clip(c[2], -1.0, 1.0))))
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


def _visible_sky_sr(usable: np.ndarray) -> float:
    """The solid angle (sr) of usable cells above MIN_SKY_ELEVATION_DEG: the most sky any fit can rest on."""
    h, w = usable.shape
    upper = sh.pixel_directions(h, w)[..., 2] > math.sin(math.radians(MIN_SKY_ELEVATION_DEG))
    return float(sh.pixel_solid_angles(h, w)[upper & usable].sum())


def _position_scores(rad, usable, clipped, suns, table: SkyTable, turbidities: slice = slice(None)):
    """((P,) each candidate sun's best score over the table's turbidities (``_fit_rows``, the sRGB curve;
    inf where no sky is seen), (P,) the index of that turbidity)."""
    h, w = usable.shape
    dirs = sh.pixel_directions(h, w)
    omega = sh.pixel_solid_angles(h, w)
    upper = dirs[..., 2] > math.sin(math.radians(MIN_SKY_ELEVATION_DEG))
    lum = rad @ LUMINANCE_WEIGHTS
    obs = upper & usable & (lum > 1e-4)
    cen = upper & clipped
    if obs.sum() < 16 or suns.shape[0] == 0:
        return np.full(suns.shape[0], np.inf), np.zeros(suns.shape[0], int)
    n_obs = int(obs.sum())
    model = table.sky_luminance_suns(np.concatenate([dirs[obs], dirs[cen]]), suns, turbidities)  # (P, T, N)
    lm = np.log(np.maximum(model, 1e-12)).reshape(-1, model.shape[-1])
    score = _fit_rows(np.log(lum[obs]), lm[:, :n_obs], lm[:, n_obs:], omega[obs], omega[cen], contrast=False)[-1]
    score = score.reshape(suns.shape[0], -1)
    return score.min(axis=1), score.argmin(axis=1) + (turbidities.start or 0)


def search_sun(rad: np.ndarray, usable: np.ndarray, clipped: np.ndarray, table: SkyTable | None = None,
               max_contrast: float | None = HIDDEN_MAX_CONTRAST) -> SunSearch | None:
    """Locate a sun from the sky alone: the position whose clear sky best fits the visible sky (a coarse grid
    over the whole sky at SEARCH_ROWS, refined at REFINE_ROWS within 1.5 coarse steps of the best, over the
    coarse best turbidity and its neighbours), fitted there on the whole work map. rad (h, 2h, 3) linear work
    map (clip units), usable / clipped (h, 2h) bool as ``fit_clear_sky`` takes them. ``SunSearch.found`` says
    whether to trust it. None when less than HIDDEN_MIN_SKY_SR of sky is seen, or (``max_contrast``, a study
    passes None to see every fit) when no position is singled out: the answer ``found`` would give, sooner."""
    table = table or load_sky_table()
    coarse = _coarse(rad, usable, clipped, SEARCH_ROWS)
    if max_contrast is not None and _visible_sky_sr(usable) < HIDDEN_MIN_SKY_SR:
        return None
    suns = sun_candidates(SEARCH_STEP_DEG)
    scores, turbidity = _position_scores(*coarse, suns, table)
    finite = np.isfinite(scores)
    if not finite.any():
        return None
    i = int(np.argmin(scores))
    contrast = float(scores[i] / max(float(np.median(scores[finite])), 1e-12))
    if max_contrast is not None and contrast > max_contrast:
        return None
    best = suns[i]
    fine = sun_candidates(REFINE_STEP_DEG, best, 1.5 * SEARCH_STEP_DEG)
    near = slice(max(int(turbidity[i]) - 1, 0), int(turbidity[i]) + 2)
    fine_scores = _position_scores(*_coarse(rad, usable, clipped, REFINE_ROWS), fine, table, near)[0]
    if np.isfinite(fine_scores).any():
        best = fine[int(np.argmin(fine_scores))]
    fit = fit_clear_sky(rad, usable, clipped, best, table)
    if fit is None:
        return None
    return SunSearch(best, fit, contrast, _seen(rad, usable, clipped, best), colour_match(rad, usable, fit, best, table))


def colour_match(rad: np.ndarray, usable: np.ndarray, fit: SkyFit, sun, table: SkyTable | None = None) -> float:
    """The solid-angle weighted correlation (-1..1) of log(blue/red) observed and of the fitted model's, over the
    usable sky cells above MIN_SKY_ELEVATION_DEG within OCCLUDER_LOG of the fitted sky's luminance (its median
    offset): a clear sky is bluer away from the sun and the horizon, a ceiling or a wall does not follow it.
    0 where the model's colour does not vary over those cells."""
    table = table or load_sky_table()
    h, w = usable.shape
    dirs = sh.pixel_directions(h, w)
    cells = usable & (dirs[..., 2] > math.sin(math.radians(MIN_SKY_ELEVATION_DEG))) & (rad.min(axis=-1) > 1e-4)
    if cells.sum() < 16:
        return 0.0
    j = int(np.argmin(abs(table.turbidities - fit.turbidity)))
    model = table.sky_radiance(dirs[cells], np.asarray(sun, dtype=np.float64), j)[0]
    obs = rad[cells]
    log_ratio = np.log(obs @ LUMINANCE_WEIGHTS) - np.log(np.maximum(model @ LUMINANCE_WEIGHTS, 1e-30))
    keep = log_ratio - np.median(log_ratio) > OCCLUDER_LOG
    o = np.log(obs[keep, 2] / obs[keep, 0])
    m = np.log(np.maximum(model[keep, 2], 1e-30) / np.maximum(model[keep, 0], 1e-30))
    wt = sh.pixel_solid_angles(h, w)[cells][keep]
    do, dm = o - (o * wt).sum() / wt.sum(), m - (m * wt).sum() / wt.sum()
    norm = math.sqrt(float((do ** 2 * wt).sum() * (dm ** 2 * wt).sum()))
    return float((do * dm * wt).sum() / norm) if norm > 0 else 0.0


def _seen(rad, usable, clipped, sun) -> bool:
    """Whether the cells within SUN_PATCH_DEG of ``sun`` show sky: any clipped, or a mean luminance at least
    the median of the usable sky above MIN_SKY_ELEVATION_DEG (an occluder in front of the sun is darker)."""
    h, w = usable.shape
    dirs = sh.pixel_directions(h, w)
    near = dirs @ np.asarray(sun, dtype=np.float64) >= math.cos(math.radians(max(SUN_PATCH_DEG, 90.0 / h)))
    if (near & clipped).any():
        return True
    lum = rad @ LUMINANCE_WEIGHTS
    sky = usable & (dirs[..., 2] > math.sin(math.radians(MIN_SKY_ELEVATION_DEG)))
    if not (near & usable).any() or not sky.any():
        return False
    return float(lum[near & usable].mean()) >= float(np.median(lum[sky]))


def _fit_turbidities(log_obs, lm_obs, lm_cen, w_obs, w_cen, contrast: bool):
    """The best turbidity's fit of log sky luminance (``_fit_rows`` over the table's turbidities, lm_obs (T, N)).
    Returns (turbidity index, s, g, rms, sky solid angle, kept cells (N,) bool) or None when no cell is kept."""
    s_all, g_all, rms_all, sky_sr_all, keep, score = _fit_rows(log_obs, lm_obs, lm_cen, w_obs, w_cen, contrast)
    if not np.isfinite(score).any():
        return None
    j = int(np.argmin(score))  # the first of equal scores, as the turbidities ascend
    return j, float(s_all[j]), float(g_all[j]), float(rms_all[j]), float(sky_sr_all[j]), keep[j]


def _fit_rows(log_obs, lm_obs, lm_cen, w_obs, w_cen, contrast: bool):
    """Fits of log sky luminance, one per candidate sky: log_obs (N,) observed at cells of solid angle w_obs
    (N,), lm_obs (R, N) each candidate model's log luminance there (a turbidity, or a sun position and a
    turbidity), lm_cen (R, M) at the clipped cells (solid angles w_cen (M,)), which the fit must reach. The
    fit is log_obs = s + g lm_obs with g = 1 (a camera with the sRGB curve) or, with ``contrast``, g in
    CONTRAST_RANGE (a tone curve's contrast), on the sky cells left after dropping occluders (OCCLUDER_LOG
    below the fit, three passes: the sky is the upper envelope). Score: the residual's RMS plus the clipped
    cells' shortfall. Returns per candidate (R,): s, g, rms, kept solid angle, kept cells (R, N) bool and
    the score (inf where no cell is kept)."""
    keep = np.ones(lm_obs.shape, bool)

    def line(keep):  # (R,) offset s and slope g over the kept cells (nan where none is kept)
        wk = np.where(keep, w_obs[None, :], 0.0)
        with np.errstate(invalid="ignore", divide="ignore"):
            if not contrast:
                return ((log_obs[None, :] - lm_obs) * wk).sum(axis=1) / wk.sum(axis=1), np.ones(lm_obs.shape[0])
            mx, my = (lm_obs * wk).sum(axis=1) / wk.sum(axis=1), (log_obs[None, :] * wk).sum(axis=1) / wk.sum(axis=1)
            dx = lm_obs - mx[:, None]
            g = np.clip((wk * dx * (log_obs[None, :] - my[:, None])).sum(axis=1) / (wk * dx ** 2).sum(axis=1),
                        *CONTRAST_RANGE)
            return my - g * mx, g

    def residual(s, g):  # (R, N) log observed less the fitted line (g = 1 exactly: the plain difference)
        return log_obs[None, :] - g[:, None] * lm_obs - s[:, None]

    for _ in range(3):  # a row once empty stays empty (nan compares False)
        keep = residual(*line(keep)) > OCCLUDER_LOG
    s_all, g_all = line(keep)
    wk = np.where(keep, w_obs[None, :], 0.0)
    sky_sr_all = wk.sum(axis=1)
    res = residual(s_all, g_all)
    rms_all = np.sqrt((res ** 2 * wk).sum(axis=1) / np.where(sky_sr_all > 0, sky_sr_all, 1.0))
    short = np.zeros_like(rms_all)
    if lm_cen.shape[1]:  # clipped sky the model leaves below the clip level
        gap = np.minimum(g_all[:, None] * lm_cen + s_all[:, None], 0.0)
        short = np.sqrt((gap ** 2 * w_cen[None, :]).sum(axis=1) / w_cen.sum())
    score = np.where(keep.any(axis=1), rms_all + short, np.inf)
    return s_all, g_all, rms_all, sky_sr_all, keep, score


def _blueness(observed: np.ndarray, model: np.ndarray, weights: np.ndarray) -> float:
    """(B/R of the observed cells (n, 3)) over (B/R of the model's (n, 3)), both weighted by solid angle (n,)."""
    o = (observed * weights[:, None]).sum(0)
    m = (model * weights[:, None]).sum(0)
    if o[0] <= 0 or m[0] <= 0 or m[2] <= 0:
        return 0.0
    return float((o[2] / o[0]) / (m[2] / m[0]))
