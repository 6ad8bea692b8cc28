"""Solve ``K u = f`` with Dirichlet conditions; the result carries its residual and is checked.

Dirichlet conditions are eliminated (``K_ff u_f = f_f - K_fc u_c``). The reduced system is solved
directly (SuperLU) when small, else by conjugate gradients preconditioned with smoothed-aggregation
algebraic multigrid (pyamg) whose near-null space is the rigid-body modes. Either way the relative
residual ``||K_ff u_f - b|| / ||b||`` is computed afterwards and must be below
``TOL.fea_residual``.

Conjugate gradients updates its residual by recurrence, which drifts from the true residual by
about ``eps * cond(K)`` (Greenbaum 1997, *Iterative Methods for Solving Linear Systems*, §7.3): on
ill-conditioned parts (thin wedges, slivers) CG can report convergence while ``b - K u`` is still
above the tolerance. So CG checks the true residual when its recurrence converges and, if it is
too large, restarts from there (residual replacement); if that still does not reach the
tolerance, a system small enough is solved directly instead. The result says which
(``FEAResult.status``), and the residual is checked in every case.

The multigrid set-up draws random vectors from numpy's global generator (pyamg's spectral radius
estimates and evolution strength). A different draw gives a different preconditioner, so CG stops
at a different point within the tolerance; the paths that follow the field then differ from run to
run. So the set-up runs under a fixed seed (:func:`_seeded`), and the caller's generator state is
restored afterwards: the same system always gives the same bytes.
"""

from __future__ import annotations

import contextlib
import math
import os
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from loadpath import budget
from loadpath._lazy import lazy
from loadpath.errors import SolverError
from loadpath.fea.assembly import constitutive, stiffness
from loadpath.fea.boundary import rigid_modes
from loadpath.fea.elements import ELEMENTS
from loadpath.fea.stress import nodal_stress
from loadpath.mesh.data import MeshData
from loadpath.tolerances import TOL

sp = lazy("scipy.sparse")  # imported when a problem is solved, not when a cached result is loaded
spla = lazy("scipy.sparse.linalg")

__all__ = ["Problem", "FEAResult", "solve", "DIRECT_LIMIT", "FALLBACK_LIMIT", "direct_fill_bytes"]
__all__ += ["symmetric_lu"]

DIRECT_LIMIT = {2: 150_000, 3: 15_000}
"""Largest number of free dofs solved directly (SuperLU), per dimension; above: AMG-CG."""

FALLBACK_LIMIT = {2: 600_000, 3: 150_000}
"""Largest number of free dofs solved directly when AMG-CG misses the tolerance (SuperLU's fill
of a 3D quadratic mesh grows fast: about 3 GB at 150 000 dofs); above: the solve fails."""

_CG_RESTARTS = 3


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
        ``"direct"``, ``"amg-cg"``, or ``"amg-cg+direct"`` (CG missed the tolerance, solved directly).
    iterations : int
        CG iterations (0 for the direct solver).
    times : dict
        Seconds spent in ``assemble``, ``solve``, ``stress``.
    info : dict
        Anything the caller adds (mesh statistics, the resolved load case).
    status : str
        How the solve ended, e.g. ``"converged"``, ``"converged after 1 restart"``, or why CG fell
        back to the direct solver; always with ``residual`` below ``TOL.fea_residual``.
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
    status: str = "converged"


def solve(
    problem: Problem,
    method: str = "auto",
    rtol: float = 0.1 * TOL.fea_residual,
    K: sp.spmatrix | None = None,
    maxiter: int = 1000,
) -> FEAResult:
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
    maxiter : int
        Most CG iterations; a CG solve that misses the tolerance is finished directly when the
        system has at most :data:`FALLBACK_LIMIT` free dofs.

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
    vals = (
        np.zeros(len(fixed))
        if problem.fixed_values is None
        else np.asarray(problem.fixed_values, dtype=float)
    )
    order = np.argsort(fixed, kind="stable")
    fixed, vals = fixed[order], vals[order]
    uniq, first = np.unique(fixed, return_index=True)
    fixed, vals = uniq, vals[first]
    # dofs no cell touches (e.g. isolated nodes) are fixed at zero so the reduced matrix stays regular
    touched = np.zeros(n, dtype=bool)
    touched[(mesh.cells[:, :, None] * d + np.arange(d)).ravel()] = True
    free_mask = touched.copy()
    free_mask[fixed] = False
    free = np.flatnonzero(free_mask)
    u = np.zeros(n)
    u[fixed] = vals
    f = np.asarray(problem.f, dtype=float).ravel()
    b = (f - K @ u)[free]
    nb = float(np.linalg.norm(b))
    if nb == 0.0:
        raise SolverError(
            "the load vector is zero: no load reaches the free part of the mesh (every loaded node is "
            "held by a support: do a load and a support select the same edge?); check the load case's "
            "[[loads]] and [[supports]] selectors"
        )
    fits = direct_fill_bytes(len(free), d) <= budget.DIRECT_BYTES
    if method == "auto":
        method = "direct" if len(free) <= DIRECT_LIMIT[d] and fits else "amg-cg"
    if method not in ("direct", "amg-cg"):
        raise ValueError(f"method must be 'auto', 'direct' or 'amg-cg', not {method!r}")
    iters = 0
    status = "converged"

    def residual_of(x: np.ndarray) -> float:
        if not np.all(np.isfinite(x)):
            raise SolverError(
                "the FEA solution is not finite; the stiffness matrix is singular (is the part held?)"
            )
        u[free] = x
        return float(np.linalg.norm((K @ u - f)[free]) / nb)

    with _one_blas_thread():
        if method == "direct":
            try:
                res = residual_of(_direct(K[free][:, free], b))
            except _NoMemory as exc:  # no AMG-CG then: with memory this short, OpenBLAS may exit the process
                raise SolverError(f"the direct FEA solve of {len(free):,} unknowns {exc}; {_FIX_SIZE}") \
                    from None
        else:
            x, iters, restarts = _amg_cg(K, b, free_mask, mesh, rtol, TOL.fea_residual, maxiter)
            res = residual_of(x)
            if restarts:
                status = f"converged after {restarts} restart{'s' if restarts > 1 else ''}"
            if res > TOL.fea_residual and len(free) <= FALLBACK_LIMIT[d] and fits:
                status = (
                    f"amg-cg stopped at relative residual {res:.1e} after {iters} iterations "
                    f"({restarts} restarts); solved directly"
                )
                method = "amg-cg+direct"
                try:
                    res = residual_of(_direct(K[free][:, free], b))
                except _NoMemory as exc:
                    raise SolverError(
                        f"the FEA solve did not converge: amg-cg stopped at relative residual {res:.1e} "
                        f"after {iters} iterations ({len(free):,} free dofs), and the direct solve {exc}; "
                        f"{_FIX_SIZE}"
                    ) from None
    t2 = time.perf_counter()
    if res > TOL.fea_residual:
        raise SolverError(
            f"the FEA solve did not converge: relative residual {res:.2e} > {TOL.fea_residual:.0e} "
            f"({method}, {iters} iterations, {len(free)} free dofs); "
            "try a coarser mesh (larger mesh size) or check that the part is held"
        )
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
        status=status,
    )


def _one_blas_thread() -> contextlib.AbstractContextManager[object]:
    """Limit BLAS to one thread.

    The solvers call it on short vectors and small blocks, where threads only add synchronisation
    (10-50x slower on a busy 2-core machine).
    """
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover
        return contextlib.nullcontext()
    return threadpool_limits(limits=1, user_api="blas")


_FIX_SIZE = ("the mesh is far larger than the part needs (is a coordinate in the file far outside the "
             "part?); check the file, or set a larger --pitch (a coarser mesh)")

_FILL_PER_DOF = {2: 12.0, 3: 32.0}
"""Factor entries per ``n log2 n`` (2D) or ``n^(4/3)`` (3D) of SuperLU with the ordering of
:func:`_direct` (nested-dissection growth).  Measured on a 150 x 36 mm plate with a hole (quadratic
triangles): 7.5, 8.9, 10.1, 11.0 at 13,600, 51,500, 140,000, 313,000 dofs; 3D from the 3 GB at
150,000 dofs of quadratic tetrahedra (:data:`FALLBACK_LIMIT`)."""


def direct_fill_bytes(n: int, dim: int) -> float:
    """Bytes SuperLU's factors of ``n`` unknowns are expected to take (12 per entry: value and index).

    ``12 * c * n log2 n`` in 2D, ``12 * c * n^(4/3)`` in 3D (:data:`_FILL_PER_DOF`).  Compared with
    :data:`loadpath.budget.DIRECT_BYTES` before the factorisation; pivoting on badly shaped
    elements can still need more, which :func:`_direct` catches.
    """
    n = max(int(n), 2)
    growth = n * math.log2(n) if dim == 2 else n ** (4.0 / 3.0)
    return 12.0 * _FILL_PER_DOF[dim] * growth


class _NoMemory(Exception):
    """SuperLU could not allocate its factors; the message says so (``"needs more memory ..."``)."""


def symmetric_lu(A: sp.spmatrix) -> Any:
    """SuperLU factors of a symmetric positive definite sparse matrix (n, n).

    A symmetric ordering (minimum degree on ``A + A^T``, diagonal pivots first) gives 5-10x less
    fill and time than SuperLU's default column ordering on the stiffness matrices, and 1.6x less
    time on the level-set fit's normal equations (:func:`loadpath.engines.levelset.fit`, 66,190
    unknowns: 0.51 s against ``spsolve``'s 0.83-0.88 s).

    Raises
    ------
    RuntimeError
        SuperLU's: the matrix is exactly singular, or a factor could not be allocated.
    """
    return spla.splu(A.tocsc(), permc_spec="MMD_AT_PLUS_A", options={"SymmetricMode": True})


def _direct(A: sp.csr_matrix, b: np.ndarray) -> np.ndarray:
    """Solve with SuperLU, plus one step of iterative refinement.

    The factors are :func:`symmetric_lu`'s.

    SuperLU reports a failed allocation in three ways: ``MemoryError``, ``SystemError`` (an error
    return without an exception) or a ``RuntimeError`` naming ``SUPERLU_MALLOC``; before the
    first two it prints its own line ("Can't expand MemType 0: jcol ...") on the C stderr.  That
    line (and at times another on stdout) is kept out of the user's output (:func:`_c_output_kept`),
    and all three become :class:`_NoMemory`.

    Raises
    ------
    SolverError
        The matrix is singular.
    _NoMemory
        The factors did not fit in memory.
    """
    said: list[str] = []
    try:
        with np.errstate(all="ignore"), _c_output_kept(said):
            lu = symmetric_lu(A)
            x = lu.solve(b)
            x += lu.solve(b - A @ x)
    except (MemoryError, SystemError) as exc:
        raise _NoMemory(_no_memory(exc, said)) from None
    except RuntimeError as exc:  # SuperLU: "Factor is exactly singular", or a failed SUPERLU_MALLOC
        if "MALLOC" in str(exc):
            raise _NoMemory(_no_memory(exc, said)) from None
        raise SolverError(
            f"the stiffness matrix is singular ({exc}); the part is not held against rigid motion"
        ) from exc
    return np.asarray(x)


def _no_memory(exc: BaseException, said: list[str]) -> str:
    """``"needs more memory than this process may use (SuperLU: ...)"``: one line."""
    text = (said[0] if said else "") or str(exc).split(" at line ")[0] or type(exc).__name__
    return f"needs more memory than this process may use (SuperLU: {' '.join(text.split())[:80]})"


@contextlib.contextmanager
def _c_output_kept(said: list[str]) -> Iterator[None]:
    """File descriptors 1 and 2 go to a temporary file while inside; its lines are put in ``said`` on leaving.

    SuperLU writes its memory complaints with C's ``fprintf(stderr, ...)`` ("Can't expand MemType
    0: jcol ...") and ``printf`` ("Not enough memory to perform factorization." on stdout, seen with
    the address space capped 200 MB above the process's), which no Python redirection sees; C's
    buffers are flushed before the descriptors are put back, so a buffered line cannot come out
    later.  Anything else written to fd 1 or 2 meanwhile (another thread's) is kept out too: the
    solves run in the job's own thread of its own process.
    """
    import ctypes
    import tempfile

    try:
        saved = [os.dup(1), os.dup(2)]
    except OSError:  # no fd 1 or 2
        yield
        return
    try:
        flush_c = ctypes.CDLL(None).fflush
    except (OSError, AttributeError):  # pragma: no cover (no C library to flush)
        flush_c = None
    with tempfile.TemporaryFile() as tmp:
        sys.stdout.flush()
        sys.stderr.flush()
        os.dup2(tmp.fileno(), 1)
        os.dup2(tmp.fileno(), 2)
        try:
            yield
        finally:
            if flush_c is not None:
                flush_c(None)
            for fd, old in zip((1, 2), saved):
                os.dup2(old, fd)
                os.close(old)
            tmp.seek(0)
            said.extend(ln for ln in tmp.read(4096).decode(errors="replace").splitlines() if ln.strip())


def _p1_prolongation(mesh: MeshData) -> sp.csr_matrix:
    """Interpolation from the corner nodes to all nodes of a quadratic mesh, ``(n, c)``.

    A mid-edge node takes the mean of its edge's two corners (exact for fields linear on the edge).
    """
    el = ELEMENTS[mesh.cell_type]
    nc = mesh.n_corners
    corners = mesh.corner_nodes
    cidx = np.full(len(mesh.points), -1, dtype=np.int64)
    cidx[corners] = np.arange(len(corners))
    mids = mesh.cells[:, nc:].ravel()
    ea = mesh.cells[:, el.edges[:, 0]].ravel()
    eb = mesh.cells[:, el.edges[:, 1]].ravel()
    mids, first = np.unique(mids, return_index=True)
    rows = np.concatenate([corners, mids, mids])
    cols = np.concatenate([cidx[corners], cidx[ea[first]], cidx[eb[first]]])
    vals = np.concatenate([np.ones(len(corners)), np.full(2 * len(mids), 0.5)])
    return sp.csr_matrix((vals, (rows, cols)), shape=(len(mesh.points), len(corners)))


def _dot(a: np.ndarray, b: np.ndarray) -> float:
    # einsum's own loop, not BLAS: threaded BLAS on these short vectors is slower than serial code
    # and stalls badly on a busy machine
    return float(np.einsum("i,i->", a, b))


def _amg_cg(
    K: sp.csr_matrix,
    b: np.ndarray,
    free_mask: np.ndarray,
    mesh: MeshData,
    rtol: float,
    accept: float,
    maxiter: int = 1000,
) -> tuple[np.ndarray, int, int]:
    """Preconditioned conjugate gradients on the reduced system.

    Preconditioner: one multigrid V-cycle whose first coarsening goes from the quadratic mesh to its
    corner nodes (p-multigrid: interpolation of :func:`_p1_prolongation`, Galerkin product), followed
    by smoothed aggregation (pyamg) on that linear-element matrix, with the rigid-body modes as
    near-null space and evolution strength (robust for the flat elements of thin parts). Smoothing:
    block Gauss-Seidel on the node blocks. Dirichlet dofs are kept as identity rows so the
    blocks stay intact.

    Returns the reduced solution, the CG iterations and the restarts :func:`_pcg` needed to bring
    the true relative residual below ``accept``.
    """
    try:
        import pyamg
        from pyamg.multilevel import MultilevelSolver
        from pyamg.relaxation.smoothing import change_smoothers
    except ImportError as exc:  # pragma: no cover
        raise SolverError("pyamg is needed for large FEA problems: pip install pyamg") from exc
    with _seeded(_AMG_SEED):
        A, ml = _hierarchy(K, free_mask, mesh, pyamg, MultilevelSolver)
    # forward sweep before and backward sweep after the coarse correction: a symmetric V-cycle (as CG
    # needs) at half the cost of symmetric sweeps on both sides
    pre = ("block_gauss_seidel", {"sweep": "forward"})
    post = ("block_gauss_seidel", {"sweep": "backward"})
    change_smoothers(ml, presmoother=pre, postsmoother=post)
    M = ml.aspreconditioner(cycle="V")
    rhs = np.zeros(K.shape[0])
    rhs[free_mask] = b
    x, iters, restarts = _pcg(A, rhs, M, rtol, accept, maxiter)
    return x[free_mask], iters, restarts


_AMG_SEED = 20261202
"""Seed of the multigrid set-up's random draws (any fixed value: it only has to be the same)."""


@contextlib.contextmanager
def _seeded(seed: int):
    """Run the block with numpy's global generator seeded, then give the caller back its state."""
    state = np.random.get_state()
    np.random.seed(seed)
    try:
        yield
    finally:
        np.random.set_state(state)


def _hierarchy(
    K: sp.csr_matrix, free_mask: np.ndarray, mesh: MeshData, pyamg: Any, MultilevelSolver: Any  # noqa: N803
) -> tuple[sp.bsr_matrix, Any]:
    """The reduced matrix (Dirichlet rows as identity) and its multigrid hierarchy (:func:`_amg_cg`)."""
    d = mesh.dim
    keep = free_mask.astype(float)
    A = (sp.diags(keep) @ K @ sp.diags(keep) + sp.diags(1.0 - keep)).tobsr(blocksize=(d, d))
    sa = {
        "symmetry": "symmetric",
        "strength": "evolution",
        "smooth": "energy",
        "coarse_solver": "splu",
        "max_coarse": 500,
    }
    if mesh.is_quadratic:
        Pn = _p1_prolongation(mesh)
        P = sp.bsr_matrix(sp.kron(Pn, sp.eye(d), format="csr"), blocksize=(d, d))
        A1 = (P.T @ A @ P).tobsr(blocksize=(d, d))
        B1, _ = rigid_modes(mesh.points[mesh.corner_nodes])
        coarse = pyamg.smoothed_aggregation_solver(A1, B=B1, **sa)
        top = MultilevelSolver.Level()
        top.A, top.P, top.R = A, P, P.T.tobsr(blocksize=(d, d))
        ml = MultilevelSolver([top, *coarse.levels], coarse_solver="splu")
    else:
        B, _ = rigid_modes(mesh.points)
        ml = pyamg.smoothed_aggregation_solver(A, B=B, **sa)
    return A, ml


def _pcg(
    A: sp.spmatrix, b: np.ndarray, M: object, rtol: float, accept: float, maxiter: int
) -> tuple[np.ndarray, int, int]:
    """Conjugate gradients with preconditioner ``M`` from ``x = 0``, with residual replacement.

    Iterates until the recurrence residual ``||r|| <= rtol ||b||``, then computes the true residual
    ``b - A x``; while that is above ``accept ||b||`` (drift of the recurrence on an ill-conditioned
    system), restarts from it with the recurrence asked for ``min(rtol, accept / 10)``, at most
    ``_CG_RESTARTS`` times and ``maxiter`` iterations in all.

    Returns
    -------
    x : (n,) float
    iterations : int
    restarts : int
    """
    x = np.zeros_like(b)
    r = b.copy()
    nb = np.sqrt(_dot(b, b))
    stop = rtol * nb
    it = 0
    restarts = 0
    while True:
        z = M @ r  # type: ignore[operator]
        p = z.copy()
        rz = _dot(r, z)
        while it < maxiter:
            it += 1
            Ap = A @ p
            pap = _dot(p, Ap)
            if not pap > 0.0:  # breakdown: A not positive definite along p (or p = 0)
                break
            alpha = rz / pap
            x += alpha * p
            r -= alpha * Ap
            if np.sqrt(_dot(r, r)) <= stop:
                break
            z = M @ r  # type: ignore[operator]
            rz_new = _dot(r, z)
            p = z + (rz_new / rz) * p
            rz = rz_new
        r = b - A @ x
        if np.sqrt(_dot(r, r)) <= accept * nb or it >= maxiter or restarts >= _CG_RESTARTS:
            return x, it, restarts
        restarts += 1
        stop = min(stop, 0.1 * accept * nb)  # the recurrence overstated the progress: ask it for more
