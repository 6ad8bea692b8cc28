"""The finite-element stress field of one layer: :class:`FEStressField` (the ``StressField`` contract).

A layer's field is a set of triangles with the stress tensor ``[sxx, syy, sxy]`` at their nodes:

* 2D analysis: the mesh's quadratic triangles with the recovered nodal stresses, interpolated
  quadratically (the same functions as the displacements);
* 3D analysis: the section of the tetrahedral mesh by the plane ``z = layer middle``
  (:func:`slice_tets`): its triangles carry the in-plane part of the 3D stress as quadratic data,
  which reproduces the tetrahedra's own interpolation on the plane exactly.

Tensors are interpolated component by component (never direction vectors). Points are located with
a bucket grid (:class:`~loadpath.fea.locate.TriangleLocator`); outside every triangle the tensor is NaN.
"""

from __future__ import annotations

import numpy as np
from loadpath._typing import Points2, Region, Stress2
from loadpath.fea.locate import TriangleLocator
from loadpath.field import StressField, _check_principal
from loadpath.mesh.data import MeshData
from shapely.geometry.base import BaseGeometry

__all__ = ["FEStressField", "slice_tets", "field_from_2d", "field_from_slice"]

_CHUNK = 1 << 18
# edges of a tetrahedron (corner pairs) in the tet10 mid-node order
_TET_EDGES = np.array([[0, 1], [1, 2], [0, 2], [0, 3], [1, 3], [2, 3]])


def _edge(a: int, b: int) -> int:
    for k, (i, j) in enumerate(_TET_EDGES):
        if {i, j} == {a, b}:
            return k
    raise KeyError((a, b))


def _section_table() -> dict[int, list[int]]:
    """Above-pattern (bit i: corner i above the plane) -> cut edges in cyclic order."""
    table: dict[int, list[int]] = {}
    for code in range(1, 15):
        up = [i for i in range(4) if code >> i & 1]
        dn = [i for i in range(4) if not code >> i & 1]
        if len(up) == 2:
            a, b = up
            c, d = dn
            table[code] = [_edge(a, c), _edge(a, d), _edge(b, d), _edge(b, c)]
        else:
            lone = up[0] if len(up) == 1 else dn[0]
            table[code] = [_edge(lone, j) for j in range(4) if j != lone]
    return table


_TABLE = _section_table()


# reference (l1, l2) of the nodes: corners, then mid-edges (0,1), (1,2), (2,0)
_REF_NODES = {
    3: np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]),
    6: np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.5, 0.0], [0.5, 0.5], [0.0, 0.5]]),
}


def _monomials(L: np.ndarray, k: int | None = None) -> np.ndarray:
    """``[1, l1, l2]`` (k = 3) or ``[1, l1, l2, l1², l1 l2, l2²]`` (k = 6) at ``(p, 2)`` points."""
    k = len(L) if k is None else k
    l1, l2 = L[:, 0], L[:, 1]
    one = np.ones_like(l1)
    if k == 3:
        return np.stack([one, l1, l2], axis=1)
    return np.stack([one, l1, l2, l1 * l1, l1 * l2, l2 * l2], axis=1)


class FEStressField(StressField):
    """Stress field of one layer, interpolated on triangles.

    Parameters
    ----------
    corners : (m, 3, 2) float, mm
        Triangle corners.
    values : (m, k, 3) float, MPa
        ``[sxx, syy, sxy]`` at the triangles' nodes: ``k = 3`` (corners, linear) or ``k = 6``
        (corners then mid-edges (0,1), (1,2), (2,0), quadratic).
    scale : float, MPa
        Normalising stress (a high percentile of ``|s|`` away from supports and loads).
    principal : str
        Followed principal stress (``loadpath.field.PRINCIPALS``).
    region : shapely Polygon or MultiPolygon, optional
        The part outline of the layer (for drawing and clipping by callers).
    load_entry : shapely geometry, optional
        Where the load enters this layer (lines of the outline the load selectors picked).
    support_lines : shapely geometry, optional
        Lines of the outline the supports picked.
    z : float, optional
        Height of the layer, mm.

    Attributes
    ----------
    load_entry, support_lines, region, z
        As given.
    """

    def __init__(
        self,
        corners: np.ndarray,
        values: np.ndarray,
        scale: float,
        principal: str = "max_abs",
        region: Region | None = None,
        load_entry: BaseGeometry | None = None,
        support_lines: BaseGeometry | None = None,
        z: float | None = None,
    ) -> None:
        self.corners = np.ascontiguousarray(corners, dtype=float)
        self.values = np.ascontiguousarray(values, dtype=float)
        if self.values.shape[1] not in (3, 6) or self.values.shape[2] != 3:
            raise ValueError(f"values must be (m, 3 or 6, 3), got {self.values.shape}")
        self.locator = TriangleLocator(self.corners, cell_factor=0.5)
        # per triangle, the interpolant as a polynomial in the barycentric (l1, l2): one gather and
        # one contraction per query instead of six (the nodal data stays in ``values``)
        to_coef = np.linalg.inv(_monomials(_REF_NODES[self.values.shape[1]]))
        self._coef = np.einsum("kn,mnc->mkc", to_coef, self.values)
        self.scale = float(scale)
        self.principal = _check_principal(principal)
        self.region = region
        self.load_entry = load_entry
        self.support_lines = support_lines
        self.z = z

    def tensor(self, points: Points2) -> Stress2:  # noqa: D102 (documented in the base class)
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        out = np.full((len(pts), 3), np.nan)
        for s in range(0, len(pts), _CHUNK):
            sl = slice(s, s + _CHUNK)
            tri, L = self.locator.locate(pts[sl])
            ok = tri >= 0
            if not np.any(ok):
                continue
            C = self._coef[tri[ok]]  # (p, k, 3)
            B = _monomials(L[ok, 1:], C.shape[1])
            block = out[sl]
            block[ok] = np.einsum("pk,pkc->pc", B, C)
        return out

    @property
    def coefficients(self) -> np.ndarray:
        """Each triangle's interpolant as a polynomial in its barycentric ``(l1, l2)``, (m, k, 3) MPa.

        Monomials ``[1, l1, l2]`` (k = 3) or ``[1, l1, l2, l1², l1 l2, l2²]`` (k = 6), per
        component ``[sxx, syy, sxy]``; ``l1, l2`` are the coordinates along the edges from corner 0
        to corners 1 and 2 (:attr:`corners`).
        """
        return self._coef

    @property
    def n_triangles(self) -> int:
        """Number of triangles the field interpolates on."""
        return len(self.corners)


def field_from_2d(mesh: MeshData, stress: np.ndarray, scale: float, **kw: object) -> FEStressField:
    """Field of a 2D (tri3 / tri6) mesh with nodal stresses ``(n, 3)``."""
    if mesh.dim != 2:
        raise ValueError("field_from_2d needs a 2D mesh")
    corners = mesh.points[mesh.cells[:, :3]]
    return FEStressField(corners, stress[mesh.cells], scale, **kw)  # type: ignore[arg-type]


def _tet_shape(L: np.ndarray, quadratic: bool) -> np.ndarray:
    """tet4 / tet10 shape functions at barycentric coordinates ``(..., 4)`` -> ``(..., 4 | 10)``."""
    if not quadratic:
        return L
    a, b = _TET_EDGES[:, 0], _TET_EDGES[:, 1]
    return np.concatenate([L * (2 * L - 1), 4 * L[..., a] * L[..., b]], axis=-1)


def slice_tets(mesh: MeshData, values: np.ndarray, z: float) -> tuple[np.ndarray, np.ndarray]:
    """Section of a tetrahedral mesh by the plane ``z``.

    Each cut tetrahedron gives a triangle or a quadrilateral (two triangles). The values on a section
    triangle are those of the tetrahedron's own interpolation, taken at the triangle's corners and
    edge midpoints: for ``tet10`` the field restricted to the plane is quadratic, so the section
    triangles (as quadratic ``tri6`` data) reproduce it exactly. A corner exactly on the plane counts
    as below, so a mesh face lying in the plane is cut once (by the cells above it).

    Parameters
    ----------
    mesh : MeshData
        ``tet4`` or ``tet10``.
    values : (n, c) float
        Nodal values.
    z : float, mm

    Returns
    -------
    corners : (t, 3, 2) float, mm
    tri_values : (t, 6, c) float (``tet10``) or (t, 3, c) (``tet4``)
        At the corners, then the midpoints of edges (0,1), (1,2), (2,0).
    """
    quadratic = mesh.cells.shape[1] == 10
    cells = mesh.cells
    zc = mesh.points[cells[:, :4], 2] - z  # (m, 4)
    above = zc > 0
    code = above @ np.array([1, 2, 4, 8])
    cut = np.flatnonzero((code > 0) & (code < 15))
    cells, zc, code = cells[cut], zc[cut], code[cut]
    a, b = _TET_EDGES[:, 0], _TET_EDGES[:, 1]
    sa, sb = zc[:, a], zc[:, b]  # (m, 6)
    den = sa - sb
    t = np.clip(np.divide(sa, den, out=np.zeros_like(sa), where=den != 0), 0.0, 1.0)
    # barycentric coordinates (in the tetrahedron) of the points where the plane cuts its edges
    bary = np.zeros((len(cells), 6, 4))
    rows = np.arange(6)
    bary[:, rows, a] = 1.0 - t
    bary[:, rows, b] += t
    corners_xyz = mesh.points[cells[:, :4]]  # (m, 4, 3)
    tri_cell, tri_bary = [], []
    for cd, edges in _TABLE.items():
        sel = np.flatnonzero(code == cd)
        if len(sel) == 0:
            continue
        polys = (
            [edges[:3]]
            if len(edges) == 3
            else [[edges[0], edges[1], edges[2]], [edges[0], edges[2], edges[3]]]
        )
        for e in polys:
            tri_cell.append(sel)
            tri_bary.append(bary[sel][:, e])
    nval = values.shape[1]
    if not tri_cell:
        return np.zeros((0, 3, 2)), np.zeros((0, 6 if quadratic else 3, nval))
    tc = np.concatenate(tri_cell)
    tb = np.concatenate(tri_bary)  # (t, 3, 4)
    corners = np.einsum("tpk,tkd->tpd", tb, corners_xyz[tc])[:, :, :2]
    if quadratic:
        mids = 0.5 * (tb + tb[:, [1, 2, 0]])
        tb = np.concatenate([tb, mids], axis=1)  # (t, 6, 4)
    N = _tet_shape(tb, quadratic)  # (t, 3 | 6, 4 | 10)
    tri_values = np.einsum("tpn,tnc->tpc", N, values[cells[tc]])
    return corners, tri_values


def field_from_slice(
    mesh: MeshData, stress: np.ndarray, z: float, scale: float, **kw: object
) -> FEStressField:
    """Field of the section ``z`` of a 3D mesh with nodal stresses ``(n, 6)`` (in-plane part kept)."""
    inplane = stress[:, [0, 1, 5]]
    corners, vals = slice_tets(mesh, inplane, z)
    return FEStressField(corners, vals, scale, z=z, **kw)  # type: ignore[arg-type]
