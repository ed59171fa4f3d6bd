"""Spherical-harmonic engine: real orthonormal basis without Condon-Shortley phase, Blender world
frame (Z up), coefficient index k = l*l + l + m, arrays (..., K, C). numpy in -> numpy out,
torch in -> torch out (differentiable). See ../shared/CONVENTIONS.md for the frame and basis.
"""
from .basis import basis
from .convert import filament_sh_txt, from_paper, to_filament, to_paper, to_threejs, to_unity
from .grid import elevation_deg, pixel_directions, pixel_solid_angles, row_solid_angles
from .indexing import degrees_orders, lmax_from_count, num_coeffs
from .irradiance import convolve_lambert, irradiance, irradiance_matrix, irradiance_rh, lambert_kernel
from .nonnegative import emitter_map, nonnegative
from .rotation import rotate, rotate_z, rotation_matrices
from .transform import project, reconstruct
from .window import auto_window_width, min_over_grid, window, window_weights

__all__ = [
    "basis", "project", "reconstruct", "irradiance", "irradiance_rh", "irradiance_matrix",
    "irradiance_map", "convolve_lambert", "lambert_kernel", "window", "window_weights",
    "auto_window_width", "min_over_grid", "rotate", "rotate_z", "rotation_matrices", "num_coeffs",
    "lmax_from_count", "degrees_orders", "elevation_deg", "pixel_directions", "pixel_solid_angles", "row_solid_angles",
    "emitter_map", "nonnegative", "to_paper", "from_paper", "to_threejs", "to_unity", "to_filament", "filament_sh_txt",
]


def irradiance_map(coeffs, height: int, width: int):
    """(..., H, W, C) irradiance at every pixel's direction (normal = view direction)."""
    return reconstruct(convolve_lambert(coeffs), height, width)
