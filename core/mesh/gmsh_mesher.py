"""The only module that imports gmsh: part outlines and STL files -> :class:`MeshData`.

Headless and deterministic: ``gmsh.initialize(["-noenv"], readConfigFiles=False, interruptible=False)``,
``General.Terminal = 0``, one thread, fixed algorithms and seed; the same input gives the same mesh.

* :func:`mesh_2d`: triangles (quadratic, straight-sided: the outline is already a polygon) for a part
  outline with holes and islands, graded towards holes, re-entrant corners and the loaded / supported
  boundary, optionally following extra lines inside (used for prism stacks, :mod:`loadpath.mesh.layered`).
* :func:`mesh_stl`: quadratic tetrahedra inside a closed STL surface.

(Over 400 lines: the one adapter of gmsh -- its session, size fields, 2D and STL meshing and the
messages for its failures; the house rule keeps a heavy dependency behind one module.)
"""

from __future__ import annotations

import contextlib
import math
import re
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from loadpath import budget
from loadpath._typing import Points2, Region
from loadpath.errors import BudgetError, MeshingError, ToolMissingError
from loadpath.mesh.data import MeshData
from loadpath.mesh.outline import decimate, prepare_rings, refine_groups
from loadpath.mesh.sizing import MeshSize
from shapely.geometry.base import BaseGeometry

__all__ = ["mesh_2d", "mesh_stl", "orient_tets", "GMSH_TRI6", "GMSH_TET10"]

GMSH_TRI6 = 9
GMSH_TET10 = 11
_TET10_FROM_GMSH = np.array([0, 1, 2, 3, 4, 5, 6, 7, 9, 8])  # gmsh edge order (…, (2,3), (1,3)) -> ours
_LOCK = threading.Lock()


def _saved_signal_actions() -> Callable[[], None]:
    """Save the process's SIGPIPE, SIGINT and SIGTERM actions; the returned call puts them back.

    gmsh's first ``initialize`` resets SIGPIPE and SIGTERM to their defaults in C, behind Python's
    back: afterwards a write to a closed pipe or socket kills the process (the local service when a
    client hangs up) instead of raising ``BrokenPipeError``, and SIGTERM kills ``loadpath run`` at once
    instead of letting it remove its temporary files and say what was written
    (:mod:`loadpath.plugin.lifecycle`).  Saved and restored with libc's ``sigaction`` (an opaque
    buffer larger than ``struct sigaction``), because ``signal.signal`` only works in the main thread
    and the service meshes in worker threads.  A no-op where libc has no ``sigaction``.
    """
    import signal

    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        sigaction = libc.sigaction
    except (OSError, AttributeError):  # pragma: no cover (not POSIX)
        return lambda: None
    saved = []
    for name in ("SIGPIPE", "SIGINT", "SIGTERM"):
        if hasattr(signal, name):
            buf = ctypes.create_string_buffer(512)
            if sigaction(int(getattr(signal, name)), None, buf) == 0:
                saved.append((int(getattr(signal, name)), buf))

    def restore() -> None:
        for signum, buf in saved:
            sigaction(signum, buf, None)

    return restore


def _gmsh() -> Any:
    try:
        import gmsh
    except ImportError as exc:  # pragma: no cover
        raise ToolMissingError("gmsh is not installed: pip install gmsh") from exc
    return gmsh


@contextlib.contextmanager
def _session(name: str) -> Iterator[Any]:
    """Initialise gmsh with our options and an empty model; finalise it afterwards."""
    gmsh = _gmsh()
    with _LOCK:
        restore_signals = _saved_signal_actions()
        gmsh.initialize(["-noenv"], readConfigFiles=False, interruptible=False)
        restore_signals()
        try:
            gmsh.logger.start()  # kept for the error message when no elements come out
            opt = gmsh.option.setNumber
            for key, value in (
                ("General.Terminal", 0),
                ("General.Verbosity", 4),  # into gmsh.logger only (Terminal 0), for error messages
                ("General.NumThreads", 1),
                ("Mesh.MaxNumThreads1D", 1),
                ("Mesh.MaxNumThreads2D", 1),
                ("Mesh.MaxNumThreads3D", 1),
                ("Mesh.RandomSeed", 1),
                ("Mesh.MeshSizeFromPoints", 0),
                ("Mesh.MeshSizeFromCurvature", 0),
                ("Mesh.MeshSizeExtendFromBoundary", 0),
                ("Mesh.Algorithm", 6),  # Frontal-Delaunay: well-shaped triangles
                ("Mesh.Algorithm3D", 1),  # Delaunay
                ("Mesh.Optimize", 1),
                ("Mesh.OptimizeNetgen", 1),  # removes the slivers that ruin iterative solves
                ("Mesh.ElementOrder", 1),
                ("Mesh.SecondOrderLinear", 1),
            ):
                opt(key, value)
            gmsh.model.add(name)
            yield gmsh
        except (MeshingError, ToolMissingError, BudgetError):
            raise
        except Exception as exc:
            raise MeshingError(f"gmsh failed to mesh the {name}: {exc}; try another mesh size") from exc
        finally:
            gmsh.logger.stop()
            gmsh.finalize()


def _size_field(gmsh: Any, groups: Sequence[tuple[np.ndarray, float]], size: MeshSize) -> None:
    """Background size: ``h`` far away, ``h_g`` at each group's points, growing by ``grading`` per mm.

    The points become free geometry points (not embedded, so they do not constrain the mesh)
    measured by gmsh ``Distance`` fields.
    """
    f = gmsh.model.mesh.field
    geo = gmsh.model.geo
    thresholds = []
    for pts, h_g in groups:
        if len(pts) == 0 or h_g >= size.h:
            continue
        tags = [geo.addPoint(float(x), float(y), 0.0) for x, y in pts]
        geo.synchronize()
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
    gmsh.option.setNumber("Mesh.MeshSizeMin", 0.5 * min([size.h_min] + [g[1] for g in groups]))


class _Points:
    """gmsh geometry points, one per distinct coordinate (so rings and embedded lines share them)."""

    def __init__(self, geo: Any, scale: float) -> None:
        self.geo = geo
        self.tags: dict[tuple[int, int], int] = {}
        self.q = 1e9 / max(scale, 1e-9)

    def __call__(self, x: float, y: float) -> int:
        key = (round(x * self.q), round(y * self.q))
        t = self.tags.get(key)
        if t is None:
            t = self.tags[key] = self.geo.addPoint(float(x), float(y), 0.0)
        return t


def mesh_2d(
    outline: Region,
    size: MeshSize | float,
    refine_at: Sequence[BaseGeometry] = (),
    split_at: Points2 | None = None,
    order: int = 2,
    thickness: float = 1.0,
    z_range: tuple[float, float] | None = None,
    embed: Sequence[BaseGeometry] = (),
    refine_outlines: Sequence[Region] = (),
) -> MeshData:
    """Triangulate a part outline.

    Parameters
    ----------
    outline : shapely Polygon or MultiPolygon, mm
        The part outline (holes and several islands allowed).
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
    embed : sequence of LineString
        Lines inside the outline that element edges must follow (noded where they cross each other;
        their ends on the outline must be in ``split_at``).
    refine_outlines : sequence of Polygon or MultiPolygon
        Further outlines whose holes and re-entrant corners are refined (prism stacks).

    Returns
    -------
    MeshData
        ``tri6`` (or ``tri3``) cells, counter-clockwise.
    """
    sz = MeshSize.uniform(float(size)) if not isinstance(size, MeshSize) else size
    elements = _check_budget(outline, sz, [*refine_outlines], [*refine_at, *embed])
    t0 = time.perf_counter()
    polys = prepare_rings(outline, sz, split_at)
    groups = refine_groups([outline, *refine_outlines], sz, [*refine_at, *embed])
    _check_inside(outline, embed, 1e-3 * sz.h_min)
    x0, y0, x1, y1 = outline.bounds
    with _session("part outline") as gmsh:
        geo = gmsh.model.geo
        point = _Points(geo, max(x1 - x0, y1 - y0, 1e-6))
        surfaces = []
        for rings in polys:
            loops = []
            for c in rings:
                pts = [point(x, y) for x, y in c]
                lines = [geo.addLine(pts[i], pts[(i + 1) % len(pts)]) for i in range(len(pts))]
                loops.append(geo.addCurveLoop(lines))
            surfaces.append(geo.addPlaneSurface(loops))
        embedded: list[tuple[int, list[int]]] = []
        for line in embed:
            for part in getattr(line, "geoms", [line]):
                c = np.asarray(part.coords)[:, :2]
                # vertices shared with the outline (in split_at) must stay, or the line misses them
                keep = None
                if split_at is not None and len(split_at):
                    sp = np.asarray(split_at, dtype=float).reshape(-1, 2)
                    keep = (
                        np.min(np.linalg.norm(c[:, None, :] - sp[None, :, :], axis=2), axis=1)
                        <= 1e-3 * sz.h_min
                    )
                c = decimate(c, 0.2 * sz.h_min, closed=False, keep=keep)
                if len(c) < 2:
                    continue
                pts = [point(x, y) for x, y in c]
                tags = [geo.addLine(a, b) for a, b in zip(pts[:-1], pts[1:], strict=True) if a != b]
                mid = np.asarray(part.interpolate(0.5, normalized=True).coords)[0]
                embedded.append((_surface_of(polys, mid), tags))
        geo.synchronize()
        for k, tags in embedded:
            if tags:
                gmsh.model.mesh.embed(1, tags, 2, surfaces[k])
        _size_field(gmsh, groups, sz)
        gmsh.option.setNumber("Mesh.ElementOrder", order)
        points, cells = _generate(gmsh, 2, order, elements, _OUTLINE_FIX)
    points = points[:, :2]
    cells = _orient_tri(points, cells)
    stats = {"t_gmsh": time.perf_counter() - t0, "h": sz.h, "h_min": sz.h_min, "h_bc": sz.h_bc}
    return MeshData(
        points, cells, "tri6" if order == 2 else "tri3", thickness=thickness, z_range=z_range, stats=stats
    )


_MESH_FIX = ("the mesh is sized from the infill pitch, which is implausibly small for the part's size: set a "
             "larger --pitch, or check the file's infill (;WIDTH: lines, extrusion)")


def _check_budget(
    outline: Region, sz: MeshSize, more: Sequence[Region], lines: Sequence[BaseGeometry]
) -> float:
    """Stop before gmsh when the mesh would exceed :data:`loadpath.budget.MESH_ELEMENTS` triangles.

    Returns the estimate (triangles), which sets gmsh's time budget (:func:`_generate`).
    """
    from loadpath.areal import polygons_of
    from loadpath.mesh.sizing import reentrant_corners

    holes = sum(r.length for o in (outline, *more) for p in polygons_of(o) for r in p.interiors)
    refined = holes + sum(g.length for g in lines)
    corners = len(reentrant_corners(outline))
    est = budget.mesh_elements_estimate(outline.area, sz.h, sz.h_min, sz.grading, refined, corners)
    budget.check(est, budget.MESH_ELEMENTS, "", f"triangles estimated for the mesh ({outline.area:,.0f} mm2 "
                 f"at {sz.h:.3g} mm, {sz.h_min:.3g} mm at {refined:,.0f} mm of holes and boundary)", _MESH_FIX)
    return est


_OUTLINE_FIX = ("the outline has a detail far below the mesh size that gmsh cannot resolve (a notch or "
                "gap nearly closing on itself, as a damaged or missing wall line leaves): check the "
                "layer's walls in the file, or set another --pitch (it sets the mesh size)")
_STL_FIX = ("the STL surface may have details far below the mesh size or self-intersections: repair it "
            "or set another mesh size")


def _generate(gmsh: Any, dim: int, order: int, elements: float, fix: str) -> tuple[np.ndarray, np.ndarray]:
    """Run gmsh's mesher on the model and :func:`_extract` the elements, within a time budget.

    gmsh's 2D and 3D meshers can loop for ever on some geometry (a fuzzed Cura bracket whose hole
    wall lost one line to ``M486 S3`` ran 9.4 min of CPU in ``generate(2)``); the time is in C,
    where neither Ctrl-C nor SIGTERM reaches.  So the mesher runs in a forked child
    (:func:`loadpath.procs.in_child`) with :func:`loadpath.budget.mesh_seconds` of CPU time for the
    estimated element count; only the nodes and elements come back.  The parent waits in Python,
    so a stop signal ends the wait (and the child) at once.

    Raises
    ------
    BudgetError
        The mesher did not finish within its time.
    MeshingError
        gmsh crashed, or made no elements (:func:`_extract`).
    """
    from loadpath import procs

    k = {2: 6 if order == 2 else 3, 3: 10 if order == 2 else 4}[dim]
    etype = {(2, 2): GMSH_TRI6, (2, 1): 2, (3, 2): GMSH_TET10, (3, 1): 4}[dim, order]

    def mesh() -> tuple[np.ndarray, np.ndarray]:
        gmsh.model.mesh.generate(dim)
        if dim == 3 and order == 2:
            gmsh.model.mesh.setOrder(2)
        return _extract(gmsh, dim, etype, k)

    cpu_s = budget.mesh_seconds(elements)
    try:
        return procs.in_child(mesh, cpu_s, budget.WALL_PER_CPU * cpu_s + budget.WALL_SECONDS)
    except procs.OverLimit as exc:
        raise BudgetError(f"gmsh's mesher did not finish within its time budget of {cpu_s:.0f} s CPU "
                          f"for about {elements:,.0f} elements ({exc}); {fix}") from None
    except procs.ChildCrashed as exc:
        raise MeshingError(f"gmsh crashed while meshing ({exc}); {fix}") from None


def _check_inside(outline: Region, embed: Sequence[BaseGeometry], tol: float) -> None:
    """Raise :class:`MeshingError` when an embedded line runs outside the outline (by more than ``tol`` mm).

    gmsh cannot mesh a surface with an embedded line crossing its boundary: it either gives up
    (no elements) or keeps splitting edges forever, so this is checked first.
    """
    import shapely

    parts = [p for g in embed for p in shapely.get_parts(g)]
    if not parts:
        return
    outside = shapely.difference(np.asarray(parts, dtype=object), outline)
    bad = np.flatnonzero(shapely.length(outside) > tol)
    if len(bad):
        where = shapely.get_coordinates(outside[bad[0]])[0]
        raise MeshingError(
            f"a line to embed in the mesh runs {float(shapely.length(outside[bad[0]])):.3g} mm outside the "
            f"part outline near ({where[0]:.2f}, {where[1]:.2f}) mm; embedded lines must lie inside it"
        )


def _surface_of(polys: list[list[np.ndarray]], p: np.ndarray) -> int:
    """Index of the polygon (exterior ring) containing point ``p``."""
    from shapely import contains_xy
    from shapely.geometry import Polygon

    for k, rings in enumerate(polys):
        if contains_xy(Polygon(rings[0]), float(p[0]), float(p[1])):
            return k
    return 0


def _extract(gmsh: Any, dim: int, etype: int, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes used by the elements of one type, renumbered from 0, and the elements."""
    tags, coords, _ = gmsh.model.mesh.getNodes()
    budget.check(len(tags), budget.MESH_NODES, "", "mesh nodes from gmsh", _MESH_FIX)
    coords = np.asarray(coords).reshape(-1, 3)
    tags = np.asarray(tags, dtype=np.int64)
    etypes, _, enodes = gmsh.model.mesh.getElements(dim)
    conn = [
        np.asarray(n, dtype=np.int64).reshape(-1, k)
        for t, n in zip(etypes, enodes, strict=True)
        if t == etype
    ]
    if not conn or sum(len(c) for c in conn) == 0:
        raise MeshingError(
            f"gmsh produced no {'triangles' if dim == 2 else 'tetrahedra'}{_complaint(gmsh)}; the geometry "
            "may be degenerate (outline or layer lines crossing or nearly touching there); "
            "a different mesh size (or --pitch, which sets it) may mesh"
        )
    lookup = np.full(int(tags.max()) + 1, -1, dtype=np.int64)
    lookup[tags] = np.arange(len(tags))
    idx = lookup[np.concatenate(conn)]
    used = np.unique(idx)
    remap = np.full(len(tags), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    return coords[used], remap[idx]


_CURVES = re.compile(r"\(curves? ([0-9 ]+)\)|on curve ([0-9]+)")


def _complaint(gmsh: Any) -> str:
    """``" (<gmsh's last complaint>) near (x, y) mm"`` for an error message, or ``""``.

    gmsh says why a surface lost its elements in its log: crossing 1D meshes ("There are 2
    intersections in the 1D mesh (curves 88 334)", an Info) and edges it could not recover
    (Warnings). The place is where the named curves (straight lines here) come closest.
    """
    from shapely import shortest_line
    from shapely.geometry import LineString

    try:
        log = [m for m in gmsh.logger.get() if m.startswith(("Warning", "Error")) or "intersections" in m]
    except Exception:  # pragma: no cover - logger not started
        return ""
    if not log:
        return ""
    named = [m for m in log if _CURVES.search(m)]
    named = [m for m in named if "intersections" in m] or named
    msg = (named or log)[-1].split(":", 1)[-1].strip().lstrip(":-( ")
    if not named:
        return f" ({msg})"
    m = _CURVES.search(named[-1])
    tags = [int(t) for t in (m.group(1) or m.group(2)).split()][:2]
    try:
        lines = [
            LineString([gmsh.model.getValue(0, p, [])[:2] for _, p in gmsh.model.getBoundary([(1, t)])])
            for t in tags
        ]
    except Exception:  # pragma: no cover - the curves are gone with the model
        return f" ({msg})"
    if len(lines) == 1:
        where = lines[0].interpolate(0.5, normalized=True)
    else:
        where = shortest_line(*lines[:2]).centroid
    return f" ({msg}) near ({where.x:.2f}, {where.y:.2f}) mm"


def _orient_tri(points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    p = points[cells[:, :3]]
    a, b = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    neg = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0] < 0
    if np.any(neg):
        cells = cells.copy()
        flip = [0, 2, 1, 5, 4, 3] if cells.shape[1] == 6 else [0, 2, 1]
        cells[neg] = cells[neg][:, flip]
    return cells


def orient_tets(points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """Reorder tetrahedra (tet4 / tet10, our node order) to positive volume."""
    p = points[cells[:, :4]]
    det = np.einsum("ij,ij->i", p[:, 1] - p[:, 0], np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 0]))
    neg = det < 0
    if np.any(neg):
        cells = cells.copy()
        # swap corners 1 and 2: edges (0,1)<->(2,0), (1,2) stays, (1,3)<->(2,3)
        flip = [0, 2, 1, 3, 6, 5, 4, 7, 9, 8] if cells.shape[1] == 10 else [0, 2, 1, 3]
        cells[neg] = cells[neg][:, flip]
    return cells


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
        ``h`` is the largest element size (no grading).
    transform : (4, 4) float, optional
        Applied to the nodes afterwards (see :func:`loadpath.mesh.place.place_stl`).
    order : {1, 2}
    angle_deg : float
        Facets meeting at a sharper angle are separate surfaces (their edges are kept).

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
        x0, y0, z0, x1, y1, z1 = gmsh.model.getBoundingBox(-1, -1)
        tets = budget.tets_estimate((x1 - x0) * (y1 - y0) * (z1 - z0), sz.h)
        points, cells = _generate(gmsh, 3, order, tets, _STL_FIX)
    if order == 2:
        cells = cells[:, _TET10_FROM_GMSH]
    if transform is not None:
        t = np.asarray(transform, dtype=float)
        points = points @ t[:3, :3].T + t[:3, 3]
    cells = orient_tets(points, cells)
    stats = {"t_gmsh": time.perf_counter() - t0, "h": sz.h}
    return MeshData(points, cells, "tet10" if order == 2 else "tet4", stats=stats)
