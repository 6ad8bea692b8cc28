"""Constitutive matrices (Voigt notation) for plane stress and 3D linear elasticity.

Strain vectors use engineering shear strains: 2D ``[exx, eyy, gxy]``; 3D
``[exx, eyy, ezz, gyz, gxz, gxy]``; stresses the same order (``Stress2``, ``Stress3``).
The assembly accepts one matrix or one per element, ``(m, 3, 3)`` / ``(m, 6, 6)``, so anisotropic
(e.g. printed, orthotropic) materials use the same solver.
"""

from __future__ import annotations

import numpy as np
from loadpath.errors import SettingsError
from loadpath.loadcase.model import Material

__all__ = ["Material", "plane_stress", "isotropic_3d", "elasticity_matrix", "rotate_plane_stress"]


def _check(E: float, nu: float) -> None:  # noqa: N803
    if not (E > 0 and -1.0 < nu < 0.5):
        raise SettingsError(f"material E = {E} MPa, nu = {nu} is not physical; need E > 0 and -1 < nu < 0.5")


def plane_stress(E: float, nu: float) -> np.ndarray:  # noqa: N803
    """Plane-stress matrix ``E / (1 - nu²) [[1, nu, 0], [nu, 1, 0], [0, 0, (1 - nu) / 2]]``, (3, 3) MPa."""
    _check(E, nu)
    c = E / (1.0 - nu * nu)
    return c * np.array([[1.0, nu, 0.0], [nu, 1.0, 0.0], [0.0, 0.0, 0.5 * (1.0 - nu)]])


def isotropic_3d(E: float, nu: float) -> np.ndarray:  # noqa: N803
    """Isotropic 3D matrix, (6, 6) MPa.

    From Lamé's ``lambda = E nu / ((1 + nu)(1 - 2 nu))`` and ``mu = E / (2 (1 + nu))``.
    """
    _check(E, nu)
    lam = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))
    mu = E / (2.0 * (1.0 + nu))
    D = np.zeros((6, 6))
    D[:3, :3] = lam
    D[np.arange(3), np.arange(3)] += 2.0 * mu
    D[np.arange(3, 6), np.arange(3, 6)] = mu
    return D


def elasticity_matrix(material: Material, dim: int) -> np.ndarray:
    """Plane stress (``dim = 2``) or 3D matrix of an isotropic material."""
    if dim == 2:
        return plane_stress(material.youngs_modulus, material.poissons_ratio)
    return isotropic_3d(material.youngs_modulus, material.poissons_ratio)


def rotate_plane_stress(D: np.ndarray, angle: np.ndarray | float) -> np.ndarray:
    """Rotate plane-stress matrices from material axes by ``angle`` (rad) about z.

    ``D' = T^-1 D T^-T`` with the Voigt stress transformation ``T`` (so a fibre direction along the
    material x axis points along ``angle`` afterwards).

    Parameters
    ----------
    D : (3, 3) or (m, 3, 3) float, MPa
    angle : float or (m,) float, rad

    Returns
    -------
    (m, 3, 3) float, MPa (``m = 1`` for scalars)
    """
    a = np.atleast_1d(np.asarray(angle, dtype=float))
    c, s = np.cos(a), np.sin(a)
    # stress transformation from global to material axes: sigma_mat = T sigma_glob
    T = np.zeros((len(a), 3, 3))
    T[:, 0] = np.stack([c * c, s * s, 2 * c * s], axis=1)
    T[:, 1] = np.stack([s * s, c * c, -2 * c * s], axis=1)
    T[:, 2] = np.stack([-c * s, c * s, c * c - s * s], axis=1)
    Tinv = np.linalg.inv(T)
    Dm = np.broadcast_to(D, (len(a), 3, 3))
    # epsilon_mat = T^-T epsilon_glob (engineering strains) -> D_glob = T^-1 D_mat T^-T
    return Tinv @ Dm @ np.swapaxes(Tinv, 1, 2)
