"""Property-based checks of the SH identities (hypothesis draws the coefficients, orders and rotations)."""
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from panolight_core import sh

orders = st.integers(min_value=0, max_value=6)
seeds = st.integers(min_value=0, max_value=2 ** 31 - 1)


def _coeffs(lmax, seed):
    return np.random.default_rng(seed).normal(size=((lmax + 1) ** 2, 3))


def _rotation(seed):
    q, r = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    q = q @ np.diag(np.sign(np.diag(r)))
    return q if np.linalg.det(q) > 0 else -q


@settings(max_examples=25, deadline=None)
@given(orders, seeds, seeds)
def test_rotation_keeps_every_band_power_and_inverts(lmax, seed, rseed):
    c, rot = _coeffs(lmax, seed), _rotation(rseed)
    turned = sh.rotate(c, rot)
    for l in range(lmax + 1):
        band = slice(l * l, (l + 1) ** 2)
        np.testing.assert_allclose((turned[band] ** 2).sum(0), (c[band] ** 2).sum(0), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(sh.rotate(turned, rot.T), c, atol=1e-9)


@settings(max_examples=25, deadline=None)
@given(orders, seeds, seeds)
def test_rotation_commutes_with_evaluation_and_with_the_lambert_convolution(lmax, seed, rseed):
    c, rot = _coeffs(lmax, seed), _rotation(rseed)
    d = np.random.default_rng(rseed + 1).normal(size=(16, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    # new(d) = old(R^T d)
    np.testing.assert_allclose(sh.basis(d, lmax) @ sh.rotate(c, rot), sh.basis(d @ rot, lmax) @ c, atol=1e-9)
    np.testing.assert_allclose(sh.irradiance(sh.rotate(c, rot), d), sh.irradiance(c, d @ rot), atol=1e-9)


@settings(max_examples=15, deadline=None)
@given(orders, seeds)
def test_projection_of_a_reconstruction_gives_the_coefficients_back(lmax, seed):
    c = _coeffs(lmax, seed)
    h = 4 * (lmax + 2)  # Fejer's rule is exact for band-limited maps with H, W > 2 lmax
    np.testing.assert_allclose(sh.project(sh.reconstruct(c, h, 2 * h), lmax, weights="quadrature"), c, atol=1e-9)
