"""Reference elements: Lagrange shape functions in barycentric coordinates, and quadrature rules.

Reference simplices: triangle ``(0,0), (1,0), (0,1)`` (area 1/2), tetrahedron ``(0,0,0), (1,0,0),
(0,1,0), (0,0,1)`` (volume 1/6), line ``[0, 1]``. With barycentric coordinates ``L0 = 1 - sum(xi)``,
``Li = xi_i``, the shape functions are ``Li`` (linear) and, for quadratic elements,
``Li (2 Li - 1)`` at corners and ``4 La Lb`` at the mid-node of edge ``(a, b)``.
Node orders are those of :mod:`loadpath.mesh.data`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Element", "ELEMENTS", "triangle_rule", "tetra_rule", "line_rule"]


@dataclass(frozen=True)
class Element:
    """A Lagrange simplex element.

    Attributes
    ----------
    name : str
    dim : int
        Reference dimension (1, 2, 3).
    edges : (e, 2) int
        Corner pairs of the mid-edge nodes, in node order (empty for linear elements).
    nodes : (k, dim) float
        Reference coordinates of the nodes.
    """

    name: str
    dim: int
    edges: np.ndarray
    nodes: np.ndarray

    @property
    def n_corners(self) -> int:
        """Corner nodes."""
        return self.dim + 1

    @property
    def n_nodes(self) -> int:
        """All nodes."""
        return self.n_corners + len(self.edges)

    def _bary(self, xi: np.ndarray) -> np.ndarray:
        xi = np.atleast_2d(xi)
        return np.column_stack([1.0 - xi.sum(axis=1), xi])

    def shape(self, xi: np.ndarray) -> np.ndarray:
        """Shape functions at reference points.

        Parameters
        ----------
        xi : (q, dim) float

        Returns
        -------
        (q, k) float
        """
        L = self._bary(xi)
        if len(self.edges) == 0:
            return L
        corners = L * (2.0 * L - 1.0)
        mids = 4.0 * L[:, self.edges[:, 0]] * L[:, self.edges[:, 1]]
        return np.column_stack([corners, mids])

    def grad(self, xi: np.ndarray) -> np.ndarray:
        """Shape-function gradients with respect to the reference coordinates.

        Parameters
        ----------
        xi : (q, dim) float

        Returns
        -------
        (q, k, dim) float
        """
        L = self._bary(xi)
        q = L.shape[0]
        dL = np.vstack([-np.ones(self.dim), np.eye(self.dim)])  # (dim+1, dim)
        if len(self.edges) == 0:
            return np.broadcast_to(dL, (q, *dL.shape)).copy()
        dcorner = (4.0 * L - 1.0)[:, :, None] * dL[None, :, :]
        a, b = self.edges[:, 0], self.edges[:, 1]
        dmid = 4.0 * (L[:, a, None] * dL[None, b, :] + L[:, b, None] * dL[None, a, :])
        return np.concatenate([dcorner, dmid], axis=1)


def _make(name: str, dim: int, edges: list[tuple[int, int]]) -> Element:
    corners = np.vstack([np.zeros(dim), np.eye(dim)])
    e = np.array(edges, dtype=np.int64).reshape(-1, 2)
    nodes = np.vstack([corners, 0.5 * (corners[e[:, 0]] + corners[e[:, 1]])]) if len(e) else corners
    return Element(name, dim, e, nodes)


ELEMENTS = {
    "line2": _make("line2", 1, []),
    "line3": _make("line3", 1, [(0, 1)]),
    "tri3": _make("tri3", 2, []),
    "tri6": _make("tri6", 2, [(0, 1), (1, 2), (2, 0)]),
    "tet4": _make("tet4", 3, []),
    "tet10": _make("tet10", 3, [(0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)]),
}
"""Elements by name. Note ``line3`` orders its nodes (end 0, end 1, middle)."""


def line_rule(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre rule on ``[0, 1]`` with ``n`` points (exact to degree ``2n - 1``).

    Returns
    -------
    points : (n, 1) float
    weights : (n,) float
        Summing to 1.
    """
    x, w = np.polynomial.legendre.leggauss(n)
    return (0.5 * (x + 1.0))[:, None], 0.5 * w


def triangle_rule(degree: int) -> tuple[np.ndarray, np.ndarray]:
    """Symmetric rule on the reference triangle (weights sum to its area, 1/2).

    ``degree <= 2``: the 3-point rule at ``(1/6, 1/6)``...; ``degree <= 4``: Strang-Fix / Dunavant 6 points.
    """
    if degree <= 1:
        return np.array([[1.0 / 3.0, 1.0 / 3.0]]), np.array([0.5])
    if degree <= 2:
        p = np.array([[1 / 6, 1 / 6], [2 / 3, 1 / 6], [1 / 6, 2 / 3]])
        return p, np.full(3, 1.0 / 6.0)
    if degree <= 4:
        a, wa = 0.445948490915965, 0.223381589678011
        b, wb = 0.091576213509771, 0.109951743655322
        p = np.array([[a, a], [1 - 2 * a, a], [a, 1 - 2 * a], [b, b], [1 - 2 * b, b], [b, 1 - 2 * b]])
        return p, 0.5 * np.array([wa, wa, wa, wb, wb, wb])
    raise ValueError(f"no triangle rule of degree {degree}")


def tetra_rule(degree: int) -> tuple[np.ndarray, np.ndarray]:
    """Symmetric rule on the reference tetrahedron (weights sum to its volume, 1/6)."""
    if degree <= 1:
        return np.array([[0.25, 0.25, 0.25]]), np.array([1.0 / 6.0])
    if degree <= 2:
        a, b = 0.5854101966249685, 0.1381966011250105
        p = np.array([[b, b, b], [a, b, b], [b, a, b], [b, b, a]])
        return p, np.full(4, 1.0 / 24.0)
    raise ValueError(f"no tetrahedron rule of degree {degree}")
