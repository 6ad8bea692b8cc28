"""Vectorized assembly: shape-function gradients for all cells, element matrices, global matrix.

Like scikit-fem, every quantity is computed for all cells at once (the loop runs over quadrature
points and chunks of cells, never over single cells). The global matrix is assembled in 3x3 (2x2)
node blocks: the node-pair pattern is found once with :func:`numpy.unique`, and the element blocks
are summed into it with :func:`numpy.bincount`, which needs far less memory than a coordinate
(COO) list of every dof pair.

The stiffness is ``K = sum_cells int B^T D B dV`` with the strain-displacement matrix ``B`` of
:func:`strain_matrix`; in 2D ``dV = t dA`` with the plate thickness ``t``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from loadpath._lazy import lazy
from loadpath.fea.elements import ELEMENTS, tetra_rule, triangle_rule
from loadpath.mesh.data import MeshData

sp = lazy("scipy.sparse")  # imported when a stiffness matrix is built, not when a result is loaded

__all__ = ["Gradients", "gradients", "strain_matrix", "stiffness", "cell_dofs", "constitutive", "n_voigt"]

_CHUNK = 20000


def n_voigt(dim: int) -> int:
    """Length of the strain/stress vector: 3 in 2D, 6 in 3D."""
    return 3 if dim == 2 else 6


@dataclass(frozen=True)
class Gradients:
    """Physical shape-function gradients at reference points, for a set of cells.

    Attributes
    ----------
    dN : (m, q, k, d) float, 1/mm
        ``dN_a / dx_j`` at each point of each cell.
    detJ : (m, q) float
        Jacobian determinant (mm² or mm³ per reference unit).
    """

    dN: np.ndarray
    detJ: np.ndarray


def gradients(mesh: MeshData, xi: np.ndarray, cells: slice | np.ndarray = slice(None)) -> Gradients:
    """Shape-function gradients at reference points ``xi`` (``(q, d)``) of the selected cells."""
    el = ELEMENTS[mesh.cell_type]
    dref = el.grad(xi)  # (q, k, d)
    X = mesh.points[mesh.cells[cells]]  # (m, k, d)
    J = np.einsum("mkd,qke->mqde", X, dref)  # dx_d / dxi_e
    detJ = np.linalg.det(J)
    if np.any(detJ <= 0):
        bad = int(np.sum(np.any(detJ <= 0, axis=1)))
        raise ValueError(f"{bad} cells are inverted or degenerate (Jacobian <= 0)")
    Jinv = np.linalg.inv(J)  # dxi_e / dx_d
    dN = np.einsum("qke,mqed->mqkd", dref, Jinv)
    return Gradients(dN, detJ)


def strain_matrix(dN: np.ndarray) -> np.ndarray:
    """Strain-displacement matrices ``B`` with ``strain = B u_cell``.

    Parameters
    ----------
    dN : (..., k, d) float
        Physical gradients.

    Returns
    -------
    (..., nv, k * d) float
        Columns ordered node-major (``u0x, u0y[, u0z], u1x, ...``); rows the Voigt strains.
    """
    *lead, k, d = dN.shape
    nv = n_voigt(d)
    B = np.zeros((*lead, nv, k, d))
    if d == 2:
        B[..., 0, :, 0] = dN[..., 0]
        B[..., 1, :, 1] = dN[..., 1]
        B[..., 2, :, 0] = dN[..., 1]
        B[..., 2, :, 1] = dN[..., 0]
    else:
        for i in range(3):
            B[..., i, :, i] = dN[..., i]
        B[..., 3, :, 1], B[..., 3, :, 2] = dN[..., 2], dN[..., 1]  # gyz
        B[..., 4, :, 0], B[..., 4, :, 2] = dN[..., 2], dN[..., 0]  # gxz
        B[..., 5, :, 0], B[..., 5, :, 1] = dN[..., 1], dN[..., 0]  # gxy
    return B.reshape(*lead, nv, k * d)


def cell_dofs(mesh: MeshData) -> np.ndarray:
    """Global dof indices per cell, ``(m, k * d)``, node-major (dof = node * d + component)."""
    d = mesh.dim
    return (mesh.cells[:, :, None] * d + np.arange(d)).reshape(len(mesh.cells), -1)


def constitutive(D: np.ndarray, mesh: MeshData) -> np.ndarray:
    """Check and broadcast a constitutive matrix to one per cell, ``(m, nv, nv)``."""
    nv = n_voigt(mesh.dim)
    D = np.asarray(D, dtype=float)
    if D.shape == (nv, nv):
        return np.broadcast_to(D, (len(mesh.cells), nv, nv))
    if D.shape == (len(mesh.cells), nv, nv):
        return D
    raise ValueError(
        f"D must be ({nv}, {nv}) or ({len(mesh.cells)}, {nv}, {nv}) for this mesh, got {D.shape}"
    )


def _rule(mesh: MeshData) -> tuple[np.ndarray, np.ndarray]:
    degree = 2 if mesh.is_quadratic else 1
    return triangle_rule(degree) if mesh.dim == 2 else tetra_rule(degree)


def element_stiffness(mesh: MeshData, D: np.ndarray, cells: slice = slice(None)) -> np.ndarray:
    """Element stiffness matrices ``int B^T D B dV`` of the selected cells, ``(m, k d, k d)`` N/mm.

    Exact for straight-sided elements (the integrand is a polynomial of degree ``2 (p - 1)``).
    """
    xi, w = _rule(mesh)
    g = gradients(mesh, xi, cells)
    B = strain_matrix(g.dN)  # (m, q, nv, n)
    m, q, nv, n = B.shape
    Dm = constitutive(D, mesh)[cells]
    scale = (g.detJ * w) * (mesh.thickness if mesh.dim == 2 else 1.0)
    DB = np.matmul(Dm[:, None], B) * scale[:, :, None, None]  # (m, q, nv, n)
    # sum over quadrature points inside one product: [B_1^T .. B_q^T] [w_1 D B_1; ..; w_q D B_q]
    return np.matmul(np.swapaxes(B.reshape(m, q * nv, n), 1, 2), DB.reshape(m, q * nv, n))


def _pattern(cells: np.ndarray, n_nodes: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Node-pair block pattern: (indptr, indices, position of each cell pair in the block list)."""
    keys = (cells[:, :, None].astype(np.int64) * n_nodes + cells[:, None, :]).ravel()
    uniq, inv = np.unique(keys, return_inverse=True)
    rows = uniq // n_nodes
    cols = uniq % n_nodes
    indptr = np.zeros(n_nodes + 1, dtype=np.int64)
    np.cumsum(np.bincount(rows, minlength=n_nodes), out=indptr[1:])
    return indptr, cols, inv.reshape(len(cells), -1)


def stiffness(mesh: MeshData, D: np.ndarray) -> sp.csr_matrix:
    """Global stiffness matrix.

    Parameters
    ----------
    mesh : MeshData
    D : (nv, nv) or (m, nv, nv) float, MPa
        Constitutive matrix, one for all cells or one per cell (:mod:`loadpath.fea.material`).

    Returns
    -------
    scipy.sparse.csr_matrix, (n d, n d), N/mm
        Symmetric positive semi-definite (rigid-body modes in its null space).
    """
    d = mesh.dim
    n = len(mesh.points)
    k = mesh.cells.shape[1]
    indptr, indices, pos = _pattern(mesh.cells, n)
    nb = len(indices)
    data = np.zeros(nb * d * d)
    ij = np.arange(d)[:, None] * d + np.arange(d)[None, :]  # (d, d) place inside a block
    for start in range(0, len(mesh.cells), _CHUNK):
        sl = slice(start, start + _CHUNK)
        ke = element_stiffness(mesh, D, sl)  # (m, k d, k d) ordered (a, i, b, j)
        m = ke.shape[0]
        # scalar position of entry (a, i, b, j): block of the node pair (a, b), then (i, j) inside it
        where = (pos[sl].reshape(m, k, 1, k, 1) * (d * d) + ij[None, None, :, None, :]).ravel()
        data += np.bincount(where, weights=ke.ravel(), minlength=nb * d * d)
    K = sp.bsr_matrix((data.reshape(nb, d, d), indices, indptr), shape=(n * d, n * d))
    return K.tocsr()
