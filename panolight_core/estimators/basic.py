"""The plain estimators (``ambient``, ``naive``, ``analytic``) and ``Estimate``, what every estimator returns: SH
radiance coefficients (K, 3) float64, Blender world frame; LDR results in the camera's clip units (1 = white), HDR
results in the file's units."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .. import sh
from ..camera import linear
from .highlights import recover_highlights

ANALYTIC_WORK_HEIGHT = 64  # rows of the analytic estimator's work map (the per-source one's is highlights.WORK_HEIGHT,
# 128); 64 and 128 score alike on synthetic scenes (training/synth/evaluate.py)


@dataclass
class Estimate:
    """An estimate: coefficients (K, 3) float64 radiance SH, the estimator and what it found.

    radiance: the linear equirect map the coefficients are the projection of (the input itself for HDR,
    the recovered work map for the analytic LDR path), less the explicit ``lights`` the estimator found
    itself (the per-source estimator's key lights); the adaptive model fits the rest to it.
    """

    coeffs: np.ndarray
    estimator: str
    info: dict = field(default_factory=dict)
    radiance: np.ndarray | None = None
    recovery: object | None = None  # sources.Recovery for the per-source estimator (hdr.exr is made from it)
    lights: list = field(default_factory=list)  # explicit key lights (lighting-file dicts) not in ``radiance``
    light_exclusions: list = field(default_factory=list)  # (direction, radius rad): no second light there

    @property
    def lmax(self) -> int:
        return sh.lmax_from_count(self.coeffs.shape[0])


def ambient(pixels: np.ndarray, lmax: int) -> Estimate:
    lin = linear(pixels)
    c = sh.project(lin, lmax).astype(np.float64)
    c[1:] = 0.0
    flat = np.broadcast_to(c[0] / np.sqrt(4.0 * np.pi), lin.shape)
    return Estimate(c, "ambient", radiance=flat)


def naive(pixels: np.ndarray, lmax: int) -> Estimate:
    lin = linear(pixels)
    return Estimate(sh.project(lin, lmax).astype(np.float64), "naive", radiance=lin)


def _exact_hdr(pixels: np.ndarray, lmax: int, name: str) -> Estimate:
    """HDR input needs no recovery: its exact projection."""
    return Estimate(sh.project(pixels, lmax).astype(np.float64), name, {"input": "hdr"}, pixels)


def analytic(pixels: np.ndarray, lmax: int) -> Estimate:
    if pixels.dtype != np.uint8:
        return _exact_hdr(pixels, lmax, "analytic")
    work = max(ANALYTIC_WORK_HEIGHT, 4 * (lmax + 1))
    recovered, blobs = recover_highlights(pixels, work)
    return Estimate(sh.project(recovered, lmax), "analytic",
                    {"input": "ldr", "work_height": work, "clipped_regions": blobs}, recovered)
