"""Meshes as plain arrays: :class:`MeshData` (points, cells, cell type) and its boundary facets.

Node orderings (corner nodes first, then mid-edge nodes; the same as Abaqus/CalculiX, so a mesh can
be written to a ``.inp`` file as is):

* ``tri3``: 0, 1, 2 counter-clockwise.
* ``tri6``: corners 0, 1, 2 counter-clockwise, then edges (0,1), (1,2), (2,0).
* ``tet4``: 0, 1, 2, 3 with ``det[x1-x0, x2-x0, x3-x0] > 0``.
* ``tet10``: corners, then edges (0,1), (1,2), (2,0), (0,3), (1,3), (2,3).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np
from loadpath._typing import Cells, Ints

__all__ = ["MeshData", "CELL_TYPES", "FACETS"]

# cell type -> (dimension, nodes per cell, corner nodes)
CELL_TYPES = {"tri3": (2, 3, 3), "tri6": (2, 6, 3), "tet4": (3, 4, 4), "tet10": (3, 10, 4)}

# local facets: corners first, then mid-edge nodes in the facet's own tri6 / line3 order
FACETS = {
    "tri3": np.array([[0, 1], [1, 2], [2, 0]]),
    "tri6": np.array([[0, 1, 3], [1, 2, 4], [2, 0, 5]]),
    "tet4": np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]]),
    "tet10": np.array([[0, 2, 1, 6, 5, 4], [0, 1, 3, 4, 8, 7], [1, 2, 3, 5, 9, 8], [2, 0, 3, 6, 7, 9]]),
}


@dataclass(frozen=True)
class MeshData:
    """A finite-element mesh.

    Attributes
    ----------
    points : (n, d) float, mm
        Node coordinates, ``d = 2`` (plane) or 3.
    cells : (m, k) int
        Node indices per cell in the orderings of the module docstring.
    cell_type : {"tri3", "tri6", "tet4", "tet10"}
    thickness : float, mm
        Plate thickness of a 2D mesh (1 for 3D meshes).
    z_range : (2,) float, mm, or None
        For a 2D mesh, the heights the plate spans.
    stats : dict
        Meshing diagnostics (time in s, requested sizes), JSON-serialisable.
    """

    points: np.ndarray
    cells: Cells
    cell_type: str
    thickness: float = 1.0
    z_range: tuple[float, float] | None = None
    stats: dict[str, Any] = field(default_factory=dict, compare=False)

    def __post_init__(self) -> None:
        if self.cell_type not in CELL_TYPES:
            raise ValueError(f"cell_type {self.cell_type!r} is not one of {', '.join(CELL_TYPES)}")
        dim, k, _ = CELL_TYPES[self.cell_type]
        pts = np.ascontiguousarray(self.points, dtype=float)
        cells = np.ascontiguousarray(self.cells, dtype=np.int64)
        if pts.ndim != 2 or pts.shape[1] != dim:
            raise ValueError(f"{self.cell_type} mesh needs (n, {dim}) points, got {pts.shape}")
        if cells.ndim != 2 or cells.shape[1] != k:
            raise ValueError(f"{self.cell_type} cells must be (m, {k}), got {cells.shape}")
        if cells.size and (cells.min() < 0 or cells.max() >= len(pts)):
            raise ValueError("cell node index out of range")
        object.__setattr__(self, "points", pts)
        object.__setattr__(self, "cells", cells)

    @property
    def dim(self) -> int:
        """Spatial dimension, 2 or 3."""
        return CELL_TYPES[self.cell_type][0]

    @property
    def n_corners(self) -> int:
        """Corner nodes per cell."""
        return CELL_TYPES[self.cell_type][2]

    @property
    def is_quadratic(self) -> bool:
        """True for tri6 / tet10."""
        return self.cell_type in ("tri6", "tet10")

    @cached_property
    def corner_nodes(self) -> Ints:
        """Sorted indices of nodes that are cell corners, ``(c,)``."""
        return np.unique(self.cells[:, : self.n_corners])

    @cached_property
    def measures(self) -> np.ndarray:
        """Cell areas (2D, without thickness) or volumes (3D), ``(m,)`` mm² or mm³ (straight-sided)."""
        p = self.points[self.cells[:, : self.n_corners]]
        if self.dim == 2:
            a, b = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
            return 0.5 * (a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])
        a, b, c = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0], p[:, 3] - p[:, 0]
        return np.einsum("ij,ij->i", a, np.cross(b, c)) / 6.0

    @cached_property
    def boundary(self) -> tuple[Cells, Ints]:
        """Boundary facets, oriented with the outward normal.

        Returns
        -------
        facets : (b, kf) int
            Node indices: edges ``(a, b[, mid])`` in 2D (material on the left when going a -> b),
            faces ``(a, b, c[, ab, bc, ca])`` in 3D (counter-clockwise seen from outside).
        owner : (b,) int
            The cell each facet belongs to.
        """
        loc = FACETS[self.cell_type]
        nf = loc.shape[0]
        all_f = self.cells[:, loc].reshape(-1, loc.shape[1])
        inv = self._facet_ids
        once = np.bincount(inv)[inv] == 1
        facets = all_f[once]
        owner = np.repeat(np.arange(len(self.cells)), nf)[once]
        return facets, owner

    @cached_property
    def _facet_ids(self) -> Ints:
        """Which facet each cell's facets are, ``(m * nf,)`` (cell by cell, in :data:`FACETS` order):
        two cells share a facet where they share its corner nodes (what :attr:`boundary` and
        :attr:`pieces` both read)."""
        loc = FACETS[self.cell_type][:, : 2 if self.dim == 2 else 3]
        key = np.sort(self.cells[:, loc].reshape(-1, loc.shape[1]), axis=1)
        _, inv = np.unique(key, axis=0, return_inverse=True)
        return inv.ravel()

    @cached_property
    def pieces(self) -> Ints:
        """The piece of each cell, ``(m,)``: cells sharing a facet (2D: an edge, 3D: a face) are one.

        Cells that meet only at a node (or, in 3D, along an edge) are different pieces: such a joint
        is a hinge that carries no moment, so each piece must be held on its own (a node-connected
        count let a piece hinged to the rest pass :func:`~loadpath.fea.boundary.check_rigid`, and its
        singular stiffness stalled the iterative solver).
        """
        from scipy.sparse import coo_matrix
        from scipy.sparse.csgraph import connected_components

        m = len(self.cells)
        inv = self._facet_ids
        owner = np.repeat(np.arange(m), len(FACETS[self.cell_type]))
        order = np.argsort(inv, kind="stable")
        same = inv[order][1:] == inv[order][:-1]  # a facet has at most two cells in a conforming mesh
        a, b = owner[order][:-1][same], owner[order][1:][same]
        g = coo_matrix((np.ones(len(a)), (a, b)), shape=(m, m))
        _, labels = connected_components(g, directed=False)
        return labels.astype(np.int64)
