"""Supports and loads on a mesh.

Which boundary facets a selection picks, the constrained dofs, the load vector, and the rigid-body
check done before solving.

Facets are picked with the same tests the load case used on the body (:mod:`loadpath.loadcase.select`):
the facet centroid inside the selector's box, or on the picked hole ring. Meshes are made to
conform to selector boxes (split points in 2D, box fragments in 3D), so the picked facets cover the
selected boundary exactly.

Loads (interface.md): a force is a uniform traction ``t = F / A`` over the picked area ``A`` (length
times thickness in 2D), so the resultant is ``F`` in 2D and 3D alike; a pressure ``p`` is the traction
``-p n`` (``n`` the outward normal); a force on a hole is a bearing load ``p0 max(0, -n . F/|F|) (-n)``
(a pin pressing on the half of the hole facing the force, cosine distribution), scaled so that its
resultant is exactly ``F``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from loadpath.errors import LoadCaseError
from loadpath.fea.elements import ELEMENTS, line_rule, triangle_rule
from loadpath.loadcase.model import Load, Support
from loadpath.loadcase.resolve import ResolvedBody
from loadpath.loadcase.select import Selection
from loadpath.mesh.data import MeshData

__all__ = ["Facets", "facets_of", "pick", "support_dofs", "load_vector", "check_rigid", "rigid_modes"]


@dataclass(frozen=True)
class Facets:
    """Boundary facets of a mesh with their geometry (3D coordinates even for 2D meshes).

    Attributes
    ----------
    nodes : (b, kf) int
        Facet nodes (corners first), oriented outward.
    centroid : (b, 3) float, mm
        2D meshes: z is the middle of the plate.
    normal : (b, 3) float
        Outward unit normals (``n_z = 0`` in 2D).
    area : (b,) float, mm²
        Length x thickness in 2D.
    shape_integral : (b, kf) float, mm²
        ``int N_a dA`` for each facet node.
    size : (b,) float, mm
        Length (2D) or square root of the area (3D).
    """

    nodes: np.ndarray
    centroid: np.ndarray
    normal: np.ndarray
    area: np.ndarray
    shape_integral: np.ndarray
    size: np.ndarray


def facets_of(mesh: MeshData) -> Facets:
    """Geometry of the boundary facets of a mesh."""
    f, _ = mesh.boundary
    p = mesh.points[f]
    if mesh.dim == 2:
        a, b = p[:, 0], p[:, 1]
        d = b - a
        length = np.hypot(d[:, 0], d[:, 1])
        n2 = np.column_stack([d[:, 1], -d[:, 0]]) / length[:, None]
        zmid = 0.0 if mesh.z_range is None else 0.5 * (mesh.z_range[0] + mesh.z_range[1])
        centroid = np.column_stack([0.5 * (a + b), np.full(len(f), zmid)])
        normal = np.column_stack([n2, np.zeros(len(f))])
        area = length * mesh.thickness
        ref = "line3" if f.shape[1] == 3 else "line2"
        xi, w = line_rule(3)
        size = length
    else:
        a, b, c = p[:, 0], p[:, 1], p[:, 2]
        cr = np.cross(b - a, c - a)
        dbl = np.linalg.norm(cr, axis=1)
        normal = cr / dbl[:, None]
        area = 0.5 * dbl
        centroid = (a + b + c) / 3.0
        ref = "tri6" if f.shape[1] == 6 else "tri3"
        xi, w = triangle_rule(2)
        w = 2.0 * w  # weights over the reference triangle -> fractions of the area
        size = np.sqrt(area)
    frac = ELEMENTS[ref].shape(xi).T @ w  # (kf,) mean of each shape function
    return Facets(f, centroid, normal, area, area[:, None] * frac[None, :], size)


def pick(mesh: MeshData, facets: Facets, sel: Selection) -> np.ndarray:
    """Facets a selection picks, ``(b,)`` bool."""
    c = facets.centroid
    if sel.lower is not None:
        lo, hi = sel.lower, sel.upper
        if mesh.dim == 2:
            return np.all((c[:, :2] >= lo[:2]) & (c[:, :2] <= hi[:2]), axis=1)
        return np.all((c >= lo) & (c <= hi), axis=1)
    mask = np.zeros(len(c), dtype=bool)
    lateral = np.abs(facets.normal[:, 2]) < 0.5
    for z0, z1, ring in sel.holes:
        inz = np.ones(len(c), dtype=bool) if mesh.dim == 2 else (c[:, 2] > z0) & (c[:, 2] < z1)
        cand = lateral & inz
        if not np.any(cand):
            continue
        d = shapely.distance(ring, shapely.points(c[cand, :2]))
        tol = np.maximum(0.3 * facets.size[cand], 0.05)
        idx = np.flatnonzero(cand)
        mask[idx[d <= tol]] = True
    return mask


def support_dofs(mesh: MeshData, facets: Facets, picked: np.ndarray, support: Support) -> np.ndarray:
    """Constrained dofs of a support: every node of the picked facets, in the fixed directions."""
    nodes = np.unique(facets.nodes[picked])
    axes = [a for a in support.fixed_axes if a < mesh.dim]
    if not axes:
        return np.zeros(0, dtype=np.int64)
    return (nodes[:, None] * mesh.dim + np.asarray(axes)[None, :]).ravel()


def load_vector(mesh: MeshData, facets: Facets, picked: np.ndarray, load: Load, body: str = "") -> np.ndarray:
    """Consistent nodal forces of one load, ``(n d,)`` N."""
    d = mesh.dim
    f = np.zeros((len(mesh.points), d))
    idx = np.flatnonzero(picked)
    nodes = facets.nodes[idx]
    S = facets.shape_integral[idx]  # (p, kf)
    n = facets.normal[idx, :d]
    if load.pressure is not None:
        t = -load.pressure * n  # (p, d)
        np.add.at(f, nodes.ravel(), (S[:, :, None] * t[:, None, :]).reshape(-1, d))
        return f.ravel()
    F = np.asarray(load.force, dtype=float)[:d]
    if not load.is_bearing:
        t = F / facets.area[idx].sum()
        np.add.at(f, nodes.ravel(), (S[:, :, None] * t[None, None, :]).reshape(-1, d))
        return f.ravel()
    Fn = np.linalg.norm(F)
    w = np.maximum(0.0, -(n @ (F / Fn)))  # cosine of the angle between the inward wall normal and F
    contact = w > 0
    shape_w = S * w[:, None]
    raw = (shape_w[:, :, None] * -n[:, None, :]).sum(axis=(0, 1))
    along = float(raw @ (F / Fn))
    if along <= 1e-6 * facets.area[idx].sum() or not np.any(contact):
        raise LoadCaseError(
            f"load {load.name!r} on object {body!r}: a bearing load needs a force across the hole, "
            f"got {list(load.force)}; "
            "use a box or side selector for a force along the hole axis"
        )
    p0 = Fn / along
    fb = shape_w[:, :, None] * (-p0 * n)[:, None, :]
    # the part of F the pressure does not carry (non-symmetric holes): uniform over the contact half
    corr = (F - fb.sum(axis=(0, 1))) / facets.area[idx][contact].sum()
    fb[contact] += S[contact][:, :, None] * corr[None, None, :]
    np.add.at(f, nodes.ravel(), fb.reshape(-1, d))
    return f.ravel()


def rigid_modes(points: np.ndarray) -> tuple[np.ndarray, list[str]]:
    """Rigid-body displacement modes at points, about their centroid and scaled by their size.

    Returns
    -------
    modes : (n d, r) float
        ``r = 3`` in 2D (x, y, rotation about z), 6 in 3D.
    names : list of str
    """
    n, d = points.shape
    c = points - points.mean(axis=0)
    L = max(float(np.max(np.abs(c))), 1e-12)
    c = c / L
    if d == 2:
        m = np.zeros((n, 2, 3))
        m[:, 0, 0] = 1.0
        m[:, 1, 1] = 1.0
        m[:, 0, 2], m[:, 1, 2] = -c[:, 1], c[:, 0]
        return m.reshape(n * 2, 3), ["translate along x", "translate along y", "rotate about z"]
    m = np.zeros((n, 3, 6))
    for i in range(3):
        m[:, i, i] = 1.0
    x, y, z = c[:, 0], c[:, 1], c[:, 2]
    m[:, 1, 3], m[:, 2, 3] = -z, y  # about x
    m[:, 0, 4], m[:, 2, 4] = z, -x  # about y
    m[:, 0, 5], m[:, 1, 5] = -y, x  # about z
    names = [
        "translate along x",
        "translate along y",
        "translate along z",
        "rotate about x",
        "rotate about y",
        "rotate about z",
    ]
    return m.reshape(n * 3, 6), names


def check_rigid(mesh: MeshData, fixed: np.ndarray, rb: ResolvedBody) -> None:
    """Raise when the constrained dofs leave some connected piece of the mesh free to move.

    Parameters
    ----------
    mesh : MeshData
    fixed : (p,) int
        Constrained dofs.
    rb : ResolvedBody
        For the message (body name, supports).

    Raises
    ------
    LoadCaseError
        Naming the body, the free motion and suggesting a support.
    """
    d = mesh.dim
    pieces = mesh.pieces
    # (piece, node) pairs, grouped by piece; a node in more than one piece is a hinge between them
    pairs = np.unique(np.stack([np.repeat(pieces, mesh.cells.shape[1]), mesh.cells.ravel()]), axis=1)
    starts = np.searchsorted(pairs[0], np.arange(pieces.max() + 2 if len(pieces) else 1))
    shared = np.bincount(pairs[1], minlength=len(mesh.points)) > 1
    fixed = np.unique(fixed)
    fixed_nodes = fixed // d
    many = len(starts) > 2
    for k in range(len(starts) - 1):
        nodes = pairs[1, starts[k] : starts[k + 1]]
        modes, names = rigid_modes(mesh.points[nodes])
        # rows of the modes at this piece's constrained dofs
        local = np.full(len(mesh.points), -1)
        local[nodes] = np.arange(len(nodes))
        sel = fixed[local[fixed_nodes] >= 0]
        rows = local[sel // d] * d + sel % d
        C = modes[rows]
        s = np.linalg.svd(C, compute_uv=False) if len(rows) else np.zeros(0)
        r = int(np.sum(s > 1e-8 * max(1.0, s.max() if len(s) else 1.0)))
        if r >= modes.shape[1]:
            continue
        _, _, vt = np.linalg.svd(C if len(rows) else np.zeros((1, modes.shape[1])))
        null = vt[r:]
        free = _describe(null, names)
        where = ""
        if many:
            lo, hi = mesh.points[nodes].min(axis=0), mesh.points[nodes].max(axis=0)
            hinge = ", which meets the rest only at a point or along an edge" if shared[nodes].any() else ""
            where = (
                " (the piece at "
                + ", ".join(f"{a} {lo[i]:.1f}..{hi[i]:.1f}" for i, a in enumerate("xyz"[:d]))
                + f"{hinge})"
            )
        dim_note = ""
        if d == 3 and any("z" in f for f in free):
            dim_note = f"; it is analysed in 3D because {rb.reason}"
        names_s = ", ".join(repr(s.name) for s, _ in rb.supports)
        raise LoadCaseError(
            f"{rb.loadcase.source}: object {rb.name!r}{where} is free to {' and '.join(free)}: "
            f"the supports ({names_s}) do not hold it{dim_note}; "
            'add a support (e.g. fix = ["x", "y", "z"] on a side) or fix more directions'
        )


def _describe(null: np.ndarray, names: list[str]) -> list[str]:
    """Name the free motions spanned by null-space vectors (rows)."""
    out = []
    # project each basic mode onto the null space; those lying in it are free
    P = null.T @ null
    for i, nm in enumerate(names):
        if P[i, i] > 0.5:
            out.append(nm)
    if not out:
        v = null[0]
        out = [" + ".join(names[i] for i in np.argsort(-np.abs(v))[:2] if abs(v[i]) > 0.2)]
    return out
