"""Explicit lights: compact, very bright sources taken out of an environment map.

A source is a connected region (seam- and pole-aware) of pixels brighter than PEAK_RATIO times the
map's median luminance, no wider than MAX_RADIUS_DEG, carrying at least MIN_ENERGY_FRACTION of the
map's energy. Each becomes a light with
  direction  where its light comes from, for rendering (Blender world frame, unit vector): for a sun the
             peak direction below, for an area light the luminance-weighted centroid of its region
             (the right place for its irradiance when the region is wide),
  peak_direction  where the source peaks: the luminance-weighted centroid of its full-resolution pixels
             at or above half its peak (EVALUATION.md's dominant-light rule, applied per source),
  intensity  its luminance energy above the local background, sum (L - L_bg) x solid angle: the
             irradiance it gives a surface facing it (input radiance units x sr),
  color      that energy's RGB divided by its luminance (luminance 1),
  angle      its angular diameter in radians, 2 sqrt(2) x the RMS angle of its energy around the
             direction (exact for a uniform disk; a source smaller than a pixel reports about a pixel),
  type       "sun" (a directional light) up to SUN_MAX_DIAMETER_DEG, else "area".
A source becomes a light only when it adds at least MIN_IRRADIANCE_SHARE (5 %: a just-visible shadow
contrast) to the irradiance of a surface facing it, relative to the map's mean irradiance (total
energy / 4); weaker ones stay in the SH part.
The region is then filled with the local background (the median of a ring around it), so the lights
plus the remaining map hold exactly the original energy. Everything runs on an area-averaged copy of
WORK_HEIGHT rows, so a 16k panorama costs its averaging and no more.
"""
from __future__ import annotations

import math

import numpy as np

from .. import sh
from ..camera.color import LUMINANCE_WEIGHTS
from ..camera.resample import area_downsample
from ..packed import PackedImage
from ..sh.blobs import component_at

PEAK_RATIO = 50.0
MAX_RADIUS_DEG = 10.0
MIN_IRRADIANCE_SHARE = 0.05
SUN_MAX_DIAMETER_DEG = 5.0
MAX_LIGHTS = 4
WORK_HEIGHT = 256  # rows of the map lights are found on (0.7-degree cells)


def light_irradiance(lights, normals: np.ndarray) -> np.ndarray:
    """(..., 3) irradiance of directional lights at unit ``normals`` (..., 3): sum I c max(0, n . d)."""
    n = np.asarray(normals, dtype=np.float64)
    out = np.zeros(n.shape[:-1] + (3,))
    for light in lights:
        d = np.asarray(light["direction"], dtype=np.float64)
        out += np.maximum(n @ d, 0.0)[..., None] * (light["intensity"] * np.asarray(light["color"]))
    return out


def _peak_direction(full: np.ndarray, core: np.ndarray) -> np.ndarray | None:
    """Luminance-weighted centroid of the full-resolution pixels under ``core`` (a work-resolution mask)
    that are at or above half their peak luminance; None if the resolutions do not nest."""
    fh, fw = full.shape[:2]
    h, w = core.shape
    if fh % h or fw % w or fh < h:
        return None
    fy, fx = fh // h, fw // w
    ys, xs = np.nonzero(core)
    rows = (ys[:, None] * fy + np.arange(fy)[None, :]).ravel()
    cols = (xs[:, None] * fx + np.arange(fx)[None, :]).ravel()
    r_idx = np.repeat(ys * fy, fy * fx) + np.tile(np.repeat(np.arange(fy), fx), ys.size)
    c_idx = np.repeat(xs * fx, fy * fx) + np.tile(np.tile(np.arange(fx), fy), xs.size)
    del rows, cols
    lum = np.asarray(full[r_idx, c_idx], dtype=np.float64) @ LUMINANCE_WEIGHTS
    peak = lum.max()
    if not peak > 0:
        return None
    keep = lum >= 0.5 * peak
    d = (sh.grid.directions_at(r_idx[keep], c_idx[keep], fh, fw) * lum[keep][:, None]).sum(axis=0)
    n = np.linalg.norm(d)
    return d / n if n > 0 else None


def _energy_bound(energy: np.ndarray | None, cells: np.ndarray) -> float:
    """The most luminance energy (radiance x sr) a light taken from ``cells`` (h, w) bool can carry: their
    own, ``energy`` (h, w) being the map's luminance x solid angle with no negative value (a light is its
    cells' excess over a non-negative background); inf where ``energy`` is None (a map with negatives)."""
    return math.inf if energy is None else float(energy[cells].sum())


def extract_lights(radiance: np.ndarray, max_lights: int = MAX_LIGHTS, threshold: float | None = None, exclude=()):
    """Split a linear (H, W, 3) equirect map into lights and a residual map.

    Sources are found brightest first: from the brightest unused pixel above PEAK_RATIO x the median
    luminance, the connected region around it is taken at a threshold that starts there and rises by
    sqrt(10) until the region holding the peak is at most MAX_RADIUS_DEG wide (a sun inside bright
    sky keeps its core; the sky stays in the map). Returns (lights, residual, info): lights as
    lighting-file dicts (brightest first), residual the (WORK_HEIGHT, 2 WORK_HEIGHT, 3) float64 map
    without them, info with the map's luminance energy (radiance x sr), the fraction of it in lights and,
    when none was taken, the reason.
    threshold: the luminance a candidate must exceed, instead of PEAK_RATIO x the median (for an LDR's
    recovered map: the clip level, since clipped regions are exactly where its sources are).
    exclude: (unit direction, angular radius in radians) pairs where no light is taken (a source an
    estimator already made a light of: one light per physical source).
    """
    full = radiance if isinstance(radiance, PackedImage) else np.asarray(radiance)
    rad = area_downsample(full, WORK_HEIGHT)
    if not np.all(np.isfinite(rad)):
        raise ValueError("the radiance map contains NaN or Inf")
    h, w = rad.shape[:2]
    omega = sh.pixel_solid_angles(h, w)
    dirs = sh.pixel_directions(h, w)
    lum = rad @ LUMINANCE_WEIGHTS
    total = float((lum * omega).sum())
    info = {"energy_fraction_in_lights": 0.0, "map_energy": total}
    if total <= 0:
        info["reason"] = "the map is black: there is no light to extract"
        return [], rad, info
    median = float(np.median(lum))
    base = threshold if threshold is not None else (PEAK_RATIO * median if median > 0 else 0.0)
    max_radius = math.radians(MAX_RADIUS_DEG)
    used = np.zeros((h, w), dtype=bool)
    for d, radius in exclude:
        used |= dirs @ np.asarray(d, dtype=np.float64) >= math.cos(radius)
    need = MIN_IRRADIANCE_SHARE * total / 4.0  # the energy a light must carry (share x mean irradiance)
    # a region that cannot carry it, or all that is left, is passed over unweighed: the same lights and
    # residual as weighing it, without its threshold search
    energy = lum * omega if float(rad.min()) >= 0.0 else None
    lights, residual, reasons, weak, rest = [], rad.copy(), [], [], None
    for _ in range(4 * max(max_lights, 0)):
        if len(lights) == max_lights:
            break
        avail = (lum > base) & ~used
        if not avail.any():
            break
        left = _energy_bound(energy, avail)
        if left < need * (1.0 - 1e-9):
            rest = left / (total / 4.0)
            break
        y, x = np.unravel_index(np.argmax(np.where(avail, lum, -np.inf)), lum.shape)
        peak = float(lum[y, x])
        region = component_at(avail, y, x)
        bound = _energy_bound(energy, region)
        if bound < need * (1.0 - 1e-9):
            weak.append(bound / (total / 4.0))
            used |= region
            continue
        core, tau, area = _compact_core(avail, region, lum, omega, (y, x), base, max_radius)
        radius = math.sqrt(area / math.pi)
        wl = lum * omega * core
        centre = (dirs * wl[..., None]).sum(axis=(0, 1))
        centre /= np.linalg.norm(centre)
        peak_dir = _peak_direction(full, core)
        peak_dir = centre if peak_dir is None else peak_dir
        ang = np.arccos(np.clip(dirs @ centre, -1.0, 1.0))
        ring = (~core) & (ang > radius) & (ang < 3.0 * radius + 2 * math.pi / w)
        bg = np.median(rad[ring], axis=0) if ring.sum() >= 3 else np.zeros(3)
        excess = np.clip(rad[core] - bg[None, :], 0.0, None)
        e_rgb = (excess * omega[core][:, None]).sum(axis=0)
        intensity = float(e_rgb @ LUMINANCE_WEIGHTS)
        share = intensity / (total / 4.0)  # its irradiance over the mean irradiance
        if share < MIN_IRRADIANCE_SHARE:
            if tau >= peak:
                r0 = math.degrees(math.sqrt(float((omega * region).sum()) / math.pi))
                reasons.append(f"a bright region of {r0:.0f} degrees radius is flat: it has no compact peak")
            else:
                reasons.append(f"a bright source adds only {share:.1%} to the irradiance facing it "
                               f"(a light needs {MIN_IRRADIANCE_SHARE:.0%})")
            used |= region  # a plateau or a weak source: look elsewhere
            continue
        used |= core  # the rest of its region may hold another source
        ex_l = (excess @ LUMINANCE_WEIGHTS) * omega[core]
        rms = math.sqrt(float((ex_l * ang[core] ** 2).sum() / ex_l.sum()))
        diameter = min(2.0 * math.sqrt(2.0) * rms, math.pi)
        residual[core] = np.minimum(rad[core], bg[None, :])
        kind = "sun" if math.degrees(diameter) <= SUN_MAX_DIAMETER_DEG else "area"
        lights.append({"type": kind, "direction": (peak_dir if kind == "sun" else centre).tolist(),
                       "peak_direction": peak_dir.tolist(), "color": (e_rgb / intensity).tolist(),
                       "intensity": intensity, "angle": diameter})
    info["energy_fraction_in_lights"] = sum(l["intensity"] for l in lights) / total
    _add_weak_reasons(reasons, weak, rest, MIN_IRRADIANCE_SHARE)
    if not lights:
        info["reason"] = "; ".join(reasons) or (f"no region is brighter than {base:g}" if threshold is not None
                                                else f"no region is brighter than {PEAK_RATIO:g} x the median luminance")
    return lights, residual, info


def _compact_core(avail, region, lum, omega, at: tuple, base: float, max_radius: float):
    """(core, threshold, solid angle) of the source whose peak is pixel ``at`` in its bright ``region``: the region
    at a threshold that starts at ``base`` and rises by sqrt(10) until it is at most ``max_radius`` (radians)
    wide, or the peak pixel alone."""
    y, x = at
    peak = float(lum[y, x])
    tau = base
    while True:
        if tau >= peak:
            core = np.zeros_like(avail)
            core[y, x] = True
        else:  # at the base threshold the core is the region itself
            core = region if tau == base else component_at(avail & (lum > tau), y, x)
        area = float((omega * core).sum())
        if math.sqrt(area / math.pi) <= max_radius or tau >= peak:
            return core, tau, area
        tau = min(peak, max(tau, peak * 1e-6) * math.sqrt(10.0))


def _add_weak_reasons(reasons: list, weak: list, rest: float | None, min_share: float) -> None:
    """Append why the regions passed over unweighed made no light: too weak each (``weak``: their irradiance
    shares), or all that was left together (``rest``)."""
    if weak:
        reasons.append(f"{len(weak)} bright regions add at most {max(weak):.1%} each" if len(weak) > 1 else
                       f"a bright region adds at most {weak[0]:.1%}")
    if rest is not None:
        reasons.append(f"the {'other ' if reasons else ''}bright pixels add at most {rest:.1%} together")
    if weak or rest is not None:
        reasons[-1] += f" (a light needs {min_share:.0%})"


def light_coeffs(lights, lmax: int) -> np.ndarray:
    """(K, 3) SH coefficients of lights taken as uniform disks (EVALUATION.md's whole-model scoring).

    A light of direction d, RGB energy intensity x color (radiance units x sr) and angular diameter a is a
    spherical cap of half-angle a/2 carrying that energy; its zonal band factors are exact:
    L_lm = E f_l Y_lm(d), f_l = (P_(l-1)(c) - P_(l+1)(c)) / ((2l+1)(1-c)), c = cos(a/2), f_0 = 1,
    which tends to 1 for every l as the cap shrinks to a point.
    """
    k = (lmax + 1) ** 2
    out = np.zeros((k, 3))
    if not lights:
        return out
    from ..sh.indexing import degrees_orders

    degrees = degrees_orders(lmax)[0]
    for light in lights:
        d = np.asarray(light["direction"], dtype=np.float64)
        d = d / np.linalg.norm(d)
        c = math.cos(0.5 * float(light.get("angle", 0.0)))
        energy = float(light["intensity"]) * np.asarray(light["color"], dtype=np.float64)
        band = _cap_band_factors(c, lmax)
        out += (np.asarray(sh.basis(d[None], lmax))[0] * band[degrees])[:, None] * energy[None, :]
    return out


def _cap_band_factors(c: float, lmax: int) -> np.ndarray:
    """f_l for l = 0..lmax of a uniform cap with cos(half-angle) = c (1 for a point)."""
    f = np.ones(lmax + 1)
    if 1.0 - c < 1e-10:
        return f
    p = [1.0, c]  # Legendre P_0, P_1 at c, by recurrence
    for n in range(1, lmax + 1):
        p.append(((2 * n + 1) * c * p[n] - n * p[n - 1]) / (n + 1))
    for l in range(1, lmax + 1):
        f[l] = (p[l - 1] - p[l + 1]) / ((2 * l + 1) * (1.0 - c))
    return f


def sun_lamp(light: dict, strength: float = 1.0, rotation: float = 0.0) -> dict:
    """A lighting-file light as a sun lamp's settings (the Blender layer's arithmetic, kept here without bpy):
    direction (3,) unit, where the light comes from, turned with the lighting: a Mapping node whose Z
    rotation is ``rotation`` radians looks the texture up at R v, so the world shows it turned by -rotation,
    and so is the lamp (R direction = the light's direction); colour (3,) scaled to a maximum channel of 1,
    its scale moved into energy = intensity x strength x max(colour) (Blender's sun strength: the light's
    irradiance at normal incidence); angle: the angular diameter, radians."""
    c, s = math.cos(rotation), math.sin(rotation)
    d = np.asarray(light["direction"], dtype=np.float64)
    d = d / max(float(np.linalg.norm(d)), 1e-300)
    color = np.asarray(light["color"], dtype=np.float64)
    top = max(float(color.max()), 1e-12)
    return {"direction": np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1], d[2]]),
            "color": color / top, "energy": float(light["intensity"]) * strength * top,
            "angle": float(light.get("angle", 0.0))}
