import numpy as np
import pytest

from panolight_core import sh
from panolight_core.sh import convert
from tests.conftest import random_directions
from tests.panolight_core.sh.reference import real_sh_scipy


def _radiance(c, d):
    return sh.basis(d, sh.lmax_from_count(c.shape[0])) @ c


def test_paper_convention_against_its_definition(rng):
    """The paper's code: x mirrored, Condon-Shortley phase, BGR. Evaluate its basis with scipy directly."""
    lmax = 4
    c = rng.normal(size=((lmax + 1) ** 2, 3))
    cp = sh.to_paper(c)
    d = random_directions(rng, 40)
    dp = d * [-1, 1, 1]
    theta, phi = np.arccos(dp[:, 2]), np.arctan2(dp[:, 1], dp[:, 0])
    cs_basis = np.stack([real_sh_scipy(l, m, theta, phi) * (-1.0) ** (m % 2)
                         for l in range(lmax + 1) for m in range(-l, l + 1)], -1)
    np.testing.assert_allclose((cs_basis @ cp)[:, ::-1], _radiance(c, d), atol=1e-10)
    np.testing.assert_allclose(sh.from_paper(cp), c, atol=0)


def test_threejs_against_its_shader_definition(rng):
    c = rng.normal(size=(16, 3))  # higher orders are dropped
    c3 = np.array(sh.to_threejs(c))
    d = random_directions(rng, 40)
    x, y, z = (d @ convert.THREEJS_FROM_BLENDER.T).T
    three = np.stack([np.full_like(x, 0.282095), 0.488603 * y, 0.488603 * z, 0.488603 * x, 1.092548 * x * y,
                      1.092548 * y * z, 0.315392 * (3 * z * z - 1), 1.092548 * x * z, 0.546274 * (x * x - y * y)], -1)
    np.testing.assert_allclose(three @ c3, _radiance(c[:9], d), atol=1e-4 * np.abs(c).max())


def test_unity_against_its_definition(rng):
    c = rng.normal(size=(9, 3))
    u = np.array(sh.to_unity(c))
    assert u.shape == (3, 9)
    d = random_directions(rng, 40)
    x, y, z = (d @ convert.UNITY_FROM_BLENDER.T).T
    k = 0.488603
    sloan = np.stack([np.full_like(x, 0.282095), -k * y, k * z, -k * x, 1.092548 * x * y, -1.092548 * y * z,
                      0.315392 * (3 * z * z - 1), -1.092548 * x * z, 0.546274 * (x * x - y * y)], -1)
    np.testing.assert_allclose(sloan @ u.T, _radiance(c, d), atol=1e-5 * np.abs(c).max())


def test_filament_against_its_shader_definition(rng):
    c = rng.normal(size=(9, 3))
    f = sh.to_filament(c)
    d = random_directions(rng, 40)
    x, y, z = (d @ convert.FILAMENT_FROM_BLENDER.T).T
    poly = np.stack([np.ones_like(x), y, z, x, y * x, y * z, 3 * z * z - 1, z * x, x * x - y * y], -1)
    np.testing.assert_allclose(poly @ f, sh.irradiance(c, d) / np.pi, atol=1e-12)
    text = sh.filament_sh_txt(c)
    assert len(text.splitlines()) == 9 and text.splitlines()[0].endswith("// L00, irradiance, pre-scaled base")
    first = [float(v) for v in text.splitlines()[0].split(")")[0].strip("(").split(",")]
    np.testing.assert_allclose(first, f[0], atol=1e-8)


def test_bad_shapes():
    with pytest.raises(ValueError):
        sh.to_threejs(np.zeros((8, 3)))
    with pytest.raises(ValueError):
        sh.to_paper(np.zeros(9))
