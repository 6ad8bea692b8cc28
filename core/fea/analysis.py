"""From a resolved load case to a solved analysis and per-layer stress fields.

:func:`analyze` meshes a :class:`~loadpath.loadcase.resolve.ResolvedBody` (2D plane stress over its
thickness, or 3D), applies supports and loads, checks that the body is held (before solving),
solves, and returns an :class:`Analysis`; :meth:`Analysis.field` / :func:`field_for_layer` give the
:class:`~loadpath.fea.field.FEStressField` of a layer at height ``z``.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from loadpath.body import cover_slabs
from loadpath.errors import BudgetError, LoadCaseError
from loadpath.fea.boundary import Facets, check_rigid, facets_of, load_vector, pick, support_dofs
from loadpath.fea.field import FEStressField, field_from_2d, field_from_slice
from loadpath.fea.material import elasticity_matrix
from loadpath.fea.solver import FEAResult, Problem, solve
from loadpath.field import principal_stresses
from loadpath.loadcase.resolve import ResolvedBody, resolve_body
from loadpath.mesh.data import MeshData
from loadpath.mesh.sizing import DEFAULT_MAX_TETS, MeshSize, default_mesh_size
from shapely.geometry.base import BaseGeometry

__all__ = ["Analysis", "analyze", "field_for_layer", "build_mesh", "covered_body", "stress_scale"]


@dataclass(frozen=True)
class Analysis:
    """A solved load case on one body.

    Attributes
    ----------
    resolved : ResolvedBody
    mesh : MeshData
    result : FEAResult
        Displacements, nodal stresses, residual.
    facets : Facets
        Boundary facets of the mesh.
    picked : dict of str -> (b,) bool
        Facets each support / load picked, by name.
    scale : float, MPa
        Normalising stress of every layer's field (:func:`stress_scale`).
    times : dict
        Seconds for ``mesh``, ``assemble``, ``solve``, ``stress``.
    """

    resolved: ResolvedBody
    mesh: MeshData
    result: FEAResult
    facets: Facets
    picked: dict[str, np.ndarray]
    scale: float
    times: dict[str, float] = field(default_factory=dict)
    _cache: dict[Any, FEStressField] = field(default_factory=dict, repr=False, compare=False)

    @property
    def analysis(self) -> str:
        """``"2d"`` or ``"3d"``."""
        return self.resolved.analysis

    def field(self, z: float | None = None, principal: str = "max_abs") -> FEStressField:
        """Return the stress field of the layer at height ``z`` (see :func:`field_for_layer`)."""
        return field_for_layer(self, z, principal)


def build_mesh(
    rb: ResolvedBody,
    size: MeshSize | float | None = None,
    pitch: float | None = None,
    max_cells: int | None = None,
) -> MeshData:
    """Mesh a resolved body for its analysis (2D outline or 3D prism stack).

    A 3D stack is first coarsened to prisms the mesh can resolve
    (:func:`~loadpath.body.cover_slabs` of the layers, with a tolerance of half the bulk
    element size and a snapping grid of a quarter of the finest size, at most 0.25 mm), so a part
    whose outline drifts every layer does not force elements as small as the drift. With the
    default size, a 3D mesh keeps within an element budget: when the layered mesh would have more
    than ``max_cells`` tetrahedra, every size grows by the cube root of the excess and the part is
    meshed again (at most four times).

    Parameters
    ----------
    rb : ResolvedBody
    size : MeshSize or float, optional
        Default :func:`~loadpath.mesh.sizing.default_mesh_size` of the largest outline and ``pitch``.
    pitch : float, mm, optional
        The infill pitch the default size is derived from.
    max_cells : int, optional
        Element budget of a 3D mesh; default :data:`~loadpath.mesh.sizing.DEFAULT_MAX_TETS` with the
        default size, none with an explicit ``size``.

    Returns
    -------
    MeshData
        Its ``stats`` record the sizes used (``h``, ``h_min``, ``h_bc``, ``h_z``), the coarsening
        (``cover_tol``, ``grid``, ``slabs``) and the budget (``max_cells``, ``attempts``).
    """
    return _mesh_and_body(rb, size, pitch, max_cells)[0]


def _mesh_and_body(rb: ResolvedBody, size: MeshSize | float | None, pitch: float | None,
                   max_cells: int | None) -> tuple[MeshData, ResolvedBody]:
    """Return the mesh and the resolved body its facets are picked on (the coarser stack in 3D).

    A mesh over its budget (:mod:`loadpath.budget`) stops with the body's name and heights.
    """
    try:
        return _mesh_of(rb, size, pitch, max_cells)
    except BudgetError as exc:
        z0, z1 = rb.body.z_range
        raise exc.at(f"object {rb.name!r} (z = {z0:g}..{z1:g} mm), its FEA mesh") from None


def _mesh_of(rb: ResolvedBody, size: MeshSize | float | None, pitch: float | None,
             max_cells: int | None) -> tuple[MeshData, ResolvedBody]:
    from loadpath.mesh.gmsh_mesher import mesh_2d
    from loadpath.mesh.layered import TooManyCells, mesh_3d

    body = rb.body
    largest = max(body.slabs, key=lambda s: s.outline.area).outline
    sz = default_mesh_size(largest, pitch) if size is None else size
    if rb.analysis == "2d":
        mesh = mesh_2d(
            body.slabs[0].outline,
            sz,
            refine_at=rb.refine_lines(),
            split_at=rb.split_points(),
            thickness=rb.thickness,
            z_range=body.z_range,
        )
        return mesh, rb
    if max_cells is None and size is None:
        max_cells = DEFAULT_MAX_TETS
    ms = sz if isinstance(sz, MeshSize) else MeshSize.uniform(float(sz))
    for attempt in range(1, _BUDGET_ATTEMPTS + 1):
        tol, grid = _cover(rb, ms)
        rbm = covered_body(rb, tol, grid)
        last = attempt == _BUDGET_ATTEMPTS
        try:
            mesh = mesh_3d(
                rbm.body.slabs,
                ms,
                refine_at=rbm.refine_lines(),
                cut_boxes=rbm.cut_boxes(),
                grid=grid,
                max_cells=None if last else max_cells,
            )
        except TooManyCells as exc:
            # cells ~ 1 / (h^2 h_z): grow every size by the cube root of the excess (and a little)
            f = 1.05 * (exc.cells / exc.limit) ** (1.0 / 3.0)
            ms = MeshSize(ms.h * f, ms.h_min * f, ms.h_bc * f, ms.grading)
            continue
        stats = {
            **mesh.stats,
            "cover_tol": tol,
            "grid": grid,
            "slabs": len(rbm.body.slabs),
            "max_cells": max_cells,
            "attempts": attempt,
        }
        return dataclasses.replace(mesh, stats=stats), rbm
    raise AssertionError("unreachable")  # pragma: no cover


_BUDGET_ATTEMPTS = 5

_MAX_GRID = 0.25
"""mm: the snapping grid is at most this, so a covering outline misses a layer's outline by at most
about a grid step, well inside the outer perimeter (the infill is a bead width further in)."""


def _cover(rb: ResolvedBody, size: MeshSize) -> tuple[float, float | None]:
    """Coarsening tolerance and snapping grid of a 3D mesh of this size (none for one prism)."""
    if len(rb.body.slabs) < 2:
        return 0.0, None
    return 0.5 * size.h, min(0.25 * size.h_min, _MAX_GRID)


def covered_body(rb: ResolvedBody, tol: float, grid: float | None) -> ResolvedBody:
    """Return the load case resolved on :func:`~loadpath.body.cover_slabs` of the layers.

    The layers as sliced (``rb.layers``; the merged slabs when it is unknown) are covered, so every
    layer's outline lies in the mesh; the selectors keep the frame origin of ``rb``. The selections
    of the coarser stack pick the facets of a mesh made from it (a hole ring of a covering outline
    is where the mesh's hole is). Returns ``rb`` itself when nothing changes.
    """
    if tol <= 0 and not grid:
        return rb
    layers = getattr(rb, "layers", None) or rb.body
    body = cover_slabs(layers, tol, grid)
    return resolve_body(rb.loadcase, body, "3d", origin=getattr(rb, "origin", None))


def analyze(
    rb: ResolvedBody,
    size: MeshSize | float | None = None,
    pitch: float | None = None,
    mesh: MeshData | None = None,
    D: np.ndarray | None = None,
    method: str = "auto",
    scale_percentile: float = 99.0,
    model: str | Path | None = None,
    model_transform: np.ndarray | None = None,
    max_cells: int | None = None,
) -> Analysis:
    """Mesh, load, check, solve.

    Parameters
    ----------
    rb : ResolvedBody
    size : MeshSize or float, optional
        Mesh size (see :func:`build_mesh`).
    pitch : float, mm, optional
        Infill pitch, for the default mesh size.
    mesh : MeshData, optional
        A ready mesh (e.g. from an STL with ``--model``); its dimension must match the analysis.
    D : (nv, nv) or (m, nv, nv) float, MPa, optional
        Constitutive matrices; default the load case's isotropic material.
    method : {"auto", "direct", "amg-cg"}
    scale_percentile : float
        Percentile of ``|s|`` used as the fields' normalising stress.
    model : str or Path, optional
        An STL of the part (``--model``): meshed instead of the layer outlines (always a 3D
        analysis), placed with :func:`~loadpath.mesh.place.place_stl` on the body's first layer.
    model_transform : (4, 4) float, optional
        Explicit placement of the STL (rotated or scaled parts).
    max_cells : int, optional
        Element budget of a 3D mesh (see :func:`build_mesh`).

    Returns
    -------
    Analysis

    Raises
    ------
    LoadCaseError
        A selection that picks no mesh facet; a body free to move.
    SolverError
        The solve failed or its residual is too large.
    """
    t0 = time.perf_counter()
    if model is not None and mesh is None:
        from loadpath.mesh.gmsh_mesher import mesh_stl
        from loadpath.mesh.place import place_stl

        if rb.analysis != "3d":
            rb = dataclasses.replace(rb, analysis="3d", reason="an STL model was given")
        body = rb.body
        T = place_stl(model, body.slabs[0].outline, transform=model_transform)
        largest = max(body.slabs, key=lambda s: s.outline.area).outline
        sz = default_mesh_size(largest, pitch) if size is None else size
        h = sz if not isinstance(sz, MeshSize) else float(np.sqrt(sz.h * sz.h_min))
        mesh = mesh_stl(model, h, transform=T)
    if mesh is None:
        mesh, on = _mesh_and_body(rb, size, pitch, max_cells)
    elif (mesh.dim == 2) != (rb.analysis == "2d"):
        raise ValueError(f"a {mesh.dim}D mesh cannot carry a {rb.analysis} analysis")
    else:  # a mesh from build_mesh records how its stack was coarsened
        on = covered_body(rb, float(mesh.stats.get("cover_tol", 0.0)), mesh.stats.get("grid"))
    t1 = time.perf_counter()
    facets = facets_of(mesh)
    picked: dict[str, np.ndarray] = {}
    fixed = []
    f = np.zeros(len(mesh.points) * mesh.dim)
    for sup, sel in on.supports:
        m = _picked(mesh, facets, sel, rb)
        picked[sup.name] = m
        fixed.append(support_dofs(mesh, facets, m, sup))
    for load, sel in on.loads:
        m = _picked(mesh, facets, sel, rb)
        picked[load.name] = m
        f += load_vector(mesh, facets, m, load, rb.name)
    fixed_all = np.concatenate(fixed) if fixed else np.zeros(0, dtype=np.int64)
    check_rigid(mesh, fixed_all, rb)
    Dm = elasticity_matrix(rb.loadcase.material, mesh.dim) if D is None else D
    result = solve(Problem(mesh, Dm, f, fixed_all), method=method)
    exclude = np.unique(np.concatenate([facets.nodes[m].ravel() for m in picked.values()]))
    scale = stress_scale(mesh, result.stress, mesh.points[exclude], rb, scale_percentile)
    times = {"mesh": t1 - t0, **result.times}
    return Analysis(rb, mesh, result, facets, picked, scale, times)


def _picked(mesh: MeshData, facets: Facets, sel: Any, rb: ResolvedBody) -> np.ndarray:
    m = pick(mesh, facets, sel)
    if not np.any(m):
        raise LoadCaseError(
            f"{rb.loadcase.source}: {sel.role} {sel.name!r} ({sel.selector.describe()}) selects no element "
            f"faces of the mesh of object {rb.name!r}; part bounding box is {rb.body.describe_bounds()}; "
            "widen the selector"
        )
    return m


def _inplane(stress: np.ndarray) -> np.ndarray:
    return stress if stress.shape[1] == 3 else stress[:, [0, 1, 5]]


def stress_scale(
    mesh: MeshData, stress: np.ndarray, bc_points: np.ndarray, rb: ResolvedBody, percentile: float = 99.0
) -> float:
    """Normalising stress: a high percentile of ``|s|`` away from supports and loads.

    ``|s| = max(|sigma1|, |sigma2|)`` of the in-plane stress at the nodes, each node weighted by its
    share of the cell sizes; nodes closer to the supported or loaded boundary than 5 % of the
    body's bounding-box diagonal are left out, so the result does not depend on the mesh at a
    boundary-condition singularity. A re-entrant corner needs no exclusion: its singular peak covers
    a vanishing area, so the area-weighted percentile stays put under refinement (an L-bracket:
    82.7-82.9 MPa while the corner peak grows from 234 to 836 MPa as ``h_min`` goes from 1 to
    0.06 mm; ``tests/fea/test_fea_field.py``).

    Returns
    -------
    float, MPa
        Positive (1.0 for an unstressed body).
    """
    s1, s2, _, _ = principal_stresses(_inplane(stress))
    mag = np.maximum(np.abs(s1), np.abs(s2))
    k = mesh.cells.shape[1]
    w = np.bincount(
        mesh.cells.ravel(), weights=np.repeat(np.abs(mesh.measures) / k, k), minlength=len(mesh.points)
    )
    lo, hi = rb.body.bounds
    reach = 0.05 * float(np.linalg.norm((hi - lo)[: mesh.dim]))
    keep = (w > 0) & np.isfinite(mag)
    if len(bc_points):
        from scipy.spatial import cKDTree  # here: a cached analysis is loaded without scipy

        d, _ = cKDTree(bc_points).query(mesh.points, k=1)
        far = keep & (d > reach)
        if np.sum(w[far]) > 0.2 * np.sum(w[keep]):
            keep = far
    vals, wts = mag[keep], w[keep]
    if len(vals) == 0:
        return 1.0
    order = np.argsort(vals)
    cum = np.cumsum(wts[order])
    i = int(np.searchsorted(cum, percentile / 100.0 * cum[-1]))
    v = float(vals[order][min(i, len(vals) - 1)])
    return v if v > 0 else 1.0


def field_for_layer(analysis: Analysis, z: float | None = None, principal: str = "max_abs") -> FEStressField:
    """Return the stress field of the layer at height ``z``.

    A 2D analysis gives the same field for every layer of the body; a 3D analysis the section of
    the tetrahedral mesh at ``z`` (use the middle of the layer).

    Parameters
    ----------
    analysis : Analysis
    z : float, mm, optional
        Layer height (middle of the layer); default the middle of the body.
    principal : str
        Followed principal stress (``loadpath.field.PRINCIPALS``).

    Returns
    -------
    FEStressField
        With ``load_entry`` (lines where the load enters this layer, or None), ``support_lines``,
        ``region`` (the part outline at ``z``) and ``scale`` set.
    """
    rb = analysis.resolved
    z0, z1 = rb.body.z_range
    zq = 0.5 * (z0 + z1) if z is None else float(z)
    if not z0 - 1e-6 <= zq <= z1 + 1e-6:
        raise ValueError(f"z = {zq} mm is outside object {rb.name!r} (z {z0}..{z1})")
    key = ("2d",) if rb.analysis == "2d" else ("3d", round(zq, 9))
    base = analysis._cache.get(key)
    if base is None:
        slab = rb.body.slab_at(zq)
        region = slab.outline if slab is not None else None
        sup = _union([s.lines if rb.analysis == "2d" else s.lines_at(zq) for _, s in rb.supports])
        entry = rb.load_entry(None if rb.analysis == "2d" else zq)
        kw = dict(region=region, load_entry=entry, support_lines=sup)
        if rb.analysis == "2d":
            base = field_from_2d(analysis.mesh, analysis.result.stress, analysis.scale, **kw)
        else:
            base = field_from_slice(analysis.mesh, analysis.result.stress, zq, analysis.scale, **kw)
        analysis._cache[key] = base
    return base if principal == base.principal else base.with_principal(principal)  # type: ignore[return-value]


def _union(parts: list[BaseGeometry | None]) -> BaseGeometry | None:
    g = [p for p in parts if p is not None and not p.is_empty]
    return shapely.line_merge(shapely.unary_union(g)) if g else None
