"""Patch tests: constant strain is reproduced to machine precision on irregular meshes, 2D and 3D."""

from __future__ import annotations

import loadpath.loadcase as lc
import numpy as np
import pytest
from loadpath.fea import Problem, analyze, isotropic_3d, plane_stress, solve, stiffness
from loadpath.loadcase import Slab
from loadpath.mesh import MeshSize, mesh_2d, mesh_3d
from shapely.geometry import Point, Polygon, box

# an irregular outline with a hole, so the mesh has every element shape
PATCH = Polygon([(0, 0), (10, 0), (11, 6), (4, 8), (-1, 5)]).difference(Point(4, 3).buffer(1.3, quad_segs=5))
A2 = np.array([[1e-3, 2e-3], [-0.5e-3, 3e-3]])
A3 = np.array([[1e-3, 2e-3, -1e-3], [0.5e-3, -1e-3, 3e-3], [2e-3, 1e-3, 1.5e-3]])


def _voigt(A):
    if A.shape == (2, 2):
        return np.array([A[0, 0], A[1, 1], A[0, 1] + A[1, 0]])
    return np.array([A[0, 0], A[1, 1], A[2, 2], A[1, 2] + A[2, 1], A[0, 2] + A[2, 0], A[0, 1] + A[1, 0]])


@pytest.mark.parametrize("order", [1, 2])
def test_displacement_patch_2d(order):
    m = mesh_2d(PATCH, MeshSize(1.5, 0.6, 1.0), order=order)
    D = plane_stress(3500.0, 0.35)
    U = m.points @ A2.T + [0.1, -0.2]
    bn = np.unique(m.boundary[0])
    r = solve(Problem(m, D, np.zeros(m.points.size), (bn[:, None] * 2 + np.arange(2)).ravel(), U[bn].ravel()))
    assert r.residual < 1e-12
    np.testing.assert_allclose(r.u, U, atol=1e-14)
    np.testing.assert_allclose(r.stress, np.broadcast_to(D @ _voigt(A2), r.stress.shape), rtol=0, atol=1e-11)


@pytest.mark.parametrize("method", ["direct", "amg-cg"])
def test_displacement_patch_3d(method):
    slabs = [Slab(0.0, 1.5, PATCH), Slab(1.5, 3.0, box(0, 0, 6, 6))]
    m = mesh_3d(slabs, MeshSize(1.5, 0.6, 1.0))
    D = isotropic_3d(3500.0, 0.35)
    U = m.points @ A3.T + [0.1, -0.2, 0.3]
    bn = np.unique(m.boundary[0])
    r = solve(
        Problem(m, D, np.zeros(m.points.size), (bn[:, None] * 3 + np.arange(3)).ravel(), U[bn].ravel()),
        method=method,
    )
    tol = 1e-14 if method == "direct" else 1e-11  # the iterative solve stops at a 1e-9 relative residual
    np.testing.assert_allclose(r.u, U, atol=tol)
    np.testing.assert_allclose(
        r.stress, np.broadcast_to(D @ _voigt(A3), r.stress.shape), atol=1e3 * tol * 3500
    )


def test_traction_patch_2d_and_3d():
    """Uniform tension through the load-case path: constant stress F / A everywhere, 2D and 3D."""
    rollers = (
        'version = 1\n[[supports]]\nname = "end"\nwhere = { side = "x_min", within = 0.0 }\nfix = ["x"]\n'
        '[[supports]]\nname = "side"\nwhere = { side = "y_min", within = 0.0 }\nfix = ["y"]\n'
        '[[loads]]\nname = "pull"\nwhere = { side = "x_max", within = 0.0 }\nforce = [60.0, 0.0, 0.0]\n'
    )
    bottom = '[[supports]]\nname = "bottom"\nwhere = { side = "z_min", within = 0.0 }\nfix = ["z"]\n'
    # a trapezoid would not be a uniform-stress problem; a rectangle meshed irregularly is
    bar = box(0, 0, 20, 6)
    body = lc.Body.from_layers("bar", [(0, 1.0, bar), (1.0, 2.0, bar)])
    for analysis, text in (("2d", rollers), ("3d", rollers + bottom)):
        (rb,) = lc.resolve(lc.parse(text, "tension.toml"), [body], analysis=analysis)
        a = analyze(rb, size=MeshSize(2.5, 1.0, 1.5))
        s = a.result.stress
        sxx = 60.0 / (6 * 2)
        np.testing.assert_allclose(s[:, 0], sxx, rtol=1e-9)
        np.testing.assert_allclose(s[:, 1:], 0.0, atol=1e-9 * sxx)
        assert a.result.residual < 1e-10


def test_per_cell_constitutive_matrix_equals_shared_one():
    m = mesh_2d(PATCH, 2.0)
    D = plane_stress(3500.0, 0.35)
    K1 = stiffness(m, D)
    K2 = stiffness(m, np.repeat(D[None], len(m.cells), axis=0))
    assert abs(K1 - K2).max() < 1e-9 * abs(K1).max()
    # a stiffer half doubles exactly its cells' contributions
    stiff = np.repeat(D[None], len(m.cells), axis=0)
    stiff[::2] *= 2.0
    sub = m.cells[::2]
    from loadpath.mesh.data import MeshData

    half = stiffness(MeshData(m.points, sub, m.cell_type, thickness=m.thickness), D)
    assert abs(stiffness(m, stiff) - K1 - half).max() < 1e-9 * abs(K1).max()
