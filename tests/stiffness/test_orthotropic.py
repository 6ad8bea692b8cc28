"""The printed-ply material model: rotations, exact orientation averaging, fill models, validation."""

from __future__ import annotations

import numpy as np
import pytest
from loadpath.errors import SettingsError
from loadpath.fea.material import rotate_plane_stress
from loadpath.fea.orthotropic import (
    LINEAR,
    NMO,
    PLA_PRINTED,
    FillModel,
    PrintedMaterial,
    direction_moments,
    ply_matrices,
    printed_matrices,
    rotate,
)

ANGLES = np.deg2rad([0.0, 45.0, 90.0, 17.0, -122.0])


def test_rotation_agrees_with_the_fea_plane_stress_rotation():
    Q = PLA_PRINTED.plane_stress()
    np.testing.assert_allclose(rotate(Q, ANGLES), rotate_plane_stress(Q, ANGLES), atol=1e-9)


def test_3d_rotation_keeps_the_in_plane_block_of_a_plane_stress_condensation():
    """Condensing sigma_zz = 0 out of the rotated 3D matrix gives the rotated plane-stress matrix."""
    C = rotate(PLA_PRINTED.stiffness_3d(), ANGLES)
    S = np.linalg.inv(C)[:, [0, 1, 5]][:, :, [0, 1, 5]]  # in-plane compliance (sigma_zz = shears_z = 0)
    np.testing.assert_allclose(np.linalg.inv(S), rotate(PLA_PRINTED.plane_stress(), ANGLES), rtol=1e-9)


@pytest.mark.parametrize("dim", [2, 3])
def test_averaging_is_exact_for_one_direction_and_for_mixtures(dim):
    C = PLA_PRINTED.local(dim)
    for t in ANGLES:
        got = printed_matrices(PLA_PRINTED, np.ones(1), direction_moments(np.array([t]))[None], dim=dim)[0]
        np.testing.assert_allclose(got, rotate(C, t)[0], atol=1e-9)
    rng = np.random.default_rng(1)
    t = rng.uniform(-np.pi, np.pi, 7)
    w = rng.uniform(0.1, 2.0, 7)
    mean = np.einsum("k,kij->ij", w, rotate(C, t)) / w.sum()
    got = printed_matrices(PLA_PRINTED, np.ones(1), direction_moments(t, w)[None], dim=dim)[0]
    np.testing.assert_allclose(got, mean, atol=1e-9)


def test_moments_are_sign_free():
    t = np.array([0.3, 1.1])
    np.testing.assert_allclose(direction_moments(t), direction_moments(t + np.pi), atol=1e-12)
    np.testing.assert_allclose(direction_moments(t), direction_moments(-t[::-1] * -1), atol=1e-12)


def test_linear_fill_scales_every_component():
    v = np.array([0.2, 0.7, 1.0])
    np.testing.assert_allclose(
        ply_matrices(PLA_PRINTED, v, LINEAR), v[:, None, None] * PLA_PRINTED.plane_stress()
    )


def test_nmo_reproduces_the_thesis_constants():
    """App. B of the thesis: s22 with c = 15440 MPa, saturation 16000, v_a = 0.99, s_L = 0.1, f1 = 1e-3."""
    m = FillModel("nmo", v_a=0.99, s_L=0.1, f1=1e-3, f2=16000.0 / 15440.0)
    c = 15440.0
    s = m.scale(np.array(c), np.array([1.0, 0.99, -10.0, 10.0]))
    np.testing.assert_allclose(s[:2], [c, 1e-3 * c], rtol=1e-9)
    assert s[2] == pytest.approx(0.1, rel=1e-6) and s[3] == pytest.approx(16000.0, rel=1e-6)
    # the constants a1, a2 of the thesis (digest §4.3 table): s = a3 tanh(a1 v + a2) + a4
    a3 = (16000.0 - 0.1) / 2
    a4 = (16000.0 + 0.1) / 2
    t1 = np.arctanh((c - a4) / a3)
    ta = np.arctanh((1e-3 * c - a4) / a3)
    a1 = (t1 - ta) / 0.01
    assert a1 == pytest.approx(513.28441512576, rel=1e-9)
    assert t1 - a1 == pytest.approx(-511.626028344188, rel=1e-9)


def test_nmo_switches_off_the_transverse_stiffness_below_activation_but_not_the_filament():
    Q = PLA_PRINTED.plane_stress()
    C = ply_matrices(PLA_PRINTED, np.array([0.5, 0.9, 1.0]), NMO)
    np.testing.assert_allclose(C[:, 0, 0], Q[0, 0] * np.array([0.5, 0.9, 1.0]))
    np.testing.assert_allclose(C[2], Q, rtol=1e-9)
    assert C[0, 1, 1] < 1.0 and C[0, 2, 2] < 1.0  # gaps: no transverse or shear stiffness left
    assert np.all(np.linalg.eigvalsh(C) > 0)


def test_bad_materials_are_refused_with_the_fix():
    with pytest.raises(SettingsError, match="E2 = -1"):
        PrintedMaterial("x", E1=3000.0, E2=-1.0, G12=1000.0, nu12=0.3)
    with pytest.raises(SettingsError, match="not positive definite"):
        PrintedMaterial("x", E1=3000.0, E2=100.0, G12=1000.0, nu12=6.0)
    with pytest.raises(SettingsError, match="fill model 'cubic'"):
        FillModel("cubic")
