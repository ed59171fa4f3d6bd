"""Converters at the edges: other SH conventions and engine formats.

Our coefficients: real orthonormal basis without Condon-Shortley (CS) phase, Blender world frame
(Z up, right-handed), (K, 3) linear Rec.709 RGB. Each converter states the definition it targets;
the tests evaluate that definition independently and compare radiance at random directions.
"""
from __future__ import annotations

import numpy as np

from .indexing import degrees_orders, lmax_from_count
from .irradiance import lambert_kernel
from .rotation import rotate

# Engine frames as matrices A with d_engine = A @ d_blender.
THREEJS_FROM_BLENDER = np.array([[1.0, 0, 0], [0, 0, 1.0], [0, -1.0, 0]])  # Y up, right-handed (glTF)
FILAMENT_FROM_BLENDER = THREEJS_FROM_BLENDER  # Y up, right-handed (OpenGL)
UNITY_FROM_BLENDER = np.array([[1.0, 0, 0], [0, 0, 1.0], [0, 1.0, 0]])  # Y up, left-handed: swap Y and Z

def _as_coeffs(coeffs) -> np.ndarray:
    c = np.asarray(coeffs, dtype=np.float64)
    if c.ndim != 2:
        raise ValueError(f"coefficients must have shape (K, C), got {c.shape}")
    lmax_from_count(c.shape[0])
    return c


def _to_lmax(c: np.ndarray, lmax: int) -> np.ndarray:
    """Truncate or zero-pad (K, C) coefficients to order ``lmax``."""
    k = (lmax + 1) ** 2
    out = np.zeros((k, c.shape[1]))
    n = min(k, c.shape[0])
    out[:n] = c[:n]
    return out


def cs_phase(lmax: int) -> np.ndarray:
    """(K,) factors (-1)^m for m != 0 relating a CS-phase real basis to ours (an involution)."""
    _, m = degrees_orders(lmax)
    return np.where(m % 2 == 1, -1.0, 1.0)


def mirror_x_signs(lmax: int) -> np.ndarray:
    """(K,) signs s with Y_k(-x, y, z) = s_k Y_k(x, y, z) (phi -> pi - phi)."""
    _, m = degrees_orders(lmax)
    am = np.abs(m)
    return np.where(m >= 0, (-1.0) ** am, (-1.0) ** (am + 1))


def to_paper(coeffs) -> np.ndarray:
    """Ours -> the paper's reference code: x mirrored (x_paper = -x), CS phase, BGR channel order.

    The paper's pixel-centre offset is a sampling difference, not a coefficient transform: project its
    images with our grid. The transform is its own inverse up to the channel flip.
    """
    c = _as_coeffs(coeffs)
    lmax = lmax_from_count(c.shape[0])
    return (c * (cs_phase(lmax) * mirror_x_signs(lmax))[:, None])[:, ::-1].copy()


def from_paper(coeffs) -> np.ndarray:
    """The paper's convention (see ``to_paper``) -> ours."""
    c = _as_coeffs(coeffs)[:, ::-1]
    lmax = lmax_from_count(c.shape[0])
    return c * (cs_phase(lmax) * mirror_x_signs(lmax))[:, None]


def to_threejs(coeffs) -> list[list[float]]:
    """three.js ``SphericalHarmonics3.coefficients``: 9 [r, g, b] radiance coefficients.

    Definition: radiance(d3) = sum_k c_k Y_k(d3) with three's basis (same constants, no CS phase),
    d3 = (x, z, -y) of the Blender direction (Y up). Orders above 2 are dropped, missing ones are 0.
    Load with ``new SphericalHarmonics3().fromArray(flat)`` on the flattened list.
    """
    c = rotate(_to_lmax(_as_coeffs(coeffs), 2), THREEJS_FROM_BLENDER)
    return c.tolist()


def to_unity(coeffs) -> list[list[float]]:
    """Unity ``SphericalHarmonicsL2`` as 3 rows (R, G, B) of 9 coefficients, sh[channel, k].

    Definition (Unity manual, Light Probes technical information): Sloan's basis, i.e. ours with the
    CS phase (odd m negated), same order L00, L1-1, L10, L11, L2-2, L2-1, L20, L21, L22, radiance
    coefficients, Unity frame d_u = UNITY_FROM_BLENDER @ d_blender (Y and Z swapped; left-handed, Y up).
    """
    c = rotate(_to_lmax(_as_coeffs(coeffs), 2), UNITY_FROM_BLENDER) * cs_phase(2)[:, None]
    return c.T.tolist()


def to_filament(coeffs) -> np.ndarray:
    """Filament ``IndirectLight::Builder::irradiance(3, sh)`` values, (9, 3).

    Definition (Filament's shader): E(n) / pi = sum_k sh[k] * poly_k(n_f), poly = [1, y, z, x, yx, yz,
    3z^2 - 1, zx, x^2 - y^2] in Filament's frame n_f = (x, z, -y) of Blender's. So sh[k] = A_l c_k K_k / pi:
    irradiance convolution, Lambert 1/pi and the basis constants folded in (as cmgen --no-mirror writes).
    """
    c = rotate(_to_lmax(_as_coeffs(coeffs), 2), FILAMENT_FROM_BLENDER)
    l, _ = degrees_orders(2)
    exact_k = np.array([0.5 / np.sqrt(np.pi), np.sqrt(3 / (4 * np.pi)), np.sqrt(3 / (4 * np.pi)),
                        np.sqrt(3 / (4 * np.pi)), 0.5 * np.sqrt(15 / np.pi), 0.5 * np.sqrt(15 / np.pi),
                        0.25 * np.sqrt(5 / np.pi), 0.5 * np.sqrt(15 / np.pi), 0.25 * np.sqrt(15 / np.pi)])
    return c * (lambert_kernel(2)[l] * exact_k / np.pi)[:, None]


def filament_sh_txt(coeffs) -> str:
    """Text in cmgen's ``sh.txt`` layout: one ``(r, g, b); // Llm`` line per coefficient."""
    names = ["L00", "L1-1", "L10", "L11", "L2-2", "L2-1", "L20", "L21", "L22"]
    rows = to_filament(coeffs)
    return "".join(f"({r: .8f}, {g: .8f}, {b: .8f}); // {n}, irradiance, pre-scaled base\n"
                   for (r, g, b), n in zip(rows, names))
