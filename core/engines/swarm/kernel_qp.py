"""Compiled kernels of the swarm's QP: the chain QP (Eq. 3-12) and its exact banded solver.

The swarm solves one small QP per step (a few hundred unknowns); numpy spends more time entering
and leaving its calls than computing, so the QP is assembled and solved here, compiled by numba
(``cache=True``: the machine compiles once, later processes load the machine code).

* :func:`chain_qp` assembles the banded QP of a chain table (see :mod:`.chain` for the change of
  coordinates and the formulas);
* :func:`solve_box_qp` is Bertsekas' projected Newton method with a banded Cholesky factorisation
  (see :mod:`.banded`), exact to rounding;
* :func:`chain_potentials` gives the potential of every pair and agent at a solution (Eq. 13).

The kernels never raise: :func:`solve_box_qp` reports ``converged``; the callers in :mod:`.qp`
and :mod:`.kernel_step` fall back to OSQP when it is False.
"""

from __future__ import annotations

import numpy as np
from loadpath.engines.swarm._jit import njit, njit_inline

__all__ = ["banded_matvec", "solve_box_qp", "chain_qp", "chain_potentials"]

_ARMIJO = 1e-4
_MAX_BACKTRACK = 30


@njit
def banded_matvec(ab: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``H @ x`` for ``H`` given by its upper band ``ab`` (LAPACK upper storage), (n,)."""
    u = ab.shape[0] - 1
    n = ab.shape[1]
    y = ab[u] * x
    for k in range(1, min(u, n - 1) + 1):
        # H[i, i + k] = ab[u - k, i + k]; same order of additions as the numpy version
        for i in range(n - k):
            y[i] += ab[u - k, i + k] * x[i + k]
        for i in range(n - k):
            y[i + k] += ab[u - k, i + k] * x[i]
    return y


@njit_inline
def _dot(a: np.ndarray, b: np.ndarray) -> float:
    s = 0.0
    for i in range(a.shape[0]):
        s += a[i] * b[i]
    return s


@njit
def _factor_solve(ab: np.ndarray, fixed: np.ndarray, rhs: np.ndarray, work: np.ndarray) -> bool:
    """Solve ``A d = rhs`` in place, ``A`` the band with fixed rows/columns replaced by the identity's.

    Banded Cholesky ``A = U^T U`` (U upper, stored like ``ab``; LAPACK ``dpbtrf``/``dpbtrs``).
    Returns False if ``A`` is not positive definite.
    """
    u = ab.shape[0] - 1
    n = ab.shape[1]
    for j in range(n):
        for r in range(u + 1):
            i = j - u + r
            v = ab[r, j]
            if i >= 0 and i != j and (fixed[i] or fixed[j]):
                v = 0.0
            elif i == j and fixed[j]:
                v = 1.0
            work[r, j] = v
    for j in range(n):
        i0 = max(0, j - u)
        for i in range(i0, j):
            s = work[u + i - j, j]
            for k in range(i0, i):
                s -= work[u + k - i, i] * work[u + k - j, j]
            work[u + i - j, j] = s / work[u, i]
        s = work[u, j]
        for k in range(i0, j):
            s -= work[u + k - j, j] * work[u + k - j, j]
        if not s > 0.0:
            return False
        work[u, j] = np.sqrt(s)
    # U^T y = rhs
    for j in range(n):
        s = rhs[j]
        for k in range(max(0, j - u), j):
            s -= work[u + k - j, j] * rhs[k]
        rhs[j] = s / work[u, j]
    # U d = y
    for j in range(n - 1, -1, -1):
        s = rhs[j]
        for k in range(j + 1, min(n, j + u + 1)):
            s -= work[u + j - k, k] * rhs[k]
        rhs[j] = s / work[u, j]
    return True


@njit_inline
def _kkt(x: np.ndarray, g: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> float:
    k = 0.0
    for i in range(x.shape[0]):
        v = abs(x[i] - min(max(x[i] - g[i], lo[i]), hi[i]))
        if v > k:
            k = v
    return k


@njit
def solve_box_qp(
    ab: np.ndarray, q: np.ndarray, lo: np.ndarray, hi: np.ndarray, x0: np.ndarray, tol: float, max_iter: int
) -> tuple[np.ndarray, float, float, int, bool]:
    """Minimise ``1/2 x^T H x + q^T x`` subject to ``lo <= x <= hi`` (projected Newton, exact).

    Parameters
    ----------
    ab : (u + 1, n) float
        Upper band of ``H`` (LAPACK storage: ``ab[u + i - j, j] = H[i, j]``, ``i <= j``).
    q, lo, hi : (n,) float
    x0 : (n,) float
        Start (clipped to the box).
    tol : float
        Stop when the projected-gradient residual ``|x - clip(x - grad)|_inf <= tol``.
    max_iter : int

    Returns
    -------
    x : (n,) float
    objective : float
    kkt : float
    iterations : int
    converged : bool
    """
    n = ab.shape[1]
    x = np.minimum(np.maximum(x0, lo), hi)
    hx = banded_matvec(ab, x)
    g = hx + q
    f = 0.5 * _dot(x, hx) + _dot(q, x)
    pinned = lo >= hi
    fixed = np.zeros(n, dtype=np.bool_)
    d = np.zeros(n)
    xn = np.zeros(n)
    work = np.zeros(ab.shape)
    kkt = np.inf
    it = 0
    for it in range(1, max_iter + 1):
        kkt = _kkt(x, g, lo, hi)
        if kkt <= tol:
            return x, f, kkt, it - 1, True
        # epsilon-binding set: at (or within eps of) a bound with the gradient pushing outward
        eps = min(kkt, 1e-3)
        for i in range(n):
            fixed[i] = pinned[i] or (x[i] <= lo[i] + eps and g[i] > 0) or (x[i] >= hi[i] - eps and g[i] < 0)
            d[i] = 0.0 if fixed[i] else -g[i]
        if not _factor_solve(ab, fixed, d, work):
            return x, f, kkt, it, False
        # on the fixed variables a projected-gradient step, so the arc can leave the bound
        for i in range(n):
            if fixed[i] and not pinned[i]:
                d[i] = -g[i]
        alpha = 1.0
        ok = False
        hxn = hx
        fn = f
        for _ in range(_MAX_BACKTRACK):
            for i in range(n):
                xn[i] = min(max(x[i] + alpha * d[i], lo[i]), hi[i])
            hxn = banded_matvec(ab, xn)
            fn = 0.5 * _dot(xn, hxn) + _dot(q, xn)
            # Armijo along the projected arc (Bertsekas 1982, eq. 32)
            dec = 0.0
            for i in range(n):
                dec += g[i] * (x[i] - xn[i])
            if fn <= f - _ARMIJO * max(dec, 0.0):
                ok = True
                break
            alpha *= 0.5
        if not ok:
            return x, f, kkt, it, False
        x, xn = xn, x
        hx = hxn
        f = fn
        g = hx + q
    kkt = _kkt(x, g, lo, hi)
    return x, f, kkt, it, kkt <= tol


@njit
def chain_qp(
    t: np.ndarray,
    e1: np.ndarray,
    weight: np.ndarray,
    link: np.ndarray,
    radial: np.ndarray,
    target: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, float]:
    """Banded QP of chains of agents in scaled coordinates (see :mod:`.chain`).

    Parameters
    ----------
    t : (n, 2) float
        Ideal locations / h.
    e1 : (n, 2) float
        First frame vector of each agent (``e2`` is ``e1`` turned by +90 degrees).
    weight : (n,) float
        ``K m_j`` (0 for boundary agents).
    link : (n - 1,) bool
    radial : (n - 1, 2) float
    target : (n - 1,) float

    Returns
    -------
    ab : (4, 2n) float
        Upper band of the Hessian.
    q : (2n,) float
    c0 : float
        Constant term: ``P(u) = 1/2 u^T H u + q^T u + c0``.
    """
    n = t.shape[0]
    ab = np.zeros((4, 2 * n))
    q = np.zeros(2 * n)
    c0 = 0.0
    for j in range(n):
        nl = 0.0
        if j < n - 1 and link[j]:
            nl += 1.0
        if j > 0 and link[j - 1]:
            nl += 1.0
        dg = 2.0 * (nl + weight[j])
        ab[3, 2 * j] = dg
        ab[3, 2 * j + 1] = dg
    for j in range(n - 1):
        if not link[j]:
            continue
        # frames are rotations: e1 = (c, s), e2 = (-s, c); the off-diagonal block -2 B_j^T B_{j+1}
        c_a, s_a = e1[j, 0], e1[j, 1]
        c_b, s_b = e1[j + 1, 0], e1[j + 1, 1]
        C = -2.0 * (c_a * c_b + s_a * s_b)
        S = -2.0 * (s_a * c_b - c_a * s_b)
        ab[1, 2 * j + 2] = C
        ab[0, 2 * j + 3] = S
        ab[2, 2 * j + 2] = -S
        ab[1, 2 * j + 3] = C
        ox = t[j + 1, 0] - t[j, 0] - target[j] * radial[j, 0]
        oy = t[j + 1, 1] - t[j, 1] - target[j] * radial[j, 1]
        q[2 * j + 2] += 2.0 * (c_b * ox + s_b * oy)
        q[2 * j + 3] += 2.0 * (c_b * oy - s_b * ox)
        q[2 * j] -= 2.0 * (c_a * ox + s_a * oy)
        q[2 * j + 1] -= 2.0 * (c_a * oy - s_a * ox)
        c0 += ox * ox + oy * oy
    return ab, q, c0


@njit
def chain_positions(t: np.ndarray, e1: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Scaled positions ``t_j + u_j1 e1_j + u_j2 e2_j``, (n, 2)."""
    n = t.shape[0]
    x = np.zeros((n, 2))
    for j in range(n):
        a, b = u[2 * j], u[2 * j + 1]
        x[j, 0] = t[j, 0] + a * e1[j, 0] + b * -e1[j, 1]
        x[j, 1] = t[j, 1] + a * e1[j, 1] + b * e1[j, 0]
    return x


@njit
def chain_potentials(
    t: np.ndarray,
    e1: np.ndarray,
    weight: np.ndarray,
    link: np.ndarray,
    radial: np.ndarray,
    target: np.ndarray,
    u: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Potential of each pair ``|v - L d|^2`` (0 unlinked) and agent ``K m |u|^2`` at ``u``."""
    n = t.shape[0]
    x = chain_positions(t, e1, u)
    pair = np.zeros(max(n - 1, 0))
    agent = np.zeros(n)
    for j in range(n - 1):
        if link[j]:
            ax = x[j + 1, 0] - x[j, 0] - target[j] * radial[j, 0]
            ay = x[j + 1, 1] - x[j, 1] - target[j] * radial[j, 1]
            pair[j] = ax * ax + ay * ay
    for j in range(n):
        a, b = u[2 * j], u[2 * j + 1]
        agent[j] = weight[j] * (a * a + b * b)
    return pair, agent
