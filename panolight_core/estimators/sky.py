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
from ..camera import MID_GREY
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
MIN_CHROMA = 0.01  # a sky whose mean chroma is under this shows no colour (a grey picture): its blueness is 0
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
        elev = sh.elevation_deg(sun)
        if turbidity is not None:
            table = table[:, turbidity:turbidity + 1]
        tab = self._at_elevation(table, elev)  # (T, NTHETA, NPHI, ...)
        nt, nph = tab.shape[1:3]
        # rows = table cells, so each corner is one contiguous gather of (N, T x channels)
        rows = np.ascontiguousarray(np.moveaxis(tab.reshape(tab.shape[0], nt * nph, -1), 0, 1)).reshape(nt * nph, -1)
        d = np.asarray(dirs, dtype=np.float64)
        x0, y0, fx, fy = _table_coordinates(d, sun[None], nt, nph)
        x0, y0, fx, fy = x0[0], y0[0], fx[0][:, None], fy[0][:, None]
        out = _bilinear(rows, x0 * nph + y0, nph, fx, fy)
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
        out = _bilinear(rows, (ring.reshape(-1)[:, None] * nt + x0) * nph + y0, nph, fx[..., None], fy[..., None])
        out = np.where((d[:, 2] > 0)[None, :, None], out, 0.0)  # (P, N, T)
        return np.moveaxis(out, 2, 1)

    def sun_energy(self, elevation_deg: float) -> np.ndarray:
        """(T, 3) the solar disk's RGB energy at this elevation for every table turbidity, in the Rec.709 gamut:
        Mitsuba's RGB of the deep red sun at 0.5-2 degrees has a slightly negative blue (out of gamut; a light's
        colour cannot be), so a negative channel is set to 0 and the rest scaled to keep its luminance."""
        rgb = self._at_elevation(self.sun, elevation_deg)
        inside = np.maximum(rgb, 0.0)
        y, y_inside = rgb @ LUMINANCE_WEIGHTS, inside @ LUMINANCE_WEIGHTS
        return inside * np.where(y_inside > 0, y / np.where(y_inside > 0, y_inside, 1.0), 1.0)[:, None]


def _bilinear(rows: np.ndarray, i00: np.ndarray, nph: int, fx: np.ndarray, fy: np.ndarray) -> np.ndarray:
    """The table ``rows`` (one per table cell, nph cells to a view-zenith row) bilinearly at cell indices ``i00``
    with fractions ``fx`` (along view zenith) and ``fy`` (along azimuth), broadcast against rows[i00]."""
    return ((1 - fx) * (1 - fy) * rows[i00] + fx * (1 - fy) * rows[i00 + nph]
            + (1 - fx) * fy * rows[i00 + 1] + fx * fy * rows[i00 + nph + 1])


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
    from ..io.safetensors_np import load_shipped

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
    """A clear-sky fit: scale (camera units per Mitsuba unit: the sky as the camera's linear sensor saw it,
    before any tone curve ``contrast`` reveals, over the model's; see ``fit_clear_sky``), turbidity, the sky
    residual's RMS (natural log, over the sky pixels kept), the solid angle of sky it rests on (sr), the sun's
    RGB energy in camera units (radiance x sr, in the model's colour: re-balancing it by the sky's observed
    colour made five real suns' colours worse, docs/keylight.md; a key light takes ``keylight.camera_colour`` of
    it, the camera's fixed white point) and the kept sky's blue/red over the model's (blueness)."""

    scale: float
    turbidity: float
    rms: float
    sky_sr: float
    sun_rgb: np.ndarray
    blueness: float = 1.0
    contrast: float = 1.0  # g of log observed = s + g log model: 1 for the sRGB curve, else the tone curve's (about
    # MID_GREY)

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


def sky_cells(rad: np.ndarray, usable: np.ndarray, clipped: np.ndarray):
    """The cells a clear-sky fit rests on, for a work map ``rad`` (h, 2h, 3) and its usable / clipped (h, 2h)
    masks: (directions (h, 2h, 3), solid angles (h, 2h), luminance (h, 2h), upper: above MIN_SKY_ELEVATION_DEG,
    obs: upper, usable and not black (observed), cen: upper and clipped (censored: at least the clip level))."""
    h, w = usable.shape
    dirs = sh.pixel_directions(h, w)
    upper = dirs[..., 2] > math.sin(math.radians(MIN_SKY_ELEVATION_DEG))
    lum = rad @ LUMINANCE_WEIGHTS
    return dirs, sh.pixel_solid_angles(h, w), lum, upper, upper & usable & (lum > 1e-4), upper & clipped


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
    dirs, omega, lum, upper, obs, cen = sky_cells(rad, usable, clipped)
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
    elev = sh.elevation_deg(sun)
    # the sky before the tone curve, in the camera's linear units: a camera's curve keeps mid grey (what its
    # exposure aims at) and steepens about it, observed = MID_GREY (c model / MID_GREY)^g, so log observed =
    # s + g log model gives c = exp((s + (g - 1) log MID_GREY) / g); through sRGB (g = 1) c = exp(s)
    ratio = math.exp((s + (g - 1.0) * math.log(MID_GREY)) / g)
    sun_rgb = ratio * table.sun_energy(elev)[j]
    blueness = _blueness(rad[obs][keep], table.sky_radiance(d_obs[keep], sun, j)[0], w_obs[keep])
    return SkyFit(ratio, float(table.turbidities[j]), rms, sky_sr, sun_rgb, blueness, g)


def _fit_turbidities(log_obs, lm_obs, lm_cen, w_obs, w_cen, contrast: bool):
    """The best turbidity's fit of log sky luminance (``fit_rows`` over the table's turbidities, lm_obs (T, N)).
    Returns (turbidity index, s, g, rms, sky solid angle, kept cells (N,) bool) or None when no cell is kept."""
    s_all, g_all, rms_all, sky_sr_all, keep, score = fit_rows(log_obs, lm_obs, lm_cen, w_obs, w_cen, contrast)
    if not np.isfinite(score).any():
        return None
    j = int(np.argmin(score))  # the first of equal scores, as the turbidities ascend
    return j, float(s_all[j]), float(g_all[j]), float(rms_all[j]), float(sky_sr_all[j]), keep[j]


def fit_rows(log_obs, lm_obs, lm_cen, w_obs, w_cen, contrast: bool):
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
    """(B/R of the observed cells (n, 3)) over (B/R of the model's (n, 3)), both weighted by solid angle (n,);
    0 where the observed sky shows no colour (its mean chroma, (max - min) / max of a cell's channels, under
    MIN_CHROMA: a black-and-white photo), which no clear sky is: a grey picture cannot tell a sky from a grey
    wall, and the gate refuses it."""
    o = (observed * weights[:, None]).sum(0)
    m = (model * weights[:, None]).sum(0)
    if o[0] <= 0 or m[0] <= 0 or m[2] <= 0:
        return 0.0
    top = observed.max(axis=1)
    chroma = np.where(top > 0, (top - observed.min(axis=1)) / np.where(top > 0, top, 1.0), 0.0)
    if float((chroma * weights).sum()) < MIN_CHROMA * float(weights.sum()):
        return 0.0
    return float((o[2] / o[0]) / (m[2] / m[0]))
