"""Solve ``K u = f`` with Dirichlet conditions; the result carries its residual and is checked.

Dirichlet conditions are eliminated (``K_ff u_f = f_f - K_fc u_c``). The reduced system is solved
directly (SuperLU) when small, else by conjugate gradients preconditioned with smoothed-aggregation
algebraic multigrid (pyamg) whose near-null space is the rigid-body modes. Either way the relative
residual ``||K_ff u_f - b|| / ||b||`` is computed afterwards and must be below
``TOL.fea_residual``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from loadpath.errors import SolverError
from loadpath.fea.assembly import constitutive, stiffness
from loadpath.fea.boundary import rigid_modes
from loadpath.fea.stress import nodal_stress
from loadpath.mesh.data import MeshData
from loadpath.tolerances import TOL

__all__ = ["Problem", "FEAResult", "solve", "DIRECT_LIMIT"]

DIRECT_LIMIT = {2: 400_000, 3: 40_000}
"""Largest number of free dofs solved directly (SuperLU), per dimension; above: AMG-CG."""


@dataclass(frozen=True)
class Problem:
    """A linear-elastic problem on a mesh.

    Attributes
    ----------
    mesh : MeshData
    D : (nv, nv) or (m, nv, nv) float, MPa
        Constitutive matrix, one or one per cell.
    f : (n d,) float, N
        Nodal forces.
    fixed : (p,) int
        Constrained dofs (``node * d + component``).
    fixed_values : (p,) float, mm, optional
        Prescribed displacements of the constrained dofs; default zero.
    """

    mesh: MeshData
    D: np.ndarray
    f: np.ndarray
    fixed: np.ndarray
    fixed_values: np.ndarray | None = None


@dataclass(frozen=True)
class FEAResult:
    """A solved problem.

    Attributes
    ----------
    mesh : MeshData
    D : (nv, nv) or (m, nv, nv) float, MPa
    u : (n, d) float, mm
        Displacements.
    stress : (n, nv) float, MPa
        Recovered nodal stresses (Voigt order).
    reactions : (n, d) float, N
        ``K u - f``: the support reactions (zero at free dofs up to the residual).
    residual : float
        ``||K_ff u_f - b|| / ||b||`` of the reduced system.
    method : str
        ``"direct"`` or ``"amg-cg"``.
    iterations : int
        CG iterations (0 for the direct solver).
    times : dict
        Seconds spent in ``assemble``, ``solve``, ``stress``.
    info : dict
        Anything the caller adds (mesh statistics, the resolved load case).
    """

    mesh: MeshData
    D: np.ndarray
    u: np.ndarray
    stress: np.ndarray
    reactions: np.ndarray
    residual: float
    method: str
    iterations: int
    times: dict[str, float]
    info: dict[str, Any] = field(default_factory=dict)


def solve(problem: Problem, method: str = "auto", rtol: float = 1e-10, K: sp.spmatrix | None = None) -> FEAResult:
    """Solve a linear-elastic problem.

    Parameters
    ----------
    problem : Problem
    method : {"auto", "direct", "amg-cg"}
        ``"auto"``: direct up to :data:`DIRECT_LIMIT` free dofs.
    rtol : float
        Relative residual requested from the iterative solver.
    K : sparse matrix, optional
        The assembled stiffness, if the caller has it.

    Returns
    -------
    FEAResult

    Raises
    ------
    SolverError
        Singular system or residual above ``TOL.fea_residual``.
    """
    mesh = problem.mesh
    d = mesh.dim
    n = len(mesh.points) * d
    t0 = time.perf_counter()
    if K is None:
        K = stiffness(mesh, problem.D)
    t1 = time.perf_counter()
    fixed = np.asarray(problem.fixed, dtype=np.int64)
    vals = np.zeros(len(fixed)) if problem.fixed_values is None else np.asarray(problem.fixed_values, dtype=float)
    order = np.argsort(fixed, kind="stable")
    fixed, vals = fixed[order], vals[order]
    uniq, first = np.unique(fixed, return_index=True)
    fixed, vals = uniq, vals[first]
    # dofs no cell touches (e.g. isolated nodes) are fixed at zero so K_ff stays regular
    touched = np.zeros(n, dtype=bool)
    touched[(mesh.cells[:, :, None] * d + np.arange(d)).ravel()] = True
    free_mask = touched.copy()
    free_mask[fixed] = False
    free = np.flatnonzero(free_mask)
    u = np.zeros(n)
    u[fixed] = vals
    f = np.asarray(problem.f, dtype=float).ravel()
    b = f[free] - K[free][:, fixed] @ vals if len(fixed) else f[free]
    A = K[free][:, free].tocsr()
    nb = float(np.linalg.norm(b))
    if nb == 0.0:
        raise SolverError("the load vector is zero: no load reaches the free part of the mesh; check the load selectors")
    if method == "auto":
        method = "direct" if len(free) <= DIRECT_LIMIT[d] else "amg-cg"
    iters = 0
    if method == "direct":
        with np.errstate(all="ignore"):
            try:
                x = spla.spsolve(A.tocsc(), b, permc_spec="MMD_AT_PLUS_A")
            except RuntimeError as exc:  # SuperLU: "Factor is exactly singular"
                raise SolverError(f"the stiffness matrix is singular ({exc}); the part is not held against rigid motion") from exc
    elif method == "amg-cg":
        x, iters = _amg_cg(A, b, mesh, free, rtol)
    else:
        raise ValueError(f"method must be 'auto', 'direct' or 'amg-cg', not {method!r}")
    t2 = time.perf_counter()
    if not np.all(np.isfinite(x)):
        raise SolverError("the FEA solution is not finite; the stiffness matrix is singular (is the part held?)")
    res = float(np.linalg.norm(A @ x - b) / nb)
    if res > TOL.fea_residual:
        raise SolverError(
            f"the FEA solve did not converge: relative residual {res:.2e} > {TOL.fea_residual:.0e} ({method}, {iters} iterations); "
            "try a coarser mesh or check that the part is held"
        )
    u[free] = x
    reactions = (K @ u - f).reshape(-1, d)
    U = u.reshape(-1, d)
    stress = nodal_stress(mesh, problem.D, U)
    t3 = time.perf_counter()
    return FEAResult(
        mesh=mesh,
        D=np.asarray(problem.D) if np.ndim(problem.D) == 2 else constitutive(problem.D, mesh),
        u=U,
        stress=stress,
        reactions=reactions,
        residual=res,
        method=method,
        iterations=iters,
        times={"assemble": t1 - t0, "solve": t2 - t1, "stress": t3 - t2},
    )


def _amg_cg(A: sp.csr_matrix, b: np.ndarray, mesh: MeshData, free: np.ndarray, rtol: float) -> tuple[np.ndarray, int]:
    try:
        import pyamg
    except ImportError as exc:  # pragma: no cover
        raise SolverError("pyamg is needed for large FEA problems: pip install pyamg") from exc
    modes, _ = rigid_modes(mesh.points)
    B = np.ascontiguousarray(modes[free])
    ml = pyamg.smoothed_aggregation_solver(
        A,
        B=B,
        symmetry="symmetric",
        strength=("symmetric", {"theta": 0.0}),
        smooth=("jacobi", {"omega": 4.0 / 3.0, "degree": 1}),
        max_coarse=2000,
    )
    residuals: list[float] = []
    x = ml.solve(b, tol=rtol, accel="cg", maxiter=2000, residuals=residuals)
    return np.asarray(x), max(len(residuals) - 1, 0)
