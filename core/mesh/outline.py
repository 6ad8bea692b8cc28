"""Preparing part outlines for meshing: clean rings, required vertices, refinement points.

G-code outlines carry jitter and polygonised arcs. Only near-collinear vertices are removed (a
coarser simplification puts kinks of several degrees into arcs, and every kink is a weak stress
singularity that inflates the peak stress at a hole), vertices closer than a fraction of the
smallest element are merged, and the ends of selected boundary pieces are inserted as vertices so
the mesh follows them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import shapely
from loadpath._typing import Points2
from loadpath.areal import polygons_of
from loadpath.errors import MeshingError
from loadpath.mesh.sizing import MeshSize, reentrant_corners
from shapely.geometry import LineString, Point
from shapely.geometry.base import BaseGeometry
from shapely.geometry.polygon import orient

__all__ = ["prepare_rings", "decimate", "insert_points", "sample", "refine_groups"]


def decimate(
    c: np.ndarray, min_len: float, closed: bool = True, keep: np.ndarray | None = None
) -> np.ndarray:
    """Drop vertices closer than ``min_len`` to their predecessor.

    Never a vertex marked in ``keep``, never the ends of an open line, never two neighbours in one
    pass, never below a triangle.

    Parameters
    ----------
    c : (n, 2) float, mm
        Ring (without the closing repeat) or open line.
    min_len : float, mm
    closed : bool
    keep : (n,) bool, optional
        Vertices that must stay (e.g. ends of selected boundary pieces).

    Returns
    -------
    (k, 2) float
    """
    low = 3 if closed else 2
    kept = np.zeros(len(c), dtype=bool) if keep is None else np.asarray(keep, dtype=bool).copy()
    if not closed and len(c):
        kept[0] = kept[-1] = True
    while len(c) > low:
        if closed:
            short = np.linalg.norm(np.roll(c, -1, axis=0) - c, axis=1) < min_len  # segment i -> i + 1
            drop = np.roll(short & ~np.roll(short, 1), 1)  # vertex i + 1 after a short segment i
            # a kept vertex after a short segment: drop the one before it instead
            back = drop & kept
            drop = (drop & ~kept) | (np.roll(back, -1) & ~kept & ~np.roll(drop, 1))
        else:
            short = np.linalg.norm(c[1:] - c[:-1], axis=1) < min_len
            drop = np.zeros(len(c), dtype=bool)
            drop[1:] = short & ~np.concatenate([[False], short[:-1]])
            back = drop & kept
            drop = drop & ~kept
            drop[:-1] |= back[1:] & ~kept[:-1] & ~np.concatenate([[False], drop[:-2]])
        if not np.any(drop) or len(c) - int(drop.sum()) < low:
            break
        c = c[~drop]
        kept = kept[~drop]
    return c


def insert_points(coords: np.ndarray, extra: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """Insert the points lying on a closed ring's segments (within ``tol``) as vertices.

    Returns
    -------
    coords : (k, 2) float
    is_extra : (k,) bool
        Vertices that are (or coincide with) one of the points.
    """
    c = coords
    for p in extra:
        a = c
        ab = np.roll(c, -1, axis=0) - a
        L2 = np.einsum("ij,ij->i", ab, ab)
        t = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.where(L2 > 0, L2, 1.0), 0.0, 1.0)
        d = np.linalg.norm(a + t[:, None] * ab - p, axis=1)
        k = int(np.argmin(d))
        if d[k] > tol or np.min(np.linalg.norm(c - p, axis=1)) <= tol:
            continue
        c = np.insert(c, k + 1, a[k] + t[k] * ab[k], axis=0)
    if len(extra) == 0:
        return c, np.zeros(len(c), dtype=bool)
    dist = np.min(np.linalg.norm(c[:, None, :] - extra[None, :, :], axis=2), axis=1)
    return c, dist <= tol


def prepare_rings(
    outline: BaseGeometry, size: MeshSize, split_at: Points2 | None = None
) -> list[list[np.ndarray]]:
    """Clean rings per polygon: ``[[exterior, hole, ...], ...]``, each ``(n, 2)`` without repeat.

    Exteriors counter-clockwise, holes clockwise.
    """
    tol = min(0.005, 1e-3 * size.h_min)
    simple = shapely.simplify(outline, tol, preserve_topology=True)
    extra = np.zeros((0, 2)) if split_at is None else np.asarray(split_at, dtype=float).reshape(-1, 2)
    polys = []
    for poly in polygons_of(simple):
        poly = orient(poly, 1.0)
        rings = []
        for r in [poly.exterior, *poly.interiors]:
            c, keep = insert_points(np.asarray(r.coords)[:-1, :2], extra, 1e-3 * size.h_min)
            rings.append(decimate(c, 0.2 * size.h_min, keep=keep))
        _check_crossing(rings, 0.2 * size.h_min)
        polys.append(rings)
    if not polys:
        raise MeshingError("the part outline is empty after cleaning; check the layer geometry")
    return polys


def _check_crossing(rings: list[np.ndarray], merged: float) -> None:
    """Raise :class:`MeshingError` when the cleaned rings of one polygon cross each other or themselves.

    A notch or gap much narrower than the mesh (a wall line lost to a damaged or replaced G-code
    line) can cross itself once nearby vertices are merged; gmsh's mesher then never returns on it
    (a polygon whose edge crosses a vertex's edge ran over a minute in ``generate(2)``).  Rings that
    only touch at a point are left to gmsh.
    """
    from shapely.geometry import Polygon
    from shapely.validation import explain_validity

    why = explain_validity(Polygon(rings[0], rings[1:]))
    if not why.startswith("Self-intersection"):
        return
    x, y = (float(v) for v in why[why.index("[") + 1 : why.index("]")].split()[:2])
    raise MeshingError(
        f"the part outline crosses itself near ({x:.3f}, {y:.3f}) mm once vertices closer than "
        f"{merged:.3g} mm are merged for the mesh: a notch or gap there is far narrower than any mesh "
        "can follow (a wall line missing or damaged in the file?); check the walls at that place, or set "
        "a smaller --pitch (it sets the mesh size)"
    )


def sample(geom: BaseGeometry, step: float) -> np.ndarray:
    """Sample points along lines and ring boundaries (every ``step`` mm, ends included), ``(n, 2)``.

    Points are returned as they are.
    """
    out = []
    for g in getattr(geom, "geoms", [geom]):
        if g.is_empty:
            continue
        if isinstance(g, Point):
            out.append(np.array([[g.x, g.y]]))
        elif hasattr(g, "exterior"):
            for r in [g.exterior, *g.interiors]:
                out.append(sample(LineString(r.coords), step))
        else:
            n = max(2, int(math.ceil(g.length / step)) + 1)
            d = np.linspace(0.0, g.length, n)
            out.append(shapely.get_coordinates(shapely.line_interpolate_point(g, d))[:, :2])
    return np.concatenate(out) if out else np.zeros((0, 2))


def refine_groups(
    outlines: Sequence[BaseGeometry], size: MeshSize, lines: Sequence[BaseGeometry] = ()
) -> list[tuple[np.ndarray, float]]:
    """Points to refine at and their sizes: holes and re-entrant corners (``h_min``), ``lines`` (``h_bc``)."""
    holes = [LineString(r.coords) for o in outlines for p in polygons_of(o) for r in p.interiors]
    groups = []
    if holes:
        groups.append((sample(shapely.MultiLineString(holes), 0.5 * size.h_min), size.h_min))
    corners = [reentrant_corners(o) for o in outlines]
    corners = [c for c in corners if len(c)]
    if corners:
        groups.append((np.unique(np.concatenate(corners), axis=0), size.h_min))
    pts = [sample(g, 0.5 * size.h_bc) for g in lines if g is not None and not g.is_empty]
    if pts:
        groups.append((np.concatenate(pts), size.h_bc))
    return groups
