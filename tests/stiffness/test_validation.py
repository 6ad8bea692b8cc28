"""Validation of the printed-material model against closed forms (issue: validation tests).

1. A uniaxial bar whose filaments run at 0, 45 and 90 degrees (and a few other angles), in plane
   stress and in 3D, against the closed form of a rotated orthotropic material: under the uniform
   stress ``sigma = F / A`` the axial strain is ``sigma / E_x(theta)`` with

       1 / E_x = c^4 / E1 + (1 / G12 - 2 nu12 / E1) c^2 s^2 + s^4 / E2,

   and the shear strain ``gamma_xy = S16 sigma`` with
   ``S16 = (2 / E1 + 2 nu12 / E1 - 1 / G12) c^3 s - (2 / E2 + 2 nu12 / E1 - 1 / G12) c s^3``.
   The supports leave the bar free to contract and shear (x fixed on the clamped face, y and z
   only along its edges through the origin), so the exact solution is a uniform strain, which the
   quadratic elements reproduce to round-off: compliance ``F^2 L / (E_x A)`` and the end face's
   displacements are checked to 1e-8.
2. The same bar built from straight paths (beads at the angle, one pitch apart, flow width = pitch,
   several layers) through the whole chain (deposits -> sampled fill and direction moments -> ply
   stack -> FEA) gives the compliance of the material set directly, within the sampling error.
"""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from loadpath import metrics
from loadpath.fea import Problem, solve
from loadpath.fea.boundary import facets_of, load_vector
from loadpath.fea.orthotropic import ABS_PRINTED, LINEAR, PLA_PRINTED, direction_moments, printed_matrices
from loadpath.loadcase.model import Load, SideSelector
from loadpath.stiffness import Deposits, from_toolpaths, material_matrices, sample_deposits
from meshes import box_tet10, rectangle_tri6

L, W, T, F = 20.0, 4.0, 1.0, 100.0


def closed_form(mat, theta):
    c, s = np.cos(theta), np.sin(theta)
    inv_ex = c**4 / mat.E1 + (1 / mat.G12 - 2 * mat.nu12 / mat.E1) * c * c * s * s + s**4 / mat.E2
    s16 = (2 / mat.E1 + 2 * mat.nu12 / mat.E1 - 1 / mat.G12) * c**3 * s - (
        2 / mat.E2 + 2 * mat.nu12 / mat.E1 - 1 / mat.G12
    ) * c * s**3
    return 1.0 / inv_ex, s16


def bar_problem(mesh, D):
    """Uniform traction F on x = L; x fixed on x = 0, y on the edge y = 0 there, z on z = 0 there."""
    d = mesh.dim
    p = mesh.points
    facets = facets_of(mesh)
    picked = np.abs(facets.centroid[:, 0] - L) < 1e-9
    f = load_vector(mesh, facets, picked, Load("pull", SideSelector("x_max", 0.0), force=(F, 0.0, 0.0)))
    at0 = np.abs(p[:, 0]) < 1e-9
    fixed = [np.flatnonzero(at0) * d]
    fixed.append(np.flatnonzero(at0 & (np.abs(p[:, 1]) < 1e-9)) * d + 1)
    if d == 3:
        fixed.append(np.flatnonzero(at0 & (np.abs(p[:, 2]) < 1e-9)) * d + 2)
    return Problem(mesh, D, f, np.concatenate(fixed)), f


def moments_at(theta, m):
    return np.tile(direction_moments(np.array([theta])), (m, 1))


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("deg", [0.0, 45.0, 90.0, 30.0, -60.0])
@pytest.mark.parametrize("mat", [PLA_PRINTED, ABS_PRINTED], ids=["pla", "abs"])
def test_uniaxial_bar_against_rotated_orthotropic_closed_form(dim, deg, mat):
    mesh = rectangle_tri6(L, W, 10, 2, thickness=T) if dim == 2 else box_tet10((L, W, T), (10, 2, 1))
    theta = np.deg2rad(deg)
    m = len(mesh.cells)
    D = printed_matrices(mat, np.ones(m), moments_at(theta, m), dim=dim)
    prob, f = bar_problem(mesh, D)
    res = solve(prob)
    assert res.residual < 1e-9
    ex, s16 = closed_form(mat, theta)
    sigma = F / (W * T)
    compliance = float(f @ res.u.ravel())
    assert compliance == pytest.approx(F * F * L / (ex * W * T), rel=1e-8)
    end = np.abs(mesh.points[:, 0] - L) < 1e-9
    np.testing.assert_allclose(res.u[end, 0], sigma / ex * L, rtol=1e-8)
    # shear: u_y = gamma_xy x + eps_yy y; at (L, 0) it is gamma_xy L
    corner = np.flatnonzero(end & (np.abs(mesh.points[:, 1]) < 1e-9))
    np.testing.assert_allclose(res.u[corner, 1], s16 * sigma * L, rtol=1e-7, atol=1e-12)


def test_orientation_matters_as_the_closed_form_says():
    """Sanity of the defaults: along the filament stiffest, 45 degrees softest for PLA's shear modulus."""
    e0, _ = closed_form(PLA_PRINTED, 0.0)
    e45, _ = closed_form(PLA_PRINTED, np.pi / 4)
    e90, _ = closed_form(PLA_PRINTED, np.pi / 2)
    assert e0 == pytest.approx(PLA_PRINTED.E1)
    assert e90 == pytest.approx(PLA_PRINTED.E2)
    assert e0 > e90 and e0 > e45


def straight_deposits(deg, pitch=0.45, layers=5, height=0.2, margin=2.0):
    """Beads at ``deg`` covering the bar and a margin around it (material outside the mesh is dropped)."""
    region = shapely.box(-margin, -margin, L + margin, W + margin)
    tp = metrics.rectilinear(region, pitch, deg)
    parts = [from_toolpaths(tp, (k + 1) * height, height, k) for k in range(layers)]
    return Deposits.concat(parts)


@pytest.mark.parametrize("deg", [0.0, 45.0, 90.0, 20.0])
def test_path_derived_straight_lines_give_the_compliance_of_the_material_set_directly(deg):
    mesh = rectangle_tri6(L, W, 20, 4, thickness=1.0)  # 1 mm squares, about two pitches
    dep = straight_deposits(deg)
    fields = sample_deposits(mesh, dep, resolution=0.025)
    # the chain sees the lines: fill about 1, direction deg everywhere
    assert np.mean(fields.fill) == pytest.approx(1.0, abs=0.01)
    np.testing.assert_allclose(fields.weight.sum(), 1.0)
    angle, strength = fields.direction()
    d = np.abs(np.angle(np.exp(2j * (angle - np.deg2rad(deg))))) / 2
    assert np.max(d) < 1e-9 and np.min(strength) > 0.999
    D_paths = material_matrices(fields, PLA_PRINTED, LINEAR, 2)
    m = len(mesh.cells)
    D_direct = printed_matrices(PLA_PRINTED, np.ones(m), moments_at(np.deg2rad(deg), m))
    c_paths = bar_compliance(mesh, D_paths)
    c_direct = bar_compliance(mesh, D_direct)
    assert c_paths == pytest.approx(c_direct, rel=5e-3)


def bar_compliance(mesh, D):
    prob, f = bar_problem(mesh, D)
    res = solve(prob)
    return float(f @ res.u.ravel())


def test_cross_plied_paths_equal_the_laminate_of_their_plies():
    """Alternating 0/90 layers through the chain = the thickness-weighted mean of the two plies."""
    mesh = rectangle_tri6(L, W, 20, 4, thickness=1.0)
    region = shapely.box(-2, -2, L + 2, W + 2)
    parts = [
        from_toolpaths(metrics.rectilinear(region, 0.45, 90.0 * (k % 2)), (k + 1) * 0.25, 0.25, k)
        for k in range(4)
    ]
    fields = sample_deposits(mesh, Deposits.concat(parts), resolution=0.05)
    from loadpath.fea.orthotropic import LINEAR

    D_paths = material_matrices(fields, PLA_PRINTED, LINEAR, 2)
    m = len(mesh.cells)
    D_direct = 0.5 * (
        printed_matrices(PLA_PRINTED, np.ones(m), moments_at(0.0, m))
        + printed_matrices(PLA_PRINTED, np.ones(m), moments_at(np.pi / 2, m))
    )
    assert bar_compliance(mesh, D_paths) == pytest.approx(bar_compliance(mesh, D_direct), rel=5e-3)
    _, strength = fields.direction()
    assert np.max(strength) < 0.02  # a cross-plied stack has no dominant direction
