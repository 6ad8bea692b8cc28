"""The swarm's QP solves: the exact banded solver first, OSQP as reference and fallback.

This is the only module of loadpath that imports OSQP (house style §2.10).  OSQP's defaults
(``eps_abs = eps_rel = 1e-3``) visibly violate bounds (``real-tools.md`` §2), so it runs with the
tolerances of :data:`loadpath.tolerances.TOL` (in the scaled coordinates of the swarm: displacement
divided by the step ``h``, so they are small against the ``1/8`` box whatever the part's size and
position), with polishing, and its answer is clipped to the box and checked.

:func:`solve` runs :func:`~.banded.solve_banded_box_qp`; if that does not converge it falls back
to OSQP; if OSQP does not report ``solved`` either it raises :class:`~loadpath.errors.SolverError`.
Every call returns its status.  The swarm's compiled step (:mod:`.kernel_step`) runs the same
exact solver inside the step and calls :func:`osqp_fallback` (numba's object mode) for a QP it
does not finish, with the same checks.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from loadpath._typing import Floats
from loadpath.engines.swarm.banded import BandedQP, banded_matvec, solve_banded_box_qp
from loadpath.errors import SolverError, ToolMissingError
from loadpath.tolerances import TOL

__all__ = ["QPSolution", "solve", "solve_osqp", "osqp_fallback", "banded_to_csc"]

_BANDED_TOL = 1e-10


def _osqp_major() -> int:
    try:
        from importlib.metadata import version

        return int(version("osqp").split(".")[0])
    except Exception:  # pragma: no cover - metadata missing
        return 1


# OSQP 1.x renamed "polish" to "polishing" and warns that solve() will start raising on failure;
# we check the status ourselves, so ask it not to raise.
_POLISH = {"polishing": True} if _osqp_major() >= 1 else {"polish": True}
_SOLVE_KW = {"raise_error": False} if _osqp_major() >= 1 else {}


@dataclass(frozen=True)
class QPSolution:
    """Result of one swarm QP.

    Attributes
    ----------
    x : (n,) float
        Minimiser, inside the box.
    objective : float
        ``1/2 x^T H x + q^T x``.
    status : str
        ``"exact"`` (banded projected Newton converged), ``"osqp:solved"`` (fallback), ...
    kkt : float
        Projected-gradient residual of ``x``.
    iterations : int
    """

    x: Floats
    objective: float
    status: str
    kkt: float
    iterations: int


def banded_to_csc(ab: np.ndarray) -> sp.csc_matrix:
    """Upper triangle of the banded Hessian as a CSC matrix (what OSQP takes)."""
    u = ab.shape[0] - 1
    n = ab.shape[1]
    ks = list(range(min(u, n - 1) + 1))
    diags = [ab[u - k, k:] for k in ks]
    return sp.diags(diags, ks, shape=(n, n), format="csc")


def _kkt(qp: BandedQP, x: Floats) -> float:
    g = banded_matvec(qp.ab, x) + qp.q
    return float(np.max(np.abs(x - np.clip(x - g, qp.lo, qp.hi)), initial=0.0))


def _setup(solver: object, qp: BandedQP, n: int) -> None:
    solver.setup(  # type: ignore[attr-defined]
        banded_to_csc(qp.ab),
        np.asarray(qp.q, dtype=float),
        sp.identity(n, format="csc"),
        qp.lo,
        qp.hi,
        verbose=False,
        eps_abs=TOL.qp_eps_abs,
        eps_rel=TOL.qp_eps_rel,
        max_iter=200_000,
        **_POLISH,
    )


def solve_osqp(qp: BandedQP, x0: Floats | None = None) -> QPSolution:
    """Solve the QP with OSQP (tight tolerances, polish), clip to the box, check the status.

    Parameters
    ----------
    qp : BandedQP
    x0 : (n,) float, optional
        Warm start.

    Returns
    -------
    QPSolution

    Raises
    ------
    SolverError
        If OSQP's status is not ``solved``.
    ToolMissingError
        If OSQP is not installed.
    """
    try:
        import osqp
    except ImportError as exc:  # pragma: no cover - osqp is a hard dependency
        raise ToolMissingError("the swarm engine needs OSQP: pip install osqp qpsolvers") from exc
    n = qp.n
    solver = osqp.OSQP()
    try:
        _setup(solver, qp, n)
        if x0 is not None:
            solver.warm_start(x=np.clip(x0, qp.lo, qp.hi))
        res = solver.solve(**_SOLVE_KW)
    except (ValueError, RuntimeError, getattr(osqp, "OSQPException", RuntimeError)) as exc:
        raise SolverError(
            f"OSQP rejected a swarm QP with {n} unknowns ({exc}); the bounds or the stress field are "
            "inconsistent (check the field for NaN inside the region)"
        ) from exc
    status = str(res.info.status)
    if status != "solved" or res.x is None or not np.all(np.isfinite(res.x)):
        raise SolverError(
            f"OSQP returned status {status!r} on a swarm QP with {n} unknowns; "
            "the stress field may contain NaN or the region is degenerate (check the field and the pitch)"
        )
    x = np.clip(np.asarray(res.x, dtype=float), qp.lo, qp.hi)
    hx = banded_matvec(qp.ab, x)
    obj = 0.5 * float(x @ hx) + float(qp.q @ x)
    return QPSolution(x, obj, "osqp:" + status, _kkt(qp, x), int(res.info.iter))


def solve(qp: BandedQP, x0: Floats | None = None) -> QPSolution:
    """Solve one swarm QP: exact banded solver, OSQP if it does not converge.

    Parameters
    ----------
    qp : BandedQP
    x0 : (n,) float, optional
        Warm start.

    Returns
    -------
    QPSolution

    Raises
    ------
    SolverError
        If the data are not finite or both solvers fail.
    """
    _check_finite(qp)
    res = solve_banded_box_qp(qp, x0, tol=_BANDED_TOL)
    if res.converged:
        return QPSolution(res.x, res.objective, "exact", res.kkt, res.iterations)
    return solve_osqp(qp, x0)


def _check_finite(qp: BandedQP) -> None:
    if not (np.all(np.isfinite(qp.ab)) and np.all(np.isfinite(qp.q))):
        raise SolverError("a swarm QP has non-finite data; the stress field returned NaN inside the region")


def osqp_fallback(ab: np.ndarray, q: Floats, lo: Floats, hi: Floats) -> Floats:
    """Solve a swarm QP the exact solver did not finish with OSQP; the compiled step calls this.

    Parameters
    ----------
    ab : (4, n) float
        Upper band of the Hessian (see :class:`~.banded.BandedQP`).
    q, lo, hi : (n,) float

    Returns
    -------
    (n,) float
        The minimiser, C-contiguous.

    Raises
    ------
    SolverError
        If the data are not finite or OSQP does not report ``solved``.
    """
    qp = BandedQP(np.asarray(ab), np.asarray(q), np.asarray(lo), np.asarray(hi))
    _check_finite(qp)
    return np.ascontiguousarray(solve_osqp(qp).x, dtype=float)
