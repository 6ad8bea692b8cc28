"""Exact solver for the swarm's box-constrained QP with a banded Hessian.

The chain QP of the swarm (paper Eq. 12 after the change of coordinates, see :mod:`.chain`) is

    minimise    f(u) = 1/2 u^T H u + q^T u
    subject to  lo <= u <= hi

with ``H`` symmetric positive definite and banded (three super-diagonals: two unknowns per agent,
each agent coupled to its chain neighbours only).  We solve it with Bertsekas' projected Newton
method ("Projected Newton methods for optimization problems with simple constraints", SIAM J.
Control Optim. 20(2), 1982): at each iteration the variables at a bound whose gradient pushes
outward are held fixed, the Newton system on the others is solved with a banded Cholesky
factorisation (LAPACK ``dpbsv``: O(n) for a fixed band), and an Armijo search along
the projected arc ``clip(u + a d)`` gives global convergence.  For a strictly convex QP the
iteration identifies the optimal active set in finitely many steps and then stops at the exact
minimiser, so the result is exact to rounding: the stopping test is the projected-gradient KKT
residual ``|u - clip(u - grad f(u))|_inf <= tol``.

``tests/engines/swarm/test_banded.py`` checks it against OSQP on many random instances.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from loadpath._typing import Floats
from scipy.linalg import lapack

__all__ = ["BandedQP", "BandedResult", "solve_banded_box_qp", "banded_matvec", "banded_to_dense"]

_ARMIJO = 1e-4
_MAX_BACKTRACK = 30


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
    u = ab.shape[0] - 1
    n = ab.shape[1]
    y = ab[u] * x
    for k in range(1, min(u, n - 1) + 1):
        # H[i, i + k] = ab[u - k, i + k]
        band = ab[u - k, k:]
        y[: n - k] += band * x[k:]
        y[k:] += band * x[: n - k]
    return y


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


def _reduced(ab: np.ndarray, fixed: np.ndarray) -> np.ndarray:
    """Return the band with the rows and columns of fixed variables replaced by the identity's."""
    u = ab.shape[0] - 1
    out = ab.copy()
    if not np.any(fixed):
        return out
    out[u, fixed] = 1.0
    n = ab.shape[1]
    for k in range(1, min(u, n - 1) + 1):
        # entry (i, i + k) sits in column i + k; zero it if i or i + k is fixed
        kill = fixed[k:] | fixed[: n - k]
        out[u - k, k:][kill] = 0.0
    return out


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
    lo, hi, q, ab = qp.lo, qp.hi, qp.q, qp.ab
    n = qp.n
    x = np.clip(np.zeros(n) if x0 is None else np.asarray(x0, dtype=float), lo, hi)
    hx = banded_matvec(ab, x)
    g = hx + q
    f = 0.5 * float(x @ hx) + float(q @ x)
    pinned = lo >= hi
    kkt = float("inf")
    it = 0
    for it in range(1, max_iter + 1):  # noqa: B007 (the count is reported)
        kkt = float(np.abs(x - np.minimum(np.maximum(x - g, lo), hi)).max(initial=0.0))
        if kkt <= tol:
            return BandedResult(x, f, kkt, it - 1, True)
        # epsilon-binding set: at (or within eps of) a bound with the gradient pushing outward
        eps = min(kkt, 1e-3)
        fixed = pinned | ((x <= lo + eps) & (g > 0)) | ((x >= hi - eps) & (g < 0))
        rhs = np.where(fixed, 0.0, -g)
        # banded Cholesky solve (LAPACK dpbsv, the routine behind scipy's solveh_banded, called
        # directly: the wrapper's checks cost more than the O(n) factorisation at these sizes)
        _, d, info = lapack.dpbsv(_reduced(ab, fixed), rhs)
        if info != 0:
            return BandedResult(x, f, kkt, it, False)
        # on the fixed variables take a projected-gradient step so the arc can leave the bound
        d = np.where(fixed & ~pinned, -g, d)
        alpha = 1.0
        for _ in range(_MAX_BACKTRACK):
            xn = np.minimum(np.maximum(x + alpha * d, lo), hi)
            hxn = banded_matvec(ab, xn)
            fn = 0.5 * float(xn @ hxn) + float(q @ xn)
            # Armijo along the projected arc (Bertsekas 1982, eq. 32)
            dec = float(g @ (x - xn))
            if fn <= f - _ARMIJO * max(dec, 0.0):
                break
            alpha *= 0.5
        else:
            return BandedResult(x, f, kkt, it, False)
        x, hx, f = xn, hxn, fn
        g = hx + q
    kkt = float(np.max(np.abs(x - np.clip(x - g, lo, hi)), initial=0.0))
    return BandedResult(x, f, kkt, it, kkt <= tol)
