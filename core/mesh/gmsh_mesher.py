"""The only module that imports gmsh: part outlines, slab stacks and STL files -> :class:`MeshData`.

Headless and deterministic: ``gmsh.initialize(["-noenv"], readConfigFiles=False, interruptible=False)``,
``General.Terminal = 0``, one thread, fixed algorithms; the same input gives the same mesh.

* :func:`mesh_2d`: quadratic triangles (straight-sided: ``Mesh.SecondOrderLinear = 1``, the outline is
  already a polygon) for a part outline with holes and islands, graded towards holes, re-entrant
  corners and the loaded / supported boundary.
* :func:`mesh_3d`: quadratic tetrahedra for a stack of prisms (OpenCASCADE extrusions fragmented
  together, so the prisms share conforming faces), optionally cut by selector boxes so every
  selection ends on element faces.
* :func:`mesh_stl`: quadratic tetrahedra inside a closed STL surface.
"""

from __future__ import annotations

import contextlib
import math
import threading
import time
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np
import shapely
from shapely.geometry import LineString, Point
from shapely.geometry.base import BaseGeometry

from loadpath._typing import Points2, Region
from loadpath.errors import MeshingError, ToolMissingError
from loadpath.loadcase.body import Slab, polygons_of
from loadpath.mesh.data import MeshData
from loadpath.mesh.sizing import MeshSize, reentrant_corners

__all__ = ["mesh_2d", "mesh_3d", "mesh_stl", "GMSH_TRI6", "GMSH_TET10"]

GMSH_TRI6 = 9
GMSH_TET10 = 11
_TET10_FROM_GMSH = np.array([0, 1, 2, 3, 4, 5, 6, 7, 9, 8])  # gmsh edge order (…, (2,3), (1,3)) -> ours
_LOCK = threading.Lock()


def _gmsh():  # type: ignore[no-untyped-def]
    try:
        import gmsh
    except ImportError as exc:  # pragma: no cover
        raise ToolMissingError("gmsh is not installed: pip install gmsh") from exc
    return gmsh


@contextlib.contextmanager
def _session(name: str) -> Iterator[object]:
    """An initialised gmsh with our options and an empty model; finalised afterwards."""
    gmsh = _gmsh()
    with _LOCK:
        gmsh.initialize(["-noenv"], readConfigFiles=False, interruptible=False)
        try:
            opt = gmsh.option.setNumber
            opt("General.Terminal", 0)
            opt("General.Verbosity", 1)
            opt("General.NumThreads", 1)
            opt("Mesh.MaxNumThreads1D", 1)
            opt("Mesh.MaxNumThreads2D", 1)
            opt("Mesh.MaxNumThreads3D", 1)
            opt("Mesh.RandomSeed", 1)
            opt("Mesh.MeshSizeFromPoints", 0)
            opt("Mesh.MeshSizeFromCurvature", 0)
            opt("Mesh.MeshSizeExtendFromBoundary", 0)
            opt("Mesh.Algorithm", 6)  # Frontal-Delaunay: well-shaped triangles
            opt("Mesh.Algorithm3D", 1)  # Delaunay
            opt("Mesh.Optimize", 1)
            opt("Mesh.ElementOrder", 1)
            gmsh.model.add(name)
            yield gmsh
        except Exception as exc:
            if isinstance(exc, (MeshingError, ToolMissingError)):
                raise
            raise MeshingError(f"gmsh failed to mesh the {name}: {exc}; try another mesh size") from exc
        finally:
            gmsh.finalize()


def _sample(geom: BaseGeometry, step: float) -> np.ndarray:
    """Points along lines (every ``step`` mm, ends included) or the points themselves, ``(n, 2)``."""
    out = []
    for g in getattr(geom, "geoms", [geom]):
        if g.is_empty:
            continue
        if isinstance(g, Point):
            out.append(np.array([[g.x, g.y]]))
        elif hasattr(g, "exterior"):
            for r in [g.exterior, *g.interiors]:
                out.append(_sample(LineString(r.coords), step))
        else:
            n = max(2, int(math.ceil(g.length / step)) + 1)
            d = np.linspace(0.0, g.length, n)
            out.append(shapely.get_coordinates(shapely.line_interpolate_point(g, d))[:, :2])
    return np.concatenate(out) if out else np.zeros((0, 2))


def _size_field(gmsh, groups: Sequence[tuple[np.ndarray, float]], size: MeshSize, kernel) -> None:  # type: ignore[no-untyped-def]
    """Background size: ``h`` far away, ``h_g`` at each group's points, growing by ``grading``.

    The groups' points (``(n, 2)`` or ``(n, 3)``) become free geometry points (not embedded in the
    part, so they do not constrain the mesh) measured by gmsh ``Distance`` fields.
    """
    f = gmsh.model.mesh.field
    thresholds = []
    for pts, h_g in groups:
        if len(pts) == 0 or h_g >= size.h:
            continue
        p3 = np.column_stack([pts, np.zeros(len(pts))]) if pts.shape[1] == 2 else pts
        tags = [kernel.addPoint(float(x), float(y), float(z)) for x, y, z in p3]
        kernel.synchronize()
        d = f.add("Distance")
        f.setNumbers(d, "PointsList", tags)
        t = f.add("Threshold")
        f.setNumber(t, "InField", d)
        f.setNumber(t, "SizeMin", h_g)
        f.setNumber(t, "SizeMax", size.h)
        f.setNumber(t, "DistMin", 0.5 * h_g)
        f.setNumber(t, "DistMax", 0.5 * h_g + (size.h - h_g) / size.grading)
        thresholds.append(t)
    if thresholds:
        m = f.add("Min")
        f.setNumbers(m, "FieldsList", thresholds)
        f.setAsBackgroundMesh(m)
    gmsh.option.setNumber("Mesh.MeshSizeMax", size.h)
    gmsh.option.setNumber("Mesh.MeshSizeMin", 0.5 * min(g[1] for g in groups) if groups else 0.5 * size.h_min)


def _with_points(coords: np.ndarray, extra: np.ndarray, tol: float) -> np.ndarray:
    """Insert points lying on a closed ring's segments into it (ring given without repeat)."""
    c = coords
    for p in extra:
        a = c
        b = np.roll(c, -1, axis=0)
        ab = b - a
        L2 = np.einsum("ij,ij->i", ab, ab)
        t = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.where(L2 > 0, L2, 1.0), 0.0, 1.0)
        d = np.linalg.norm(a + t[:, None] * ab - p, axis=1)
        k = int(np.argmin(d))
        if d[k] > tol:
            continue
        if min(np.linalg.norm(c - p, axis=1)) <= tol:
            continue  # already a vertex
        q = a[k] + t[k] * ab[k]
        c = np.insert(c, k + 1, q, axis=0)
    return c


def _decimate(c: np.ndarray, min_len: float) -> np.ndarray:
    """Drop ring vertices closer than ``min_len`` to their predecessor (G-code jitter would force
    tiny elements); never two neighbours in one pass, never below a triangle."""
    while len(c) > 3:
        seg = np.linalg.norm(np.roll(c, -1, axis=0) - c, axis=1)  # segment i -> i + 1
        short = seg < min_len
        drop = np.roll(short & ~np.roll(short, 1), 1)  # vertex i + 1 after a short segment i
        if not np.any(drop):
            break
        if len(c) - int(drop.sum()) < 3:
            break
        c = c[~drop]
    return c


def _prepare_outline(outline: Region, size: MeshSize, split_at: Points2 | None) -> list[list[np.ndarray]]:
    """Simplified rings per polygon (each ring ``(n, 2)`` without the closing repeat)."""
    # only (near-)collinear vertices go: a coarser Douglas-Peucker puts kinks of several degrees into
    # polygonised arcs, and each kink is a weak stress singularity that inflates the peak at holes
    tol = min(0.005, 1e-3 * size.h_min)
    simple = shapely.simplify(outline, tol, preserve_topology=True)
    extra = np.zeros((0, 2)) if split_at is None else np.asarray(split_at, dtype=float).reshape(-1, 2)
    merge = 1e-3 * size.h_min
    polys = []
    for poly in polygons_of(shapely.geometry.polygon.orient(simple, 1.0) if simple.geom_type == "Polygon" else simple):
        poly = shapely.geometry.polygon.orient(poly, 1.0)
        rings = []
        for r in [poly.exterior, *poly.interiors]:
            c = _decimate(np.asarray(r.coords)[:-1, :2], 0.2 * size.h_min)
            c = _with_points(c, extra, 10 * merge + 1e-9)
            rings.append(c)
        polys.append(rings)
    if not polys:
        raise MeshingError("the part outline is empty after simplification; check the layer geometry")
    return polys


def _refine_groups(outline: Region, size: MeshSize, refine_at: Sequence[BaseGeometry]) -> list[tuple[np.ndarray, float]]:
    holes = [LineString(r.coords) for p in polygons_of(outline) for r in p.interiors]
    groups = []
    if holes:
        groups.append((_sample(shapely.MultiLineString(holes), 0.5 * size.h_min), size.h_min))
    corners = reentrant_corners(outline)
    if len(corners):
        groups.append((corners, size.h_min))
    pts = [_sample(g, 0.5 * size.h_bc) for g in refine_at if g is not None and not g.is_empty]
    if pts:
        groups.append((np.concatenate(pts), size.h_bc))
    return groups


def mesh_2d(
    outline: Region,
    size: MeshSize | float,
    refine_at: Sequence[BaseGeometry] = (),
    split_at: Points2 | None = None,
    order: int = 2,
    thickness: float = 1.0,
    z_range: tuple[float, float] | None = None,
) -> MeshData:
    """Triangulate a part outline.

    Parameters
    ----------
    outline : shapely Polygon or MultiPolygon, mm
        The part outline (holes and several islands allowed). Simplified by ``0.02 h_min`` (at most
        0.02 mm) so G-code jitter does not force tiny elements.
    size : MeshSize or float, mm
        Element sizes; a float gives a uniform mesh.
    refine_at : sequence of shapely geometry
        Extra places to refine to ``size.h_bc`` (loaded and supported boundary pieces). Holes and
        re-entrant corners are always refined to ``size.h_min``.
    split_at : (n, 2) float, mm, optional
        Points on the outline that must be mesh nodes (ends of selected boundary pieces).
    order : {1, 2}
        Linear (``tri3``) or quadratic (``tri6``) triangles.
    thickness : float, mm
        Plate thickness stored with the mesh.
    z_range : (2,) float, optional
        Heights the plate spans.

    Returns
    -------
    MeshData
        ``tri6`` (or ``tri3``) cells, counter-clockwise.
    """
    sz = MeshSize.uniform(float(size)) if not isinstance(size, MeshSize) else size
    t0 = time.perf_counter()
    polys = _prepare_outline(outline, sz, split_at)
    groups = _refine_groups(outline, sz, refine_at)
    with _session("part outline") as gmsh:
        geo = gmsh.model.geo
        for rings in polys:
            loops = []
            for c in rings:
                pts = [geo.addPoint(float(x), float(y), 0.0) for x, y in c]
                lines = [geo.addLine(pts[i], pts[(i + 1) % len(pts)]) for i in range(len(pts))]
                loops.append(geo.addCurveLoop(lines))
            geo.addPlaneSurface(loops)
        geo.synchronize()
        _size_field(gmsh, groups, sz, geo)
        gmsh.option.setNumber("Mesh.ElementOrder", order)
        gmsh.option.setNumber("Mesh.SecondOrderLinear", 1)
        gmsh.model.mesh.generate(2)
        if order == 2:
            gmsh.model.mesh.setOrder(2)
        points, cells = _extract(gmsh, 2, GMSH_TRI6 if order == 2 else 2, 6 if order == 2 else 3)
    points = points[:, :2]
    cells = _orient_tri(points, cells)
    stats = {"t_gmsh": time.perf_counter() - t0, "h": sz.h, "h_min": sz.h_min, "h_bc": sz.h_bc}
    return MeshData(points, cells, "tri6" if order == 2 else "tri3", thickness=thickness, z_range=z_range, stats=stats)


def _extract(gmsh, dim: int, etype: int, k: int) -> tuple[np.ndarray, np.ndarray]:  # type: ignore[no-untyped-def]
    tags, coords, _ = gmsh.model.mesh.getNodes()
    coords = np.asarray(coords).reshape(-1, 3)
    tags = np.asarray(tags, dtype=np.int64)
    etypes, _, enodes = gmsh.model.mesh.getElements(dim)
    conn = [np.asarray(n, dtype=np.int64).reshape(-1, k) for t, n in zip(etypes, enodes) if t == etype]
    if not conn or sum(len(c) for c in conn) == 0:
        raise MeshingError("gmsh produced no elements; the geometry may be degenerate (check the outline)")
    conn_tags = np.concatenate(conn)
    lookup = np.full(int(tags.max()) + 1, -1, dtype=np.int64)
    lookup[tags] = np.arange(len(tags))
    idx = lookup[conn_tags]
    used = np.unique(idx)
    remap = np.full(len(tags), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    return coords[used], remap[idx]


def _orient_tri(points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    p = points[cells[:, :3]]
    a, b = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    neg = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0] < 0
    if np.any(neg):
        cells = cells.copy()
        flip = [0, 2, 1, 5, 4, 3] if cells.shape[1] == 6 else [0, 2, 1]
        cells[neg] = cells[neg][:, flip]
    return cells


def _orient_tet(points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    p = points[cells[:, :4]]
    det = np.einsum("ij,ij->i", p[:, 1] - p[:, 0], np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 0]))
    neg = det < 0
    if np.any(neg):
        cells = cells.copy()
        # swap corners 1 and 2: edges (0,1)<->(2,0), (1,2) stays, (1,3)<->(2,3)
        flip = [0, 2, 1, 3, 6, 5, 4, 7, 9, 8] if cells.shape[1] == 10 else [0, 2, 1, 3]
        cells[neg] = cells[neg][:, flip]
    return cells


def mesh_3d(
    slabs: Sequence[Slab],
    size: MeshSize | float,
    refine_at: Sequence[BaseGeometry] = (),
    cut_boxes: Sequence[tuple[np.ndarray, np.ndarray]] = (),
    order: int = 2,
) -> MeshData:
    """Tetrahedralise a stack of prisms.

    Each slab's outline is extruded from ``z0`` to ``z1`` with OpenCASCADE; all prisms (and the
    ``cut_boxes``) are fragmented together so neighbouring prisms share conforming faces and every
    selector box ends on element faces; the box pieces outside the part are removed.

    Parameters
    ----------
    slabs : sequence of Slab
        Bottom first, contiguous.
    size : MeshSize or float, mm
    refine_at : sequence of shapely geometry
        Lines (xy) refined to ``size.h_bc`` over the whole height.
    cut_boxes : sequence of ((3,), (3,)) float, mm
        Boxes ``(lower, upper)`` whose faces the mesh must follow.
    order : {1, 2}

    Returns
    -------
    MeshData
        ``tet10`` (or ``tet4``) cells, positively oriented.
    """
    sz = MeshSize.uniform(float(size)) if not isinstance(size, MeshSize) else size
    t0 = time.perf_counter()
    with _session("part") as gmsh:
        occ = gmsh.model.occ
        vols = []
        groups: list[tuple[np.ndarray, float]] = []
        for s in slabs:
            polys = _prepare_outline(s.outline, sz, None)
            for rings in polys:
                loops = []
                for c in rings:
                    pts = [occ.addPoint(float(x), float(y), s.z0) for x, y in c]
                    lines = [occ.addLine(pts[i], pts[(i + 1) % len(pts)]) for i in range(len(pts))]
                    loops.append(occ.addCurveLoop(lines))
                surf = occ.addPlaneSurface(loops)
                ext = occ.extrude([(2, surf)], 0.0, 0.0, s.z1 - s.z0)
                vols.extend(t for d, t in ext if d == 3)
            for pts2, h_g in _refine_groups(s.outline, sz, refine_at):
                groups.append((_extrude_points(pts2, s.z0, s.z1, 0.5 * h_g), h_g))
        tools = [occ.addBox(*lo, *(hi - lo)) for lo, hi in cut_boxes]
        obj = [(3, v) for v in vols]
        if len(obj) > 1 or tools:
            _, out_map = occ.fragment(obj, [(3, b) for b in tools])
            keep = {t for m in out_map[: len(obj)] for d, t in m if d == 3}
            drop = {t for m in out_map[len(obj) :] for d, t in m if d == 3} - keep
            if drop:
                occ.remove([(3, t) for t in sorted(drop)], recursive=True)
        occ.synchronize()
        groups = [(g, h) for g, h in groups if len(g)]
        _size_field(gmsh, groups, sz, occ)
        gmsh.option.setNumber("Mesh.ElementOrder", 1)
        gmsh.option.setNumber("Mesh.SecondOrderLinear", 1)
        gmsh.model.mesh.generate(3)
        if order == 2:
            gmsh.model.mesh.setOrder(2)
        points, cells = _extract(gmsh, 3, GMSH_TET10 if order == 2 else 4, 10 if order == 2 else 4)
    if order == 2:
        cells = cells[:, _TET10_FROM_GMSH]
    cells = _orient_tet(points, cells)
    stats = {"t_gmsh": time.perf_counter() - t0, "h": sz.h, "h_min": sz.h_min, "h_bc": sz.h_bc}
    return MeshData(points, cells, "tet10" if order == 2 else "tet4", stats=stats)


def _extrude_points(pts: np.ndarray, z0: float, z1: float, step: float) -> np.ndarray:
    nz = max(2, int(math.ceil((z1 - z0) / step)) + 1)
    z = np.linspace(z0, z1, nz)
    return np.column_stack([np.repeat(pts, nz, axis=0), np.tile(z, len(pts))])


def mesh_stl(
    path: str | Path,
    size: MeshSize | float,
    transform: np.ndarray | None = None,
    order: int = 2,
    angle_deg: float = 40.0,
) -> MeshData:
    """Tetrahedralise the inside of a closed STL surface.

    Parameters
    ----------
    path : str or Path
        The STL file (mm).
    size : MeshSize or float, mm
        Only ``h`` is used (uniform size).
    transform : (4, 4) float, optional
        Applied to the mesh nodes (e.g. from :func:`loadpath.mesh.place.place_stl`).
    order : {1, 2}
    angle_deg : float
        Facets meeting at a sharper angle are separate surfaces (kept as edges of the mesh).

    Returns
    -------
    MeshData
    """
    sz = MeshSize.uniform(float(size)) if not isinstance(size, MeshSize) else size
    p = Path(path)
    if not p.is_file():
        raise MeshingError(f"STL file {str(p)!r} does not exist; check the --model path")
    t0 = time.perf_counter()
    with _session("STL model") as gmsh:
        gmsh.merge(str(p))
        gmsh.model.mesh.classifySurfaces(math.radians(angle_deg), True, True, math.pi)
        gmsh.model.mesh.createGeometry()
        surfs = [t for _, t in gmsh.model.getEntities(2)]
        loop = gmsh.model.geo.addSurfaceLoop(surfs)
        gmsh.model.geo.addVolume([loop])
        gmsh.model.geo.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", sz.h)
        gmsh.option.setNumber("Mesh.MeshSizeMin", 0.5 * sz.h_min)
        gmsh.option.setNumber("Mesh.SecondOrderLinear", 1)
        gmsh.model.mesh.generate(3)
        if order == 2:
            gmsh.model.mesh.setOrder(2)
        points, cells = _extract(gmsh, 3, GMSH_TET10 if order == 2 else 4, 10 if order == 2 else 4)
    if order == 2:
        cells = cells[:, _TET10_FROM_GMSH]
    if transform is not None:
        t = np.asarray(transform, dtype=float)
        points = points @ t[:3, :3].T + t[:3, 3]
    cells = _orient_tet(points, cells)
    stats = {"t_gmsh": time.perf_counter() - t0, "h": sz.h}
    return MeshData(points, cells, "tet10" if order == 2 else "tet4", stats=stats)
