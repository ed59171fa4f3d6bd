"""The three-sphere protocol of the published lighting-estimation tables (Weber et al. 2022 and after): a diffuse, a
matte-silver and a mirror sphere, each rendered under an estimate and under the truth, compared by RMSE, scale-
invariant RMSE and RGB angular error (``metrics.sphere_scores``).

The spheres are seen orthographically from +X (CONVENTIONS.md frame: Z up, the panorama's centre +X), SPHERE_SIZE
pixels across; only the disk is compared. Both sides are rendered the same way from an equirect environment at
ENV_HEIGHT rows: the truth's HDR area-averaged there, the estimate's SH radiance with its explicit lights splatted
onto the cells within their angular radius (energy kept). Diffuse: irradiance / pi from the environment's SH at
EXACT_ORDER; matte silver: the environment's SH convolved with a Phong-like lobe (MATTE_EXPONENT) and read at the
mirror direction; mirror: the environment read at the mirror direction (nearest cell).
"""
from __future__ import annotations

import math

import numpy as np

from .. import sh
from ..camera.resample import area_downsample
from ..sh.grid import pixel_coordinates

SPHERE_SIZE = 64
ENV_HEIGHT = 128  # 1.4-degree cells: the mirror sphere's resolution (a 64-pixel sphere resolves about 3 degrees)
EXACT_ORDER = 24  # as metrics.EXACT_ORDER: the diffuse and matte lobes are negligible beyond it
MATTE_EXPONENT = 64.0  # the matte-silver lobe: SH band l weighed exp(-l^2 / (2 x this)), about 7 degrees wide
SPHERES = ("diffuse", "matte", "mirror")


def sphere_geometry(size: int = SPHERE_SIZE) -> tuple[np.ndarray, np.ndarray]:
    """(normals (n, 3), mirror directions (n, 3)) of the disk's pixels (row-major inside an size x size image) of a
    unit sphere seen from +X: image right is +Y, up is +Z."""
    c = (np.arange(size) + 0.5) / size * 2.0 - 1.0
    u, v = np.meshgrid(c, -c)  # u right, v up
    inside = u * u + v * v <= 1.0
    u, v = u[inside], v[inside]
    n = np.stack([np.sqrt(np.maximum(1.0 - u * u - v * v, 0.0)), u, v], axis=-1)
    view = np.array([1.0, 0.0, 0.0])
    r = 2.0 * (n @ view)[:, None] * n - view
    return n, r / np.linalg.norm(r, axis=-1, keepdims=True)


def environment_from_panorama(hdr: np.ndarray) -> np.ndarray:
    """(ENV_HEIGHT, 2 ENV_HEIGHT, 3) float64: the panorama area-averaged onto the protocol's environment grid."""
    return area_downsample(np.asarray(hdr), ENV_HEIGHT).astype(np.float64)


def environment_from_model(coeffs: np.ndarray, lights) -> np.ndarray:
    """(ENV_HEIGHT, 2 ENV_HEIGHT, 3) float64: an estimate's radiance on the protocol's grid: its SH (K, 3) reconstructed,
    and each explicit light's energy (intensity x colour: irradiance at normal incidence) spread evenly over the
    cells within its angular radius (at least the cell holding its direction)."""
    env = sh.reconstruct(np.asarray(coeffs, dtype=np.float64), ENV_HEIGHT, 2 * ENV_HEIGHT).astype(np.float64)
    dirs = sh.pixel_directions(ENV_HEIGHT, 2 * ENV_HEIGHT)
    omega = sh.pixel_solid_angles(ENV_HEIGHT, 2 * ENV_HEIGHT)
    for light in lights:
        d = np.asarray(light["direction"], dtype=np.float64)
        d = d / np.linalg.norm(d)
        cells = dirs @ d >= math.cos(0.5 * float(light.get("angle", 0.0)))
        if not cells.any():
            cells = np.zeros(cells.shape, dtype=bool)
            cells[np.unravel_index(np.argmax(dirs @ d), cells.shape)] = True
        energy = float(light["intensity"]) * np.asarray(light["color"], dtype=np.float64)
        env[cells] += energy / float(omega[cells].sum())
    return env


def render_spheres(env: np.ndarray, size: int = SPHERE_SIZE) -> dict:
    """{"diffuse", "matte", "mirror"}: each (n, 3) float64, the disk pixels' radiance of that sphere lit by the
    environment ``env`` (h, 2h, 3) (``environment_from_panorama`` or ``environment_from_model``)."""
    normals, mirror = sphere_geometry(size)
    coeffs = sh.project(env, EXACT_ORDER).astype(np.float64)
    lobe = np.array([math.exp(-l * l / (2.0 * MATTE_EXPONENT)) for l in range(EXACT_ORDER + 1)])
    per_coeff = np.repeat(lobe, [2 * l + 1 for l in range(EXACT_ORDER + 1)])
    h, w = env.shape[:2]
    rows, cols = pixel_coordinates(mirror, h, w)  # the nearest cell: pixel centres at integers
    row = np.clip(np.floor(rows + 0.5).astype(int), 0, h - 1)
    col = np.floor(cols + 0.5).astype(int) % w
    return {"diffuse": sh.irradiance(coeffs, normals) / math.pi,
            "matte": sh.basis(mirror, EXACT_ORDER) @ (coeffs * per_coeff[:, None]),
            "mirror": env[row, col]}


def model_scores(truth: dict, coeffs, lights, unit: float = 1.0) -> dict:
    """The protocol's scores (``metrics.sphere_scores``) of an estimate, SH ``coeffs`` (K, 3) and explicit ``lights``
    (lighting-file dicts) in units of which ``unit`` is one of the truth's, against the truth's spheres ``truth``
    (``render_spheres`` of ``environment_from_panorama``)."""
    from ..metrics import sphere_scores

    scaled = [dict(light, intensity=float(light["intensity"]) * unit) for light in lights]
    return sphere_scores(truth, render_spheres(environment_from_model(np.asarray(coeffs, dtype=np.float64) * unit,
                                                                       scaled)))


def score_medians(scores: list[dict]) -> dict:
    """Per sphere, the median of each score (rmse, si_rmse, angular_deg) over a list of ``model_scores``; {} for none."""
    return {name: {k: float(np.median([s[name][k] for s in scores])) for k in ("rmse", "si_rmse", "angular_deg")}
            for name in SPHERES} if scores else {}
