import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from panolight_core import sh
from tests.conftest import random_directions


@pytest.mark.parametrize("shift", [1, 7, 40])
def test_rotate_z_matches_turning_the_map(rng, shift):
    h, w = 32, 64
    img = rng.random((h, w, 3))
    angle = 2 * math.pi * shift / w
    # new(d) = old(Rz(-a) d): the texture turns counter-clockwise seen from above = moves left in the image
    turned = np.roll(img, -shift, axis=1)
    np.testing.assert_allclose(sh.rotate_z(sh.project(img, 10), angle), sh.project(turned, 10), atol=1e-12)


def test_rotate_z_equals_general_rotation(rng):
    c = rng.normal(size=(49, 3))
    a = 0.83
    r = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])
    np.testing.assert_allclose(sh.rotate(c, r), sh.rotate_z(c, a), atol=1e-12)


@pytest.mark.parametrize("lmax", [1, 4, 12])
def test_general_rotation_definition_and_group_laws(rng, lmax):
    c = rng.normal(size=((lmax + 1) ** 2, 3))
    r1, r2 = Rotation.random(2, random_state=3).as_matrix()
    d = random_directions(rng, 50)
    np.testing.assert_allclose(sh.basis(d, lmax) @ sh.rotate(c, r1), sh.basis(d @ r1, lmax) @ c, atol=1e-11)
    np.testing.assert_allclose(sh.rotate(sh.rotate(c, r1), r2), sh.rotate(c, r2 @ r1), atol=1e-11)
    for dl in sh.rotation_matrices(r1, lmax):
        np.testing.assert_allclose(dl @ dl.T, np.eye(dl.shape[0]), atol=1e-11)


def test_reflection_and_bad_matrix(rng):
    c = rng.normal(size=(9, 3))
    mirror = np.diag([-1.0, 1, 1])
    d = random_directions(rng, 20)
    np.testing.assert_allclose(sh.basis(d, 2) @ sh.rotate(c, mirror), sh.basis(d @ mirror, 2) @ c, atol=1e-12)
    with pytest.raises(ValueError, match="orthogonal"):
        sh.rotate(c, np.eye(3) * 2)
