"""The swarm potential of chains of agents as a banded, box-constrained QP (paper Eq. 3-12).

Change of coordinates (paper Sec. III-B5, "all constraints can be transformed into input bounds").
Every agent ``j`` gets a local orthonormal frame ``B_j = [e1_j, e2_j]`` and its position is

    x_j = t_j + h B_j u_j,      lo_j <= u_j <= hi_j

where ``t_j`` is its ideal location (Eq. 2) and ``h`` the step.  For a moving agent ``e1 = s_hat``
(the stress direction it stepped along) and ``e2 = s_hat^perp``, and the box of Eq. 12 becomes
``|u1| <= 1/4`` (``h/4`` along the stress) and ``|u2| <= 1/8`` (``h/8`` across it).  A boundary agent
moves along the boundary: ``e1`` is the boundary tangent at its reference point, ``u1`` is bounded
by ``+-1/2`` and ``u2`` is pinned to 0 (it is projected back onto the boundary afterwards).
Everything is divided by ``h``, so the unknowns are O(1) wherever the part sits on the bed.

Potentials (scaled by ``1/h^2``):

* environment, Eq. 3 with the squared norm (benchmarks.md §1.5): ``K m_j |x_j - t_j|^2 / h^2 =
  K m_j |u_j|^2`` (``B_j`` is orthonormal); boundary agents have none (Eq. 10 sums over 1..N);
* aggregation, Eq. 7-9, for a linked pair ``(j, j+1)`` with radial unit vector ``d`` (Eq. 5-6):
  ``(v.d - L)^2 + |v - (v.d) d|^2 = |v - L d|^2`` with ``v = (x_{j+1} - x_j) / h``; ``L = l / h = 1``
  between moving agents and ``1/2`` between a boundary agent and its neighbour (our boundary is
  the edge of the region to fill, so the first bead's edge, not its centre, lies on it).

So ``P = sum_pairs |c_p + B_{j+1} u_{j+1} - B_j u_j|^2 + K sum_j m_j |u_j|^2`` with
``c_p = (t_{j+1} - t_j) / h - L_p d_p``: a QP whose Hessian is block tridiagonal (three
super-diagonals in the scalar unknowns ``u = [u_0^1, u_0^2, u_1^1, ...]``), whatever the number
of chains (unlinked neighbours simply have no coupling).

The assembly and the potentials are the compiled kernels of :mod:`.kernel_qp` (the swarm's step
calls them directly); this module is their documented Python face, used by the tests.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from loadpath._typing import Bools, Floats, Points2
from loadpath.engines.swarm import kernel_qp
from loadpath.engines.swarm.banded import BandedQP

__all__ = ["ChainProblem", "build_qp", "potentials", "positions", "MASS_FLOOR", "WEIGHT_FLOOR"]

MASS_FLOOR = 1e-3
"""Smallest virtual mass used in the QP, so the Hessian stays positive definite where the stress
vanishes (there the aggregation term alone decides, as it should)."""

WEIGHT_FLOOR = 1e-4
"""Smallest environment weight ``K m`` of an agent in the QP.  With ``K = 0`` (spacing only) a
chain that no boundary agent anchors can slide as a whole at no cost: the Hessian is singular, the
exact solver cannot factor it and OSQP stops at its iteration limit.  The floor pins that slide to
the ideal locations; it changes nothing for ``K >= 0.1`` (``0.1 MASS_FLOOR`` is already 1e-4)."""

BOX_ALONG = 0.25
BOX_ACROSS = 0.125
BOUNDARY_SLIDE = 0.5


@dataclass(frozen=True)
class ChainProblem:
    """Agents of one or several chains, in chain order, in coordinates scaled by ``h``.

    Attributes
    ----------
    t : (n, 2) float
        Ideal locations divided by ``h`` (boundary agents: their reference point on the boundary).
    frame : (n, 2, 2) float
        ``frame[j] = [e1_j, e2_j]`` as rows: the local orthonormal frame of each agent, ``e2_j`` is
        ``e1_j`` turned by +90 degrees.
    lo, hi : (n, 2) float
        Bounds on ``u_j`` in that frame.
    weight : (n,) float
        ``K m_j`` (0 for boundary agents).
    link : (n - 1,) bool
        ``link[j]``: agents ``j`` and ``j + 1`` are neighbours (aggregation term).
    radial : (n - 1, 2) float
        Unit radial direction ``d`` of each pair (unused where not linked).
    target : (n - 1,) float
        Desired radial distance ``L`` of each pair, in units of ``h``.
    """

    t: Points2
    frame: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    weight: Floats
    link: Bools
    radial: np.ndarray
    target: Floats

    @property
    def n(self) -> int:
        """Number of agents."""
        return int(self.t.shape[0])


def _arrays(cp: ChainProblem) -> tuple[np.ndarray, ...]:
    c = np.ascontiguousarray
    return (
        c(cp.t, dtype=float),
        c(cp.frame[:, 0, :], dtype=float),
        c(cp.weight, dtype=float),
        c(cp.link, dtype=np.bool_),
        c(cp.radial, dtype=float).reshape(-1, 2),
        c(cp.target, dtype=float),
    )


def build_qp(cp: ChainProblem) -> tuple[BandedQP, float]:
    """Assemble the banded QP of the chains.

    Returns
    -------
    qp : BandedQP
        Unknowns ``u`` flattened agent by agent (2 per agent); ``P(u) = 1/2 u^T H u + q^T u + c0``.
    c0 : float
        The constant term, so ``P`` itself can be compared between swarms.
    """
    ab, q, c0 = kernel_qp.chain_qp(*_arrays(cp))
    qp = BandedQP(ab=ab, q=q, lo=cp.lo.ravel().astype(float), hi=cp.hi.ravel().astype(float))
    return qp, float(c0)


def positions(cp: ChainProblem, u: Floats) -> Points2:
    """Scaled positions ``t_j + B_j u_j`` of the agents, (n, 2)."""
    t, e1 = _arrays(cp)[:2]
    return kernel_qp.chain_positions(t, e1, np.ascontiguousarray(u, dtype=float))


def potentials(cp: ChainProblem, u: Floats) -> tuple[Floats, Floats]:
    """Potential of each pair and of each agent at the solution.

    Returns
    -------
    pair : (n - 1,) float
        ``|v - L d|^2`` for linked pairs, 0 otherwise.
    agent : (n,) float
        ``K m_j |u_j|^2``.
    """
    return kernel_qp.chain_potentials(*_arrays(cp), np.ascontiguousarray(u, dtype=float))
