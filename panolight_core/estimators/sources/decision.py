"""Which energy to report per region: the one of least expected error under the metric itself, among those that
harm no truth within the prediction's 68 % range.

m-RMSE punishes an over-estimate without bound and an under-estimate at most by the source's energy: for a
dominant source the error is |r_hat / r - 1|, smallest in expectation at log r_hat = mu - sigma^2 when
log r ~ N(mu, sigma^2). The metric's median scaling adds more (a bright enough estimate drags the median of
an lmax-2 map to zero), so ``choose_shrink`` decides per scene under the metric itself:
log r_hat = max(mu - c sigma^2, 0) with the c of lowest expected error over truths drawn from the
predictive distribution. Never below 1: clipping only hides light.

Being wrong is priced too (issue 58, docs/studies/do_no_harm.md): the expected error alone took choices that harm a
scene (EVALUATION.md's "Harm": over 2x and + 0.25 the plain map's m-RMSE) when its truth lay at the low end of the
prediction's 68 % range, as clipped clouds' do. A choice is kept only where no truth of the range (every region at
mu - sigma, mu and mu + sigma together: a scene's regions err together) makes it harm; of those, the least
expected error; and never a bolder choice than the expected error's own.
"""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from ... import sh
from ...harm import harmed
from .regions import Regions

SHRINK_CANDIDATES = (0.0, 0.25, 0.5, 1.0, 1.5, 2.0, 3.0, math.inf)  # inf: keep every region at its clip level
DECISION_SAMPLES = 64
DECISION_CORRELATION = 0.5  # how much of a region's error is shared by the scene (one exposure, one camera)
DECISION_TOLERANCE = 0.05
MIN_MEDIAN_RATIO = 0.1
_DECISION_GRID = (32, 64)


def shrunk(mu: np.ndarray, sigma: np.ndarray, c: float) -> np.ndarray:
    """(n,) the log ratios reported for shrink c: max(mu - c sigma^2, 0); c = inf keeps every region at its
    clip level (0)."""
    return np.zeros_like(mu) if math.isinf(c) else np.maximum(mu - c * sigma ** 2, 0.0)


@lru_cache(maxsize=4)
def _grid_basis(h: int, w: int) -> np.ndarray:
    """(h w, 9) real SH of bands 0-2 at an (h, 2h) grid's pixel centres (the work map's, the decision's):
    made once per size, read-only."""
    y = sh.basis(sh.pixel_directions(h, w).reshape(-1, 3), 2)
    y.setflags(write=False)
    return y


def _map_medians(c: np.ndarray, y: np.ndarray) -> np.ndarray:
    """(X,) the median over pixels and channels of each of X maps with SH coefficients c (X, 9, 3) on a grid
    of basis y (N, 9), taken in place in the maps (np.median's copy would cost twice the product)."""
    maps = np.matmul(y, c)
    return np.median(maps.reshape(maps.shape[0], -1), axis=1, overwrite_input=True)


def _weighted_errors(qc: np.ndarray, gc: np.ndarray, y: np.ndarray, w: np.ndarray) -> np.ndarray:
    """EVALUATION.md's median-scaled relative RMSE for every (candidate, sample) pair.

    qc (C, 9, 3) and gc (S, 9, 3) SH coefficients, y (N, 9) their basis on a grid with weights w (N,) summing
    to 1 -> (C, S). Only the medians need the maps; the weighted products are taken in coefficient space
    through the grid's Gram matrix y^T diag(w) y (9, 9)."""
    med_q, med_g = _map_medians(qc, y), _map_medians(gc, y)
    scale = np.where(med_q[:, None] > 0, med_g[None, :] / np.where(med_q > 0, med_q, 1.0)[:, None], 1.0)
    gram = y.T @ (y * w[:, None])
    qq = np.einsum("cik,ij,cjk->c", qc, gram, qc) / 3.0
    gg = np.einsum("sik,ij,sjk->s", gc, gram, gc) / 3.0
    qg = np.einsum("cik,ij,sjk->cs", qc, gram, gc) / 3.0
    num = np.sqrt(np.maximum(scale ** 2 * qq[:, None] - 2.0 * scale * qg + gg[None, :], 0.0))
    den = np.einsum("i,sik->s", w @ y, gc) / 3.0
    return num / np.where(np.abs(den) > 0, den, np.inf)[None, :]


def decision_errors(base: np.ndarray, regions: Regions, cand_lr: np.ndarray, true_lr: np.ndarray):
    """(err (2, C, S), healthy (C,)): EVALUATION.md's m-RMSE and irr-RMSE at lmax 2 of each of C candidate reports
    against each of S truths, both (X, n) log ratios of the n ``regions`` over the plain linearised work map
    ``base`` (each region's excess spread as ``fill_regions`` spreads it, white), taken on the decision's grid; and
    whether each candidate's lmax-2 map keeps a median of at least MIN_MEDIAN_RATIO of its mean (one whose source
    rings the rest of the sphere down makes the metric's median scale explode for any truth that does not share
    it). The last candidate is taken as healthy (the plain map, in ``choose_shrink``)."""
    from ...sh.irradiance import convolve_lambert

    n = regions.count
    h, w = regions.labels.shape
    y = _grid_basis(h, w)  # (h w, 9)
    m = (regions.labels >= 0).ravel()
    lab = regions.labels.ravel()[m]
    # SH of each region's fill per unit excess energy (white), as fill_regions spreads it
    wt = regions.share.ravel()[m]
    unit = np.stack([np.bincount(lab, wt * y[m, k], n) for k in range(9)], -1)  # (n, 9) per unit excess energy
    b = sh.project(base, 2)  # (9, 3)

    def coeffs(lr):  # (X, n) log ratios -> (X, 9, 3)
        excess = (np.exp(lr) - 1.0) * regions.held[None, :]
        return b[None] + (excess @ unit)[:, :, None] * np.ones(3)

    gh, gw = _DECISION_GRID
    grid_y = _grid_basis(gh, gw)
    wgrid = sh.pixel_solid_angles(gh, gw).ravel() / (4.0 * math.pi)
    qc, gc = coeffs(cand_lr), coeffs(true_lr)
    err = np.stack([_weighted_errors(qc, gc, grid_y, wgrid),
                    _weighted_errors(convolve_lambert(qc), convolve_lambert(gc), grid_y, wgrid)])
    med = _map_medians(qc, grid_y)
    mean = np.einsum("i,cik->c", wgrid @ grid_y, qc) / 3.0
    healthy = med >= MIN_MEDIAN_RATIO * np.maximum(mean, 1e-300)
    healthy[-1] = True
    return err, healthy


def choose_shrink(base: np.ndarray, regions: Regions, mu: np.ndarray, sigma: np.ndarray, seed: int = 0,
                  tolerance: float | None = None):
    """Pick c in SHRINK_CANDIDATES so that log r_i = max(mu_i - c sigma_i^2, 0) minimises the expected
    m-RMSE + irr-RMSE at lmax 2 when the truth is drawn from the model's own predictive distribution
    (log r_i = mu_i + sigma_i z_i, z correlated DECISION_CORRELATION across the scene's regions).

    The metric's median scaling makes over-estimates dangerous beyond the simple |r_hat/r - 1| argument
    (a bright enough source drags the median of an lmax-2 map to zero): deciding under the metric
    itself weighs that too. Of the candidates within ``tolerance`` (default DECISION_TOLERANCE, relative)
    of the lowest expected error the most conservative is taken, skipping candidates whose lmax-2 map
    has a median below MIN_MEDIAN_RATIO of its mean; and where that one could harm a truth of the 68 % range
    (``harmless``), the same choice among those that could not, if it is more conservative. base: the plain
    linearised work map.
    Returns (c, expected errors per c)."""
    tolerance = DECISION_TOLERANCE if tolerance is None else tolerance
    n = regions.count
    if n == 0:
        return 0.0, {}
    rng = np.random.default_rng(seed)
    z0 = rng.standard_normal((DECISION_SAMPLES, 1))
    z = DECISION_CORRELATION * z0 + math.sqrt(1 - DECISION_CORRELATION ** 2) * rng.standard_normal((DECISION_SAMPLES, n))
    true_lr = np.maximum(mu[None, :] + sigma[None, :] * z, 0.0)
    cand_lr = np.stack([shrunk(mu, sigma, c) for c in SHRINK_CANDIDATES])
    range_lr = np.stack([np.maximum(mu + z * sigma, 0.0) for z in HARM_RANGE_Z])  # the 68 % range's truths
    err, healthy = decision_errors(base, regions, cand_lr, np.concatenate([true_lr, range_lr]))
    expected = err[:, :, :DECISION_SAMPLES].sum(axis=0).mean(axis=1)

    def least(allowed):  # the least energy whose expected error is within ``tolerance`` of the best allowed: near-ties
        pool = np.where(allowed, expected, np.inf)  # go to the side where a wrong answer costs least
        return int(np.flatnonzero(pool <= pool.min() * (1.0 + tolerance) + 1e-12).max())

    best = max(least(healthy), least(healthy & harmless(err[0][:, DECISION_SAMPLES:])))
    return SHRINK_CANDIDATES[best], {("none" if math.isinf(c) else f"{c:g}"): round(float(e), 6)
                                     for c, e in zip(SHRINK_CANDIDATES, expected)}


HARM_RANGE_Z = (-1.0, 0.0, 1.0)  # the truths a choice must not harm: the 68 % range's ends and middle


def harmless(m: np.ndarray) -> np.ndarray:
    """(C,) whether each candidate harms (``harm.harmed``: m-RMSE over 2x and + 0.25 the plain map's, the last
    candidate's) none of the truths of the prediction's 68 % range, given their m-RMSE ``m`` (C, Z): every region at
    mu + z sigma (z in HARM_RANGE_Z) together, as ``choose_shrink`` scores them; the last candidate (the plain map)
    always."""
    ok = np.array([not any(harmed(m[i, j], m[-1, j]) for j in range(m.shape[1])) for i in range(m.shape[0])])
    ok[-1] = True
    return ok
