"""Reference elements, quadrature and constitutive matrices."""

from __future__ import annotations

import numpy as np
import pytest
from loadpath.fea.assembly import strain_matrix
from loadpath.fea.elements import ELEMENTS, line_rule, tetra_rule, triangle_rule
from loadpath.fea.material import isotropic_3d, plane_stress, rotate_plane_stress


@pytest.mark.parametrize("name", ["line2", "line3", "tri3", "tri6", "tet4", "tet10"])
def test_shape_functions_interpolate_nodes_and_sum_to_one(name):
    el = ELEMENTS[name]
    np.testing.assert_allclose(el.shape(el.nodes), np.eye(el.n_nodes), atol=1e-14)
    xi = np.random.default_rng(1).uniform(0, 1.0 / el.dim, size=(20, el.dim))
    np.testing.assert_allclose(el.shape(xi).sum(axis=1), 1.0, atol=1e-14)
    np.testing.assert_allclose(el.grad(xi).sum(axis=1), 0.0, atol=1e-13)
    # gradients against central differences
    eps = 1e-6
    for j in range(el.dim):
        e = np.zeros(el.dim)
        e[j] = eps
        fd = (el.shape(xi + e) - el.shape(xi - e)) / (2 * eps)
        np.testing.assert_allclose(el.grad(xi)[:, :, j], fd, atol=1e-8)


def test_quadrature_rules_are_exact_to_their_degree():
    from math import factorial

    def simplex_monomial(a):  # integral of x^a0 y^a1 (z^a2) over the unit simplex
        return np.prod([factorial(k) for k in a]) / factorial(sum(a) + len(a))

    for degree, rule in [(2, triangle_rule(2)), (4, triangle_rule(4))]:
        p, w = rule
        for a in [(i, j) for i in range(degree + 1) for j in range(degree + 1 - i)]:
            assert np.sum(w * p[:, 0] ** a[0] * p[:, 1] ** a[1]) == pytest.approx(
                simplex_monomial(a), rel=1e-12
            )
    p, w = tetra_rule(2)
    for a in [(i, j, k) for i in range(3) for j in range(3) for k in range(3) if i + j + k <= 2]:
        assert np.sum(w * np.prod(p**a, axis=1)) == pytest.approx(simplex_monomial(a), rel=1e-12)
    p, w = line_rule(3)
    assert np.sum(w * p[:, 0] ** 5) == pytest.approx(1 / 6)


def test_constitutive_matrices():
    E, nu = 3500.0, 0.35
    S = np.linalg.inv(plane_stress(E, nu))  # compliance: exx = (sxx - nu syy) / E, gxy = 2 (1 + nu) sxy / E
    np.testing.assert_allclose(
        S, [[1 / E, -nu / E, 0], [-nu / E, 1 / E, 0], [0, 0, 2 * (1 + nu) / E]], rtol=1e-12
    )
    S3 = np.linalg.inv(isotropic_3d(E, nu))
    assert (
        S3[0, 0] == pytest.approx(1 / E)
        and S3[0, 1] == pytest.approx(-nu / E)
        and S3[3, 3] == pytest.approx(2 * (1 + nu) / E)
    )


def test_rotated_orthotropic_matrix():
    E1, E2, G12, nu12 = 3000.0, 2000.0, 800.0, 0.3
    S = np.array([[1 / E1, -nu12 / E1, 0], [-nu12 / E1, 1 / E2, 0], [0, 0, 1 / G12]])
    D = np.linalg.inv(S)
    iso = plane_stress(3500.0, 0.35)
    np.testing.assert_allclose(rotate_plane_stress(iso, 0.7)[0], iso, atol=1e-9)
    Dr = rotate_plane_stress(D, np.pi / 2)[0]
    assert Dr[0, 0] == pytest.approx(D[1, 1]) and Dr[1, 1] == pytest.approx(D[0, 0])
    # uniaxial stress along the fibre direction at 30 degrees: strain along it is sigma / E1
    a = np.radians(30)
    n = np.array([np.cos(a), np.sin(a)])
    sig = np.array([n[0] ** 2, n[1] ** 2, n[0] * n[1]])
    eps = np.linalg.solve(rotate_plane_stress(D, a)[0], sig)
    along = eps[0] * n[0] ** 2 + eps[1] * n[1] ** 2 + eps[2] * n[0] * n[1]
    assert along == pytest.approx(1 / E1, rel=1e-12)


def test_strain_matrix_gives_the_symmetric_gradient():
    rng = np.random.default_rng(0)
    dN = rng.normal(size=(4, 10, 3))
    u = rng.normal(size=(10, 3))
    G = np.einsum("kj,ki->ij", dN[0], u)
    eps = strain_matrix(dN)[0] @ u.ravel()
    np.testing.assert_allclose(
        eps, [G[0, 0], G[1, 1], G[2, 2], G[1, 2] + G[2, 1], G[0, 2] + G[2, 0], G[0, 1] + G[1, 0]]
    )
