import math
import tracemalloc

import numpy as np
import pytest
import torch

from panolight_core import sh
from panolight_core.sh import transform
from tests.panolight_core.sh.reference import cell_integral


@pytest.mark.parametrize("lmax", [0, 1, 2, 8, 9, 20, 30])
def test_orthonormal_round_trip_float64(rng, lmax):
    c = rng.normal(size=((lmax + 1) ** 2, 3))
    h = 2 * lmax + 2
    back = sh.project(sh.reconstruct(c, h, 2 * h), lmax, weights="quadrature")
    np.testing.assert_allclose(back, c, atol=1e-9, rtol=0)


@pytest.mark.parametrize("lmax", [2, 8, 20, 30])
def test_orthonormal_round_trip_float32(rng, lmax):
    c = rng.normal(size=((lmax + 1) ** 2, 3)).astype(np.float32)
    h = 2 * lmax + 2
    back = sh.project(sh.reconstruct(c, h, 2 * h), lmax, weights="quadrature")
    assert back.dtype == np.float32
    np.testing.assert_allclose(back, c, atol=1e-4, rtol=0)


@pytest.mark.parametrize("size,weights", [((1, 2), "cell"), ((2, 4), "cell"), ((3, 6), "cell"), ((16, 32), "cell"),
                                          ((512, 1024), "cell"), ((3, 6), "quadrature"), ((512, 1024), "quadrature")])
def test_constant_white_map(size, weights):
    """Exact at any size for cell weights; quadrature is exact once H > lmax."""
    h, w = size
    c = sh.project(np.ones((h, w, 3)), 4 if h > 4 else 2, weights=weights)
    np.testing.assert_allclose(c[0], math.sqrt(4 * math.pi), rtol=1e-12)
    assert np.abs(c[1:]).max() < 1e-6
    e = sh.irradiance_map(c, 8, 16)
    np.testing.assert_allclose(e, math.pi, rtol=1e-6)


@pytest.mark.parametrize("lmax", [0, 2, 8, 9, 20])
def test_tiny_images_give_finite_results(rng, lmax):
    for h in (1, 2):
        img = rng.random((h, 2 * h, 3))
        c = sh.project(img, lmax)
        assert c.shape == ((lmax + 1) ** 2, 3) and np.all(np.isfinite(c))
        np.testing.assert_allclose(c[0], img.reshape(-1, 3).T @ sh.pixel_solid_angles(h, 2 * h).ravel()
                                   / math.sqrt(4 * math.pi), rtol=1e-12)
        assert np.all(np.isfinite(sh.reconstruct(c, h, 2 * h)))


def test_centre_weights_leak_into_l20_as_conventions_warns():
    """The plain solid-angle weighting of centre samples is O(1/H^2) off; the cell projection is exact."""
    c_centre = sh.project(np.ones((8, 16, 3)), 2, weights="centre")
    assert c_centre[6, 0] > 1e-2
    assert abs(sh.project(np.ones((8, 16, 3)), 2)[6, 0]) < 1e-13


@pytest.mark.parametrize("row", [32, 3, 0])  # equator, near the pole, the pole row
def test_sun_pixel_against_independent_reference(row):
    h, w, x = 64, 128, 37
    img = np.full((h, w, 3), 1e-3)
    img[row, x] = [1e5, 5e4, 2e4]
    lmax = 2
    ref = np.zeros((9, 3))
    ref[0] = 1e-3 * math.sqrt(4 * math.pi)
    k = 0
    for l in range(lmax + 1):
        for m in range(-l, l + 1):
            ref[k] += (img[row, x] - 1e-3) * cell_integral(l, m, row, x, h, w)
            k += 1
    got = sh.project(img, lmax)
    scale = np.abs(ref).max(axis=0)
    assert np.all(np.abs(got - ref) <= 1e-6 * scale)
    got32 = sh.project(img.astype(np.float32), lmax)
    assert np.all(np.abs(got32 - ref) <= 1e-4 * scale)


@pytest.mark.parametrize("lmax", [2, 9])  # one per contraction order
def test_matches_naive_per_pixel_sum(rng, lmax):
    h, w = 24, 48
    img = rng.random((h, w, 3))
    basis = sh.basis(sh.pixel_directions(h, w), lmax)
    naive = np.einsum("hwk,hwc,hw->kc", basis, img, sh.pixel_solid_angles(h, w))
    np.testing.assert_allclose(sh.project(img, lmax, weights="centre"), naive, atol=1e-12)
    c = rng.normal(size=((lmax + 1) ** 2, 3))
    np.testing.assert_allclose(sh.reconstruct(c, h, w), basis @ c, atol=1e-12)


def test_both_contraction_orders_agree(rng, monkeypatch):
    img = rng.random((2, 20, 40, 3))
    c = rng.normal(size=(2, 36, 3))
    a, ra = sh.project(img, 5), sh.reconstruct(c, 20, 40)
    monkeypatch.setattr(transform, "ROWS_FIRST_MAX_LMAX", -1)
    np.testing.assert_allclose(sh.project(img, 5), a, atol=1e-13)
    np.testing.assert_allclose(sh.reconstruct(c, 20, 40), ra, atol=1e-13)


def test_batched_equals_per_item(rng):
    img = rng.random((3, 2, 8, 16, 3))
    c = sh.project(img, 3)
    assert c.shape == (3, 2, 16, 3)
    np.testing.assert_allclose(c[1, 1], sh.project(img[1, 1], 3), atol=1e-14)
    rec = sh.reconstruct(c, 8, 16)
    assert rec.shape == (3, 2, 8, 16, 3)
    np.testing.assert_allclose(rec[2, 0], sh.reconstruct(c[2, 0], 8, 16), atol=1e-14)


def test_torch_matches_numpy_and_keeps_dtype(rng):
    img = rng.random((16, 32, 3))
    for dtype in (torch.float32, torch.float64):
        t = torch.tensor(img, dtype=dtype)
        c = sh.project(t, 4)
        assert isinstance(c, torch.Tensor) and c.dtype == dtype
        np.testing.assert_allclose(c.numpy(), sh.project(img, 4), atol=1e-5 if dtype == torch.float32 else 1e-13)
        assert sh.reconstruct(c, 8, 16).dtype == dtype


def test_gradcheck_project_reconstruct(rng):
    img = torch.tensor(rng.random((4, 8, 3)), requires_grad=True)
    assert torch.autograd.gradcheck(lambda x: sh.project(x, 2), (img,))
    c = torch.tensor(rng.normal(size=(9, 3)), requires_grad=True)
    assert torch.autograd.gradcheck(lambda x: sh.reconstruct(x, 4, 8), (c,))
    img10 = torch.tensor(rng.random((10, 20, 3)), requires_grad=True)
    assert torch.autograd.gradcheck(lambda x: sh.project(x, 9), (img10,))  # columns-first path


def test_large_image_bounded_memory():
    h, w = 4096, 8192
    img = np.full((h, w, 3), 0.5, dtype=np.float32)  # 400 MB
    tracemalloc.start()
    c = sh.project(img, 2)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert peak < 64 * 2 ** 20, f"projection allocated {peak / 2 ** 20:.0f} MB for a 400 MB input"
    np.testing.assert_allclose(c[0], 0.5 * math.sqrt(4 * math.pi), rtol=1e-5)
    assert np.abs(c[1:]).max() < 1e-4


def test_bad_inputs():
    with pytest.raises(ValueError, match="shape"):
        sh.project(np.zeros((4, 8)), 2)
    with pytest.raises(ValueError, match="empty"):
        sh.project(np.zeros((0, 8, 3)), 2)
    with pytest.raises(ValueError, match=r"\(lmax\+1\)\^2"):
        sh.reconstruct(np.zeros((8, 3)), 4, 8)
    with pytest.raises(ValueError, match="height"):
        sh.reconstruct(np.zeros((9, 3)), 0, 8)
    with pytest.raises(ValueError, match="weights"):
        sh.project(np.zeros((4, 8, 3)), 2, weights="uniform")
    with pytest.raises(ValueError, match="numeric"):
        sh.project(np.full((4, 8, 3), "a"), 2)
