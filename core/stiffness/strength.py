r"""First-ply failure of a printed part: Tsai-Wu per ply on bead-scale averaged strains.

Criterion: Tsai-Wu (Tsai & Wu, J. Compos. Mater. 5 (1971) 58), in the bead axes of every ply,

.. math::

    F_1 \sigma_1 + F_2 \sigma_2 + F_{11} \sigma_1^2 + F_{22} \sigma_2^2 + F_{66} \tau^2
    + 2 F_{12} \sigma_1 \sigma_2 = 1,

``F_1 = 1/X_t - 1/X_c``, ``F_11 = 1/(X_t X_c)`` (likewise 2 with ``Y``), ``F_66 = 1/S^2`` and the
Tsai-Hahn interaction ``F_12 = -1/2 sqrt(F_11 F_22)``.  Why Tsai-Wu: printed plastic is much weaker
across the bead in tension (the bond opens) than in compression (the bond is pressed shut), and
Tsai-Wu is the one quadratic criterion that takes the tensile and compressive strengths separately
in one smooth surface (Tsai-Hill needs the strengths switched by the sign of each stress, and is not
smooth where they switch).  Being quadratic in the stresses, its load factor is closed form: for a
linear analysis, the stresses at load factor ``lambda`` are ``lambda sigma``, and
``a lambda^2 + b lambda = 1`` with ``a = sigma . F sigma``, ``b = F . sigma``.

Stresses in the beads (not the smeared ply): from the ply's strain in its bead axes (its mean bead
direction), with the bead model's fused fraction ``phi``, transfer ``eta`` and crossing spacing
``L_c`` (:mod:`.beads`):

* along: ``sigma_1 = eta [phi (Q11 e1 + Q12 e2) + (1 - phi) E1 e1]``;
* across and shear go through the bond: ``sigma_2 = phi (Q12 e1 + Q22 e2)``, ``tau = phi G12 g12``
  (an unfused bead carries none, so cannot fail there);
* an unfused bead sheared between crossings bends: its outer fibre adds
  ``+- (1 - phi) 3/2 E1 w g12 / L_c`` to ``sigma_1`` (end moment ``6 E I psi / L`` with the joint
  rotation ``psi = g12 / 2`` of a rigid-jointed grid).

Characteristic distance (Whitney & Nuismer, J. Compos. Mater. 8 (1974) 253, average-stress form):
each ply's bead stresses are averaged over its material within a disc of radius ``a0`` around every
element before the criterion is applied, so the answer at a hole or a re-entrant corner converges under mesh refinement instead of
following the singular peak.  ``a0`` defaults to two bead widths (:data:`A0_BEADS`): the scale below
which printed plastic is not a continuum (a bead carries its load as a whole).  It is a modelling
choice, not fitted to any test.

Elements touching a support or a loaded face are not checked: a clamp's edge is a singular point of
the model that a real grip spreads over its serrations (a coupon counts only when it breaks in the
gauge length).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from loadpath._typing import Floats
from loadpath.fea.boundary import load_vector
from loadpath.fea.stress import cell_stress
from loadpath.stiffness.cards import MaterialCard

__all__ = ["Failure", "first_failure", "tsai_wu_factor", "A0_BEADS", "applied_force"]

A0_BEADS = 2.0
"""Averaging radius of the characteristic-distance criterion, in bead (flow) widths."""

_MIN_FILL = 0.05


@dataclass(frozen=True)
class Failure:
    """First-ply failure of one body.

    Attributes
    ----------
    load_factor : float
        Multiple of the applied load at which the first ply fails (the safety factor).
    failure_load : float, N
        ``load_factor`` x the magnitude of the applied load.
    applied : float, N
        Magnitude of the applied load (sum over the loads of the resultant's length).
    location : (3,) float, mm
        Centroid of the first failing element, at the middle of the failing ply.
    ply : int
        Layer index of the failing ply (-1 in 3D).
    mode : str
        ``along``, ``across``, ``shear`` or ``bending``: the term of the criterion that dominates there.
    index : (m,) float
        Failure index per element at the applied load (``1 / load factor``, max over plies).
    a0 : float, mm
        Averaging radius used.
    """

    load_factor: float
    failure_load: float
    applied: float
    location: tuple[float, float, float]
    ply: int
    mode: str
    index: Floats = field(repr=False)
    a0: float = 0.0


def tsai_wu_factor(s1: Floats, s2: Floats, t12: Floats, card: MaterialCard) -> tuple[Floats, Floats]:
    """Load factor at which bead stresses ``(s1, s2, t12)`` (MPa, any shape) reach the Tsai-Wu surface.

    Returns
    -------
    factor : array
        ``inf`` where the stress is zero.
    terms : (4, ...) array
        ``|F1 s1 + F11 s1^2|``, ``|F2 s2 + F22 s2^2|``, ``F66 t12^2``, for naming the mode.
    """
    k = card.strength
    F1, F2 = 1 / k.Xt - 1 / k.Xc, 1 / k.Yt - 1 / k.Yc  # noqa: N806
    F11, F22, F66 = 1 / (k.Xt * k.Xc), 1 / (k.Yt * k.Yc), 1 / k.S**2  # noqa: N806
    F12 = -0.5 * np.sqrt(F11 * F22)  # noqa: N806
    a = F11 * s1**2 + F22 * s2**2 + F66 * t12**2 + 2 * F12 * s1 * s2
    b = F1 * s1 + F2 * s2
    with np.errstate(divide="ignore", invalid="ignore"):
        disc = np.sqrt(np.maximum(b * b + 4 * a, 0.0))
        lam = np.where(a > 1e-300, (-b + disc) / (2 * a), np.where(b > 0, 1 / np.maximum(b, 1e-300), np.inf))
    terms = np.stack([np.abs(F1 * s1 + F11 * s1**2), np.abs(F2 * s2 + F22 * s2**2), F66 * t12**2])
    return lam, terms


def applied_force(an) -> float:  # type: ignore[no-untyped-def]
    """Magnitude of the applied load of an analysis, N (sum over its loads of the resultant's length)."""
    rb, mesh = an.resolved, an.mesh
    total = 0.0
    for load, _ in rb.loads:
        f = load_vector(mesh, an.facets, an.picked[load.name], load, rb.name).reshape(-1, mesh.dim)
        total += float(np.linalg.norm(f.sum(axis=0)))
    return total


def _discs(mesh, a0: float):  # type: ignore[no-untyped-def]
    """Sparse 0/1 ``(m, m)``: the elements whose centroids lie within ``a0`` of each other (and itself)."""
    from scipy.sparse import csr_matrix
    from scipy.spatial import cKDTree

    nc = mesh.n_corners
    cen = mesh.points[mesh.cells[:, :nc]].mean(axis=1)
    tree = cKDTree(cen)
    M = tree.sparse_distance_matrix(tree, a0, output_type="coo_matrix")  # noqa: N806
    m = len(cen)
    rows = np.concatenate([M.row, np.arange(m)])
    cols = np.concatenate([M.col, np.arange(m)])
    A = csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(m, m))  # noqa: N806
    A.data[:] = 1.0
    return A


def _rotate_strain(e: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """In-plane engineering strain ``(m, 3)`` into axes turned by ``theta`` (bead axes)."""
    c, s = np.cos(theta), np.sin(theta)
    exx, eyy, gxy = e[:, 0], e[:, 1], e[:, 2]
    e1 = c * c * exx + s * s * eyy + c * s * gxy
    e2 = s * s * exx + c * c * eyy - c * s * gxy
    g12 = 2 * c * s * (eyy - exx) + (c * c - s * s) * gxy
    return np.stack([e1, e2, g12], axis=1)


def first_failure(  # type: ignore[no-untyped-def]
    prediction, card: MaterialCard, a0: float | None = None, within: tuple[float, float, float, float] | None = None
) -> Failure:
    """First-ply failure of a bead-model prediction (module docstring).

    Parameters
    ----------
    prediction : Prediction
        From :func:`~.predict.predict` with the ``beads`` fill model (needs ``prediction.fields``).
    card : MaterialCard
    a0 : float, mm, optional
        Averaging radius; default :data:`A0_BEADS` x the median flow width of the part's beads.
    within : (x_min, y_min, x_max, y_max), mm, optional
        Check only elements whose centroid lies in this box (a coupon's gauge length: a test
        counts only a break there); default the whole part.

    Returns
    -------
    Failure
    """
    from loadpath.stiffness.beads import crossings

    an, fields, mesh = prediction.analysis, prediction.fields, prediction.mesh
    dim = mesh.dim
    m = len(mesh.cells)
    fill = fields.effective_fill()
    width = fields.extra["width"]
    if a0 is None:
        w_med = float(np.median(width[fill > 0.5])) if np.any(fill > 0.5) else 0.45
        a0 = A0_BEADS * w_med
    nv = 3 if dim == 2 else 6
    xi = np.full((1, dim), 1.0 / (dim + 1))
    eps = cell_stress(mesh, np.eye(nv), an.result.u, xi)[:, 0]  # identity D: the strain
    if dim == 3:
        eps = eps[:, [0, 1, 5]]
    has = np.any(fill > _MIN_FILL, axis=0)
    disc = _discs(mesh, a0)
    vol = np.abs(mesh.measures)
    # elements touching a support or a loaded face are not checked (module docstring)
    grip = np.zeros(len(mesh.points), dtype=bool)
    for mask in an.picked.values():
        grip[an.facets.nodes[mask].ravel()] = True
    checked = has & ~np.any(grip[mesh.cells], axis=1)
    if within is not None:
        c = mesh.points[mesh.cells[:, : mesh.n_corners]].mean(axis=1)
        x0, y0, x1, y1 = within
        checked &= (c[:, 0] >= x0) & (c[:, 0] <= x1) & (c[:, 1] >= y0) & (c[:, 1] <= y1)
    Q = card.elastic.plane_stress()  # noqa: N806
    E1 = card.elastic.E1  # noqa: N806
    Lc = crossings(fields)  # noqa: N806
    best = np.full(m, np.inf)
    best_ply = np.zeros(m, dtype=np.int64)
    best_mode = np.zeros(m, dtype=np.int64)
    for k in range(len(fields.layers)):
        theta = 0.5 * np.arctan2(fields.moments[k, :, 1], fields.moments[k, :, 0])
        e1, e2, g = _rotate_strain(eps, theta).T
        # fill models other than the bead model measure no fusion or transfer: fully fused, full length
        phi = np.clip(fields.extra["fused"][k], 0, 1) if "fused" in fields.extra else np.ones(m)
        eta = np.clip(fields.extra["transfer"][k], 0, 1) if "transfer" in fields.extra else np.ones(m)
        s1 = eta * (phi * (Q[0, 0] * e1 + Q[0, 1] * e2) + (1 - phi) * E1 * e1)
        s2 = phi * (Q[0, 1] * e1 + Q[1, 1] * e2)
        t = phi * Q[2, 2] * g
        sb = (1 - phi) * 1.5 * E1 * width[k] * np.abs(g) / np.maximum(Lc[k], width[k])
        # average stress criterion: the bead stresses of this ply averaged over its material in the disc
        wk = vol * np.minimum(fill[k], 1.0)
        den = np.maximum(disc @ wk, 1e-300)
        s1p, s1m, s2, t = ((disc @ (wk * x)) / den for x in (s1 + sb, s1 - sb, s2, t))
        sb = 0.5 * (s1p - s1m)
        lam_p, terms_p = tsai_wu_factor(s1p, s2, t, card)
        lam_m, terms_m = tsai_wu_factor(s1m, s2, t, card)
        lam = np.minimum(lam_p, lam_m)
        terms = np.where((lam_p <= lam_m)[None], terms_p, terms_m)
        mode = np.argmax(terms, axis=0)
        mode = np.where((mode == 0) & (np.abs(sb) > np.abs(0.5 * (s1p + s1m))), 3, mode)
        lam = np.where(checked & (fill[k] > _MIN_FILL), lam, np.inf)
        better = lam < best
        best = np.where(better, lam, best)
        best_ply = np.where(better, k, best_ply)
        best_mode = np.where(better, mode, best_mode)
    e = int(np.argmin(best))
    lam = float(best[e])
    nc = mesh.n_corners
    cen = mesh.points[mesh.cells[e, :nc]].mean(axis=0)
    k = int(best_ply[e])
    if dim == 2:
        layer = int(fields.layers[k])
        z0 = an.resolved.body.z_range[0]
        z = float(z0 + np.sum(fields.height[:k]) + 0.5 * fields.height[k])
        loc = (float(cen[0]), float(cen[1]), z)
    else:
        layer = -1
        loc = (float(cen[0]), float(cen[1]), float(cen[2]))
    applied = applied_force(an)
    with np.errstate(divide="ignore"):
        index = np.where(np.isfinite(best), 1.0 / best, 0.0)
    return Failure(
        load_factor=lam,
        failure_load=lam * applied,
        applied=applied,
        location=loc,
        ply=layer,
        mode=("along", "across", "shear", "bending")[int(best_mode[e])],
        index=index,
        a0=float(a0),
    )
