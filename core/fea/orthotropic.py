r"""Printed-material stiffness: an orthotropic layer (ply) of extruded filament, scaled by its fill.

A printed layer is modelled as a ply whose material axes follow the filament: axis 1 along the
filament, axis 2 across it in the layer, axis 3 the build direction (transversely isotropic about
axis 1, as in the thesis's model, ``C2222 = C3333``).  Its stiffness depends on

* the local filament **direction**: per element, the length-weighted distribution of the directions
  of the beads inside it (sign-free: only the angle modulo pi matters);
* the local **fill** ``v``: extruded material volume over element volume (1 = fully dense).

Orientation averaging (Voigt)
-----------------------------
A stiffness matrix rotated by ``theta`` about z, ``C(theta) = M(theta) C_loc M(theta)^T``, is a
trigonometric polynomial of degree 4 in ``theta`` with period pi: it is fixed by the harmonics
``1, cos 2t, sin 2t, cos 4t, sin 4t`` (the Tsai-Pagano invariants in 2D).  The length-weighted mean
of ``C`` over the beads of an element is therefore exact from four moments of the direction
distribution, ``<cos 2t>, <sin 2t>, <cos 4t>, <sin 4t>`` (the second moments are the direction
tensor ``<n n>``; the fourth ones ``<n n n n>``).  It is evaluated as a weighted sum over five fixed
angles ``t_j = j pi / 5``:

.. math::

    \bar C = \sum_j \lambda_j C(t_j), \quad
    \lambda_j = \tfrac15 \Big[1 + 2 \sum_{k=1,2} \big(\langle\cos 2kt\rangle \cos 2k t_j
    + \langle\sin 2kt\rangle \sin 2k t_j\big)\Big],

which is exact for a single direction (``C(t0)``) and for any mixture.  Mixing directions inside
one element this way assumes equal strain across the beads of the element (Voigt, an upper bound);
elements a few pitches wide mix little except where perimeters meet infill.

Fill models
-----------
``"linear"`` (Fernandez et al. 2019, the thesis's "LMO"): ``C = v C_full``.

``"nmo"`` (thesis §3.2, Eqs. 3.16-3.18; ``../shared/seeds/thesis-digest.md`` §4.3): the component
along the filament scales linearly, ``C1111 = v c1111``; every other component follows
``s(v) = a3 tanh(a1 v + a2) + a4`` with ``s(-inf) = s_L``, ``s(v_a) = f1 c``, ``s(1) = c``,
``s(+inf) = f2 c``: the transverse stiffness switches on only when neighbouring beads touch
(``v`` close to 1).  Closed form of the constants::

    a3 = (f2 c - s_L) / 2,  a4 = (f2 c + s_L) / 2,
    t1 = atanh((c - a4) / a3),  ta = atanh((f1 c - a4) / a3),
    a1 = (t1 - ta) / (1 - v_a),  a2 = t1 - a1.

The fill given here is the *effective* one (:meth:`loadpath.stiffness.PlyFields.effective_fill`:
over-filled neighbourhoods are brought down to solid, since a layer cannot be denser than solid
plastic); it is floored at :data:`VOID_FILL` so empty elements stay positive definite (air is
modelled as a very soft material, not as a hole in the mesh) and capped at ``max_fill``.

Material defaults: see :data:`PLA_PRINTED` (with its source) and :data:`ABS_PRINTED`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from loadpath.errors import SettingsError

__all__ = [
    "PrintedMaterial", "FillModel", "PLA_PRINTED", "ABS_PRINTED", "LINEAR", "NMO", "BEADS", "VOID_FILL",
    "orientation_average", "rotation_voigt", "rotate", "direction_moments", "averaging_weights",
    "ply_matrices", "printed_matrices",
]

VOID_FILL = 1e-3
"""Smallest fill used for stiffness (empty elements are very soft, never singular)."""

_HARMONIC_ANGLES = np.arange(5) * np.pi / 5.0


@dataclass(frozen=True)
class PrintedMaterial:
    """Elastic constants of a fully dense printed layer, in the filament axes.

    Attributes
    ----------
    name : str
    E1 : float, MPa
        Young's modulus along the filament.
    E2 : float, MPa
        Across the filament in the layer (and along z: transversely isotropic about axis 1).
    G12 : float, MPa
        In-plane shear modulus (also ``G13``).
    nu12 : float
        Major Poisson's ratio (strain across / strain along for a pull along the filament; also ``nu13``).
    nu23 : float
        Poisson's ratio in the transverse plane (only the 3D analysis uses it; ``G23 = E2 / (2 (1 + nu23))``).
    density : float, g/cm³
        Of the solid plastic (specific stiffness, mass of the part).
    source : str
        Where the numbers come from.
    """

    name: str
    E1: float  # noqa: N815 (the usual symbols)
    E2: float  # noqa: N815
    G12: float  # noqa: N815
    nu12: float
    nu23: float = 0.35
    density: float = 1.24
    source: str = ""

    def __post_init__(self) -> None:
        for key in ("E1", "E2", "G12", "density"):
            v = getattr(self, key)
            if not (math.isfinite(v) and v > 0):
                raise SettingsError(f"material {self.name!r}: {key} = {v!r} must be a positive number")
        if not -1.0 < self.nu23 < 1.0:
            raise SettingsError(f"material {self.name!r}: nu23 = {self.nu23} must lie in (-1, 1)")
        if not np.all(np.linalg.eigvalsh(self.compliance_3d()) > 0):
            raise SettingsError(
                f"material {self.name!r}: E1 = {self.E1}, E2 = {self.E2}, nu12 = {self.nu12}, "
                f"nu23 = {self.nu23} "
                "is not positive definite; need nu12^2 < E1 / E2 and |nu23| < 1 - 2 nu12^2 E2 / E1"
            )

    @property
    def nu21(self) -> float:
        """Minor Poisson's ratio ``nu12 E2 / E1``."""
        return self.nu12 * self.E2 / self.E1

    def plane_stress(self) -> np.ndarray:
        """Reduced stiffness ``Q`` in the filament axes, ``(3, 3)`` MPa (Voigt ``[e11, e22, g12]``).

        ``Q11 = E1 / (1 - nu12 nu21)``, ``Q22 = E2 / (1 - nu12 nu21)``, ``Q12 = nu12 Q22``, ``Q66 = G12``.
        """
        d = 1.0 - self.nu12 * self.nu21
        q11, q22 = self.E1 / d, self.E2 / d
        return np.array([[q11, self.nu12 * q22, 0.0], [self.nu12 * q22, q22, 0.0], [0.0, 0.0, self.G12]])

    def compliance_3d(self) -> np.ndarray:
        """3D compliance in the filament axes, ``(6, 6)`` 1/MPa, Voigt ``[11, 22, 33, 23, 13, 12]``."""
        E1, E2 = self.E1, self.E2  # noqa: N806
        g23 = E2 / (2.0 * (1.0 + self.nu23))
        S = np.zeros((6, 6))
        S[0, 0], S[1, 1], S[2, 2] = 1.0 / E1, 1.0 / E2, 1.0 / E2
        S[0, 1] = S[1, 0] = S[0, 2] = S[2, 0] = -self.nu12 / E1
        S[1, 2] = S[2, 1] = -self.nu23 / E2
        S[3, 3] = 1.0 / g23
        S[4, 4] = S[5, 5] = 1.0 / self.G12
        return S

    def stiffness_3d(self) -> np.ndarray:
        """3D stiffness in the filament axes, ``(6, 6)`` MPa."""
        return np.linalg.inv(self.compliance_3d())

    def local(self, dim: int) -> np.ndarray:
        """Full-density local matrix: :meth:`plane_stress` (``dim = 2``) or :meth:`stiffness_3d`."""
        return self.plane_stress() if dim == 2 else self.stiffness_3d()


# Li M., Xu Y., Fang J., Thin-Walled Structures 199 (2024) 111800: printed PLA lamina, as transcribed in
# Strecs3D's material card (github tomohiron907/Strecs3D, FEM/step2inp/MaterialManager.cpp, read there):
# E1 2669, E2 2583, E3 2208, nu12 0.43, nu13 = nu23 0.37, G12 919, G13 = G23 844 MPa.  This replaces
# E1 3209 / E2 2899 / G12 1195 MPa attributed to Casavola et al., Materials & Design 90 (2016) 453-458
# "from memory", which no session could re-read.  Strengths and the rest of the card:
# loadpath.stiffness.cards.  Density: PLA 1.24 g/cm3 (Prusament PLA; the MK3S filament preset).
PLA_PRINTED = PrintedMaterial(
    "PLA (printed, fully fused ply)",
    E1=2669.0,
    E2=2583.0,
    G12=919.0,
    nu12=0.43,
    nu23=0.37,
    density=1.24,
    source="Li, Xu & Fang, Thin-Walled Structures 199 (2024) 111800 (printed PLA lamina), via Strecs3D's card",
)
"""Default printed material: PLA (source in the code above)."""

# Alaimo G., Marconi S., Costato L., Auricchio F., "Influence of meso-structure and chemical composition on
# FDM 3D-printed parts", Composites Part B 113 (2017) 371-380, as used by the thesis (Murugan, §3.6,
# thesis-digest.md §4.3): fully filled printed ABS, E_L 2010, E_T 1671, G_LT 641 MPa, nu_LT 0.32.
ABS_PRINTED = PrintedMaterial(
    "ABS (printed, fully fused ply)",
    E1=2010.0,
    E2=1671.0,
    G12=641.0,
    nu12=0.32,
    nu23=0.35,
    density=1.04,
    source="Alaimo et al., Composites Part B 113 (2017) 371-380, via Murugan's thesis §3.6",
)
"""Printed ABS of the thesis's MBB experiment."""


@dataclass(frozen=True)
class FillModel:
    """How the stiffness depends on the local fill ``v`` (see the module docstring).

    Attributes
    ----------
    kind : {"linear", "nmo"}
    v_a : float
        NMO activation fill (thesis: 0.9 for the printed ABS experiment and differential evolution,
        0.99 for the gradient runs).
    s_L : float, MPa
        NMO stiffness of widely spaced filaments (thesis: 0.1 MPa).
    f1, f2 : float
        NMO value at ``v_a`` and saturation, as fractions of the full-density component (thesis:
        ``f1 = 1e-3``, ``f2`` about 1.03-1.1).
    """

    kind: str = "linear"
    v_a: float = 0.9
    s_L: float = 0.1  # noqa: N815
    f1: float = 1e-3
    f2: float = 1.05

    def __post_init__(self) -> None:
        if self.kind not in ("linear", "nmo", "beads"):
            raise SettingsError(f"fill model {self.kind!r} is unknown; use 'beads', 'linear' or 'nmo'")
        if not (0.0 < self.v_a < 1.0 and self.s_L > 0 and 0.0 < self.f1 < 1.0 < self.f2):
            raise SettingsError(
                f"NMO parameters v_a = {self.v_a}, s_L = {self.s_L}, f1 = {self.f1}, f2 = {self.f2} "
                "are invalid; "
                "need 0 < v_a < 1, s_L > 0, 0 < f1 < 1 < f2"
            )

    def scale(self, c: np.ndarray, v: np.ndarray) -> np.ndarray:
        """NMO law ``s(v)`` for components ``c`` (any shape, MPa) at fills ``v`` (broadcast).

        The law needs ``f1 |c| > s_L``; smaller components (the zeros of the local matrix) scale
        linearly.
        """
        c = np.asarray(c, dtype=float)
        sign = np.sign(c)
        ca = np.abs(c)
        big = self.f1 * ca > self.s_L
        cs = np.where(big, ca, 2.0 * self.s_L / self.f1)
        a3 = 0.5 * (self.f2 * cs - self.s_L)
        a4 = 0.5 * (self.f2 * cs + self.s_L)
        t1 = np.arctanh((cs - a4) / a3)
        ta = np.arctanh((self.f1 * cs - a4) / a3)
        a1 = (t1 - ta) / (1.0 - self.v_a)
        a2 = t1 - a1
        s = a3 * np.tanh(a1 * v + a2) + a4
        return np.where(big, sign * s, c * v)


LINEAR = FillModel("linear")
NMO = FillModel("nmo")
BEADS = FillModel("beads")
"""The bead model (:mod:`loadpath.stiffness.beads`): fusion, transfer and crossings from the beads."""


def rotation_voigt(theta: np.ndarray | float, dim: int) -> np.ndarray:
    """Stress rotation ``sigma_global = M sigma_local`` for material axes turned by ``theta`` about z.

    Voigt orders: 2D ``[xx, yy, xy]``; 3D ``[xx, yy, zz, yz, xz, xy]``.  With engineering shear
    strains, ``C_global = M C_local M^T``.

    Parameters
    ----------
    theta : float or (m,) float, rad
        Angle of the filament (axis 1) from +x, counter-clockwise.
    dim : {2, 3}

    Returns
    -------
    (m, nv, nv) float
    """
    t = np.atleast_1d(np.asarray(theta, dtype=float))
    c, s = np.cos(t), np.sin(t)
    cc, ss, cs = c * c, s * s, c * s
    if dim == 2:
        M = np.zeros((len(t), 3, 3))
        M[:, 0] = np.stack([cc, ss, -2 * cs], axis=1)
        M[:, 1] = np.stack([ss, cc, 2 * cs], axis=1)
        M[:, 2] = np.stack([cs, -cs, cc - ss], axis=1)
        return M
    M = np.zeros((len(t), 6, 6))
    M[:, 0, 0], M[:, 0, 1], M[:, 0, 5] = cc, ss, -2 * cs
    M[:, 1, 0], M[:, 1, 1], M[:, 1, 5] = ss, cc, 2 * cs
    M[:, 2, 2] = 1.0
    M[:, 3, 3], M[:, 3, 4] = c, s  # yz from 23 and 13
    M[:, 4, 3], M[:, 4, 4] = -s, c  # xz
    M[:, 5, 0], M[:, 5, 1], M[:, 5, 5] = cs, -cs, cc - ss
    return M


def rotate(C_local: np.ndarray, theta: np.ndarray | float) -> np.ndarray:
    """Rotate local matrices ``(nv, nv)`` or ``(m, nv, nv)`` by ``theta`` (rad), ``(m, nv, nv)`` MPa."""
    C = np.asarray(C_local, dtype=float)
    M = rotation_voigt(theta, 2 if C.shape[-1] == 3 else 3)
    return M @ C @ np.swapaxes(M, 1, 2)


def direction_moments(theta: np.ndarray, weight: np.ndarray | None = None) -> np.ndarray:
    """Return the four moments ``[<cos 2t>, <sin 2t>, <cos 4t>, <sin 4t>]`` of a set of directions.

    Parameters
    ----------
    theta : (n,) float, rad
    weight : (n,) float, optional
        E.g. the bead lengths; default equal weights.

    Returns
    -------
    (4,) float
    """
    t = np.asarray(theta, dtype=float)
    w = np.ones_like(t) if weight is None else np.asarray(weight, dtype=float)
    h = np.stack([np.cos(2 * t), np.sin(2 * t), np.cos(4 * t), np.sin(4 * t)])
    return h @ w / np.sum(w)


def averaging_weights(moments: np.ndarray) -> np.ndarray:
    """Weights ``lambda_j`` of the five harmonic angles for direction moments (module docstring).

    Parameters
    ----------
    moments : (m, 4) or (4,) float

    Returns
    -------
    (m, 5) float
        Each row sums to 1.
    """
    mom = np.atleast_2d(np.asarray(moments, dtype=float))
    t = _HARMONIC_ANGLES
    basis = np.stack([np.cos(2 * t), np.sin(2 * t), np.cos(4 * t), np.sin(4 * t)])  # (4, 5)
    return (1.0 + 2.0 * mom @ basis) / 5.0


def ply_matrices(
    material: PrintedMaterial,
    fill: np.ndarray,
    model: FillModel = LINEAR,
    dim: int = 2,
    max_fill: float = 1.25,
) -> np.ndarray:
    """Local (filament-axes) matrices at the given fills, ``(m, nv, nv)`` MPa.

    Parameters
    ----------
    material : PrintedMaterial
    fill : (m,) float
        Effective fill (material volume / element volume); clipped to ``[VOID_FILL, max_fill]``.
    model : FillModel
    dim : {2, 3}
    max_fill : float
        Upper clip of the fill.
    """
    v = np.clip(np.asarray(fill, dtype=float), VOID_FILL, max_fill)
    C = material.local(dim)
    if model.kind in ("linear", "beads"):  # beads: the fully fused, endless ply (the bead model's own
        return v[:, None, None] * C[None]  # matrices come from loadpath.stiffness.beads)
    out = model.scale(C[None], v[:, None, None])
    out[:, 0, 0] = C[0, 0] * v  # along the filament: linear (Eq. 3.16)
    return out


def printed_matrices(
    material: PrintedMaterial,
    fill: np.ndarray,
    moments: np.ndarray,
    model: FillModel = LINEAR,
    dim: int = 2,
) -> np.ndarray:
    """Orientation-averaged printed stiffness per element, ``(m, nv, nv)`` MPa.

    Parameters
    ----------
    material : PrintedMaterial
    fill : (m,) float
        Fill per element.
    moments : (m, 4) float
        Direction moments per element (:func:`direction_moments`); zeros (no bead) give the
        isotropic in-plane mean.
    model : FillModel
    dim : {2, 3}
    """
    return orientation_average(ply_matrices(material, fill, model, dim), moments, dim)


def orientation_average(local: np.ndarray, moments: np.ndarray, dim: int) -> np.ndarray:
    """Mean of local (bead-axes) matrices ``(m, nv, nv)`` over each element's bead directions (exact).

    Parameters
    ----------
    local : (m, nv, nv) float, MPa
    moments : (m, 4) float
        Direction moments (:func:`direction_moments`).
    dim : {2, 3}
    """
    lam = averaging_weights(moments)  # (m, 5)
    out = np.zeros_like(local)
    for j, t in enumerate(_HARMONIC_ANGLES):
        M = rotation_voigt(t, dim)[0]
        out += lam[:, j, None, None] * (M @ local @ M.T)
    return 0.5 * (out + np.swapaxes(out, 1, 2))
