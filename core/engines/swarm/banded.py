"""Exact solver for the swarm's box-constrained QP with a banded Hessian.

The chain QP of the swarm (paper Eq. 12 after the change of coordinates, see :mod:`.chain`) is

    minimise    f(u) = 1/2 u^T H u + q^T u
    subject to  lo <= u <= hi

with ``H`` symmetric positive definite and banded (three super-diagonals: two unknowns per agent,
each agent coupled to its chain neighbours only).  We solve it with Bertsekas' projected Newton
method ("Projected Newton methods for optimization problems with simple constraints", SIAM J.
Control Optim. 20(2), 1982): at each iteration the variables at a bound whose gradient pushes
outward are held fixed, the Newton system on the others is solved with a banded Cholesky
factorisation (O(n) for a fixed band; compiled with numba in :mod:`.kernel_qp`, as the swarm's
whole step is), and an Armijo search along the projected arc ``clip(u + a d)`` gives global
convergence.  For a strictly convex QP the
iteration identifies the optimal active set in finitely many steps and then stops at the exact
minimiser, so the result is exact to rounding: the stopping test is the projected-gradient KKT
residual ``|u - clip(u - grad f(u))|_inf <= tol``.

``tests/engines/swarm/test_qp.py`` checks it against OSQP on many random instances.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from loadpath._typing import Floats
from loadpath.engines.swarm import kernel_qp

__all__ = ["BandedQP", "BandedResult", "solve_banded_box_qp", "banded_matvec", "banded_to_dense"]


@dataclass(frozen=True)
class BandedQP:
    """A box-constrained QP with a symmetric banded Hessian.

    Attributes
    ----------
    ab : (u + 1, n) float
        Upper band of ``H`` in LAPACK form: ``ab[u + i - j, j] = H[i, j]`` for ``i <= j``
        (``scipy.linalg.solveh_banded`` convention); the last row is the diagonal.
    q : (n,) float
        Linear term.
    lo, hi : (n,) float
        Bounds, ``lo <= hi``; ``lo == hi`` fixes a variable.
    """

    ab: np.ndarray
    q: Floats
    lo: Floats
    hi: Floats

    @property
    def n(self) -> int:
        """Number of unknowns."""
        return int(self.ab.shape[1])


@dataclass(frozen=True)
class BandedResult:
    """Solution of a :class:`BandedQP`.

    Attributes
    ----------
    x : (n,) float
        The minimiser, inside the bounds.
    objective : float
        ``1/2 x^T H x + q^T x``.
    kkt : float
        Projected-gradient residual ``|x - clip(x - grad)|_inf``.
    iterations : int
    converged : bool
        ``kkt <= tol``.
    """

    x: Floats
    objective: float
    kkt: float
    iterations: int
    converged: bool


def banded_matvec(ab: np.ndarray, x: Floats) -> Floats:
    """``H @ x`` for ``H`` given by its upper band ``ab`` (see :class:`BandedQP`)."""
    c = np.ascontiguousarray
    return kernel_qp.banded_matvec(c(ab, dtype=float), c(x, dtype=float))


def banded_to_dense(ab: np.ndarray) -> np.ndarray:
    """Return the full symmetric matrix of an upper band ``ab`` (for tests and the OSQP fallback)."""
    u = ab.shape[0] - 1
    n = ab.shape[1]
    h = np.diag(ab[u].copy())
    for k in range(1, min(u, n - 1) + 1):
        idx = np.arange(n - k)
        h[idx, idx + k] = ab[u - k, k:]
        h[idx + k, idx] = ab[u - k, k:]
    return h


def solve_banded_box_qp(
    qp: BandedQP, x0: Floats | None = None, tol: float = 1e-10, max_iter: int = 100
) -> BandedResult:
    """Minimise ``1/2 x^T H x + q^T x`` subject to ``lo <= x <= hi`` exactly (projected Newton).

    Parameters
    ----------
    qp : BandedQP
        ``H`` must be positive definite on the free variables.
    x0 : (n,) float, optional
        Warm start (clipped to the box); default: the clipped zero vector.
    tol : float
        KKT tolerance on the projected gradient, in the units of ``x``.
    max_iter : int

    Returns
    -------
    BandedResult
        ``converged`` is False if the iteration limit was hit or a factorisation failed; the
        caller then falls back to OSQP (see :mod:`.qp`).
    """
    n = qp.n
    x0 = np.zeros(n) if x0 is None else np.asarray(x0, dtype=float)
    x, f, kkt, it, ok = kernel_qp.solve_box_qp(
        *(np.ascontiguousarray(a, dtype=float) for a in (qp.ab, qp.q, qp.lo, qp.hi, x0)),
        float(tol),
        int(max_iter),
    )
    return BandedResult(x, float(f), float(kkt), int(it), bool(ok))
