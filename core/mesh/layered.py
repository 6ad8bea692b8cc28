"""Quadratic tetrahedra for a stack of prisms, built in layers from one 2D mesh.

A part given as slabs (z range + part outline) is 2.5-dimensional, so its tetrahedral mesh is made
from a triangulation of the union of all outlines that follows every slab's outline (and the
footprints of selector boxes) as embedded lines:

1. the slabs are split at the heights of selector boxes, and each slab gets
   ``ceil(thickness / h_z)`` equal layers;
2. the union of the outlines is triangulated once (gmsh, graded like :func:`mesh_2d`), with every
   outline edge inside it embedded;
3. in each layer, the triangles inside that slab's outline become prisms, and every prism is cut into
   three tetrahedra by the rule of Dompierre et al. (1999): each quadrilateral face is split by the
   diagonal through its vertex with the smallest global number, so neighbouring prisms agree and the
   mesh is conforming;
4. mid-edge nodes are added at edge midpoints (straight-sided ``tet10``).

Compared with a 3D Delaunay mesh of the same part (and OpenCASCADE booleans to join the prisms, which
fail when a hole is partly covered by the slab above), the layers give well-shaped elements in thin
parts (no slivers, which stall the iterative solver), exact control of the element count through
the thickness, and conformity by construction.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence

import numpy as np
import shapely
from loadpath import budget
from loadpath.body import Slab
from loadpath.errors import MeshingError
from loadpath.mesh.data import MeshData
from loadpath.mesh.gmsh_mesher import mesh_2d, orient_tets
from loadpath.mesh.sizing import MeshSize
from shapely.geometry import LineString
from shapely.geometry.base import BaseGeometry

__all__ = ["mesh_3d", "split_prisms", "promote_tet10", "TooManyCells"]


class TooManyCells(MeshingError):
    """A mesh would exceed its element budget (``cells`` > ``limit``); callers coarsen and retry."""

    def __init__(self, cells: int, limit: int) -> None:
        super().__init__(f"the mesh would have {cells} tetrahedra, more than the budget of {limit}")
        self.cells = cells
        self.limit = limit


# symmetries of the prism (0,1,2 bottom; 3,4,5 above them) bringing vertex k to position 0
_PRISM_PERM = np.array(
    [
        [0, 1, 2, 3, 4, 5],
        [1, 2, 0, 4, 5, 3],
        [2, 0, 1, 5, 3, 4],
        [3, 5, 4, 0, 2, 1],
        [4, 3, 5, 1, 0, 2],
        [5, 4, 3, 2, 1, 0],
    ]
)
_SPLIT_A = np.array([[0, 1, 2, 5], [0, 1, 5, 4], [0, 4, 5, 3]])  # diagonal 1-5 on face (1, 2, 5, 4)
_SPLIT_B = np.array([[0, 1, 2, 4], [0, 4, 2, 5], [0, 4, 5, 3]])  # diagonal 2-4
_TET_EDGES = np.array([[0, 1], [1, 2], [2, 0], [0, 3], [1, 3], [2, 3]])


def split_prisms(prisms: np.ndarray) -> np.ndarray:
    """Cut prisms into tetrahedra consistently (Dompierre et al. 1999).

    Parameters
    ----------
    prisms : (p, 6) int
        Global node numbers: bottom triangle, then the nodes above them.

    Returns
    -------
    (3 p, 4) int
        Tetrahedra (orientation not normalised).
    """
    V = np.asarray(prisms, dtype=np.int64)
    k = np.argmin(V, axis=1)
    W = np.take_along_axis(V, _PRISM_PERM[k], axis=1)
    diag15 = np.minimum(W[:, 1], W[:, 5]) < np.minimum(W[:, 2], W[:, 4])
    tets = np.where(diag15[:, None, None], W[:, _SPLIT_A], W[:, _SPLIT_B])
    return tets.reshape(-1, 4)


def promote_tet10(points: np.ndarray, tets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Add a node at the midpoint of every edge: tet4 -> tet10 (our edge order)."""
    n = len(points)
    pairs = np.sort(tets[:, _TET_EDGES], axis=2).reshape(-1, 2)
    keys = pairs[:, 0] * n + pairs[:, 1]
    uniq, inv = np.unique(keys, return_inverse=True)
    a, b = uniq // n, uniq % n
    mids = 0.5 * (points[a] + points[b])
    cells = np.column_stack([tets, n + inv.reshape(-1, 6)])
    return np.vstack([points, mids]), cells


def _near(v: float, values: np.ndarray, tol: float) -> bool:
    return bool(len(values) and np.min(np.abs(values - v)) <= tol)


def _cut(
    slabs: Sequence[Slab], cut_boxes: Sequence[tuple[np.ndarray, np.ndarray]], tol: float
) -> tuple[list[Slab], list[BaseGeometry]]:
    """Slabs split at box heights, and box footprints (rectangles) whose edges the mesh must follow.

    Bounds within ``tol`` of an existing vertex coordinate or height, or outside the part, need no cut.
    """
    zs = np.array([slabs[0].z0] + [s.z1 for s in slabs])
    xy = np.concatenate([shapely.get_coordinates(s.outline) for s in slabs])
    lo_b, hi_b = xy.min(axis=0), xy.max(axis=0)
    pad = 1.0 + float(np.max(hi_b - lo_b))
    cuts_z: list[float] = []
    rects = []
    for lo, hi in cut_boxes:
        lo = np.array(lo, dtype=float)
        hi = np.array(hi, dtype=float)
        for a in range(2):
            if lo[a] <= lo_b[a] + tol or _near(lo[a], xy[:, a], tol):
                lo[a] = lo_b[a] - pad
            if hi[a] >= hi_b[a] - tol or _near(hi[a], xy[:, a], tol):
                hi[a] = hi_b[a] + pad
        for zb in (lo[2], hi[2]):
            if (
                zs[0] + tol < zb < zs[-1] - tol
                and not _near(zb, zs, tol)
                and not _near(zb, np.array(cuts_z), tol)
            ):
                cuts_z.append(float(zb))
        if lo[0] > lo_b[0] - pad or lo[1] > lo_b[1] - pad or hi[0] < hi_b[0] + pad or hi[1] < hi_b[1] + pad:
            rects.append(shapely.box(lo[0], lo[1], hi[0], hi[1]))
    stack: list[Slab] = []
    for s in slabs:
        edges = [s.z0, *sorted(z for z in cuts_z if s.z0 < z < s.z1), s.z1]
        stack.extend(Slab(a, b, s.outline) for a, b in zip(edges[:-1], edges[1:], strict=True))
    return stack, rects


def _arrangement(
    stack: Sequence[Slab],
    rects: Sequence[BaseGeometry],
    union: BaseGeometry,
    tol: float,
    grid: float | None = None,
) -> tuple[BaseGeometry, list[LineString]]:
    """Return the region to mesh and the outline and box edges inside it, noded at their crossings.

    All lines (every slab's outline, the box rectangles) are noded together, and the region is the
    union of the faces of that arrangement lying in ``union``, so its boundary is made of the very
    segments the inner lines end on. With ``grid``, noding is snap rounding on that grid: a crossing
    becomes a grid point, and every segment passing that grid cell bends through it. The union
    computed on its own does not have those bends, so an inner line (e.g. a box edge) ending at a
    snapped crossing would end up to ``grid / sqrt(2)`` outside the union or short of it, and gmsh
    cannot mesh an embedded line crossing the outline (the real twisted tower sliced by PrusaSlicer
    lost all its triangles that way). Taking the region from the arrangement keeps it consistent.

    Returns
    -------
    region : Polygon or MultiPolygon
        Within about a grid step of ``union``.
    inner : list of LineString
        Lines inside ``region`` (none within ``tol`` of its boundary), merged between junctions.
    """
    edges = [s.outline.boundary for s in stack] + [r.boundary for r in rects]
    noded = shapely.unary_union(edges, grid_size=grid)
    faces = np.asarray(shapely.get_parts(shapely.polygonize(shapely.get_parts(noded))))
    if len(faces):
        share = shapely.area(shapely.intersection(faces, union)) / np.maximum(shapely.area(faces), 1e-300)
        faces = faces[share > 0.5]
    if not len(faces):
        return union, []
    region = shapely.coverage_union_all(faces)
    if not region.is_valid:  # pragma: no cover - polygonize faces form a coverage
        region = shapely.make_valid(region)
    inner = shapely.difference(noded, region.boundary)
    out = []
    for g in shapely.get_parts(inner):
        if g.geom_type != "LineString" or g.length <= tol:
            continue
        mid = g.interpolate(0.5, normalized=True)
        if region.boundary.distance(mid) <= tol or not region.contains(mid):
            continue
        out.append(g)
    if len(out) < 2:
        return region, out
    merged = shapely.line_merge(shapely.MultiLineString(out))
    return region, list(shapely.get_parts(merged))


def mesh_3d(
    slabs: Sequence[Slab],
    size: MeshSize | float,
    refine_at: Sequence[BaseGeometry] = (),
    cut_boxes: Sequence[tuple[np.ndarray, np.ndarray]] = (),
    order: int = 2,
    h_z: float | None = None,
    grid: float | None = None,
    max_cells: int | None = None,
) -> MeshData:
    """Tetrahedralise a stack of prisms in layers.

    Parameters
    ----------
    slabs : sequence of Slab
        Bottom first, contiguous (e.g. ``Body.slabs`` after :func:`~loadpath.body.merge_slabs`).
    size : MeshSize or float, mm
        In-plane element sizes, graded as in :func:`~loadpath.mesh.gmsh_mesher.mesh_2d`.
    refine_at : sequence of shapely geometry
        Lines (xy) refined to ``size.h_bc`` over the whole height.
    cut_boxes : sequence of ((3,), (3,)) float, mm
        Boxes ``(lower, upper)`` whose faces the mesh must follow (selector boxes).
    order : {1, 2}
    h_z : float, mm, optional
        Layer thickness; default ``sqrt(h h_min)`` clipped to ``[h_min, h]``.
    grid : float, mm, optional
        Snap the outlines, their union and their crossings to this grid (snap rounding), so lines
        that nearly touch do not make sliver elements (see
        :func:`~loadpath.body.cover_slabs`).
    max_cells : int, optional
        Raise :class:`TooManyCells` (before the quadratic nodes are made) when the mesh would have
        more tetrahedra.

    Returns
    -------
    MeshData
        ``tet10`` (or ``tet4``), positively oriented.

    Raises
    ------
    TooManyCells
        Above ``max_cells``; its ``cells`` attribute is the count.
    """
    sz = MeshSize.uniform(float(size)) if not isinstance(size, MeshSize) else size
    t0 = time.perf_counter()
    tol = 0.1 * sz.h_min
    if grid:
        slabs = [Slab(s.z0, s.z1, shapely.set_precision(s.outline, grid)) for s in slabs]
    stack, rects = _cut(list(slabs), cut_boxes, tol)
    union = shapely.unary_union([s.outline for s in stack], grid_size=grid)
    union, inner = _arrangement(stack, rects, union, tol, grid)
    # every vertex of an inner line that lies on the outside boundary must be a boundary vertex too
    ends = np.array([c[:2] for ln in inner for c in ln.coords]).reshape(-1, 2)
    on_edge = (
        shapely.distance(union.boundary, shapely.points(ends)) <= 1e-6 * (1.0 + sz.h)
        if len(ends)
        else np.zeros(0, bool)
    )
    m2 = mesh_2d(
        union,
        sz,
        refine_at=refine_at,
        split_at=ends[on_edge],
        order=1,
        embed=inner,
        refine_outlines=[s.outline for s in stack],
    )
    t_gmsh = m2.stats["t_gmsh"]
    pts2 = m2.points
    tri = m2.cells
    cen = pts2[tri].mean(axis=1)
    hz = float(np.clip(math.sqrt(sz.h * sz.h_min), sz.h_min, sz.h)) if h_z is None else float(h_z)
    levels = [stack[0].z0]
    layer_slab = []
    for k, s in enumerate(stack):
        nz = max(1, math.ceil((s.z1 - s.z0) / hz - 1e-9))
        levels.extend(np.linspace(s.z0, s.z1, nz + 1)[1:].tolist())
        layer_slab.extend([k] * nz)
    n2 = len(pts2)
    inside = [shapely.contains_xy(s.outline, cen[:, 0], cen[:, 1]) for s in stack]
    prisms = []
    for j, k in enumerate(layer_slab):
        t = tri[inside[k]]
        prisms.append(np.column_stack([j * n2 + t, (j + 1) * n2 + t]))
    P = np.concatenate(prisms) if prisms else np.zeros((0, 6), dtype=np.int64)
    if max_cells is not None and 3 * len(P) > max_cells:
        raise TooManyCells(3 * len(P), max_cells)
    budget.check(3 * len(P), budget.MESH_ELEMENTS, "", "tetrahedra of the layered mesh",
                 "the part is too large for its mesh size even after coarsening: set a larger --pitch")
    tets = split_prisms(P)
    used, inv = np.unique(tets, return_inverse=True)
    z = np.asarray(levels)[used // n2]
    points = np.column_stack([pts2[used % n2], z])
    tets = inv.reshape(-1, 4)
    if order == 2:
        points, tets = promote_tet10(points, tets)
    tets = orient_tets(points, tets)
    stats = {
        "t_gmsh": t_gmsh,
        "t_mesh": time.perf_counter() - t0,
        "h": sz.h,
        "h_min": sz.h_min,
        "h_bc": sz.h_bc,
        "h_z": hz,
        "layers": len(layer_slab),
        "triangles": len(tri),
    }
    return MeshData(points, tets, "tet10" if order == 2 else "tet4", stats=stats)
