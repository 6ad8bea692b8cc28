"""Evaluate selectors against a body's boundary.

A :class:`Selection` holds what a ``where = {...}`` picked, in the bed frame:

* for side and box selectors, the closed box ``lower <= p <= upper`` (a side selector is the box
  ``x <= x_min + within`` etc. of the body's bounding box);
* for hole selectors, per slab, the hole ring nearest to the point (if within the radius);
* the picked boundary itself: lateral pieces (lines of the outline, per slab z range) and, for a 3D
  analysis, horizontal faces (exposed tops and bottoms), with their measure (area, mm²).

The finite-element code applies the same box / ring test to mesh facets (``loadpath.fea.boundary``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from loadpath.areal import polygons_of
from loadpath.body import Body
from loadpath.loadcase.model import BoxSelector, HoleSelector, Selector, SideSelector
from loadpath.tolerances import TOL
from shapely.geometry import LineString, MultiLineString, Point, Polygon
from shapely.geometry.base import BaseGeometry

__all__ = ["Selection", "select", "exposed_faces", "box_of", "selection_eps"]


@dataclass(frozen=True)
class Selection:
    """The boundary one selector picked on one body (bed frame).

    Attributes
    ----------
    name : str
        The support's or load's name.
    role : {"support", "load"}
    selector : Selector
        As written in the load case.
    lower, upper : (3,) float, mm, or None
        The closed box of a side or box selector (``±inf`` where open); None for a hole selector.
    holes : tuple of (z0, z1, LinearRing)
        Hole selectors: the picked hole ring per slab.
    lateral : tuple of (z0, z1, lines)
        Picked pieces of the side walls: the outline lines (MultiLineString, xy) over ``z0..z1``.
    faces : tuple of (z, Polygon or MultiPolygon)
        Picked pieces of exposed horizontal faces (only used by a 3D analysis).
    """

    name: str
    role: str
    selector: Selector
    lower: np.ndarray | None
    upper: np.ndarray | None
    holes: tuple[tuple[float, float, BaseGeometry], ...]
    lateral: tuple[tuple[float, float, BaseGeometry], ...]
    faces: tuple[tuple[float, BaseGeometry], ...]

    @property
    def area_lateral(self) -> float:
        """Area of the picked side walls (length x height), mm²."""
        return float(sum(g.length * (z1 - z0) for z0, z1, g in self.lateral))

    @property
    def area_faces(self) -> float:
        """Area of the picked horizontal faces, mm²."""
        return float(sum(g.area for _, g in self.faces))

    def measure(self, analysis: str) -> float:
        """Return the picked area in a ``"2d"`` (side walls only) or ``"3d"`` analysis, mm²."""
        return self.area_lateral + (self.area_faces if analysis == "3d" else 0.0)

    def lines_at(self, z: float) -> BaseGeometry | None:
        """Return the picked side-wall lines at height ``z`` (xy), or None when nothing is picked."""
        parts = []
        for z0, z1, g in self.lateral:
            if z0 - TOL.length_mm <= z <= z1 + TOL.length_mm and not g.is_empty:
                parts.append(g)
        if not parts:
            return None
        return shapely.line_merge(shapely.unary_union(parts))

    @property
    def lines(self) -> BaseGeometry | None:
        """All picked side-wall lines, projected on xy."""
        parts = [g for _, _, g in self.lateral if not g.is_empty]
        return shapely.line_merge(shapely.unary_union(parts)) if parts else None


def selection_eps(body: Body) -> float:
    """Tolerance of the box tests: a point on a box face is inside, mm."""
    lo, hi = body.bounds
    return max(10.0 * TOL.length_mm, 1e-9 * float(np.max(hi - lo)))


def box_of(selector: Selector, body: Body, origin: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return the bed-frame box of a side or box selector.

    Parameters
    ----------
    selector : SideSelector or BoxSelector
    body : Body
    origin : (3,) float, mm
        Added to box bounds (the body's minimum corner with ``frame = "part"``, else zeros).

    Returns
    -------
    lower, upper : (3,) float, mm
        Widened by :func:`selection_eps`.
    """
    eps = selection_eps(body)
    blo, bhi = body.bounds
    lo = np.full(3, -np.inf)
    hi = np.full(3, np.inf)
    if isinstance(selector, SideSelector):
        a = selector.axis
        if selector.is_max:
            lo[a] = bhi[a] - selector.within
        else:
            hi[a] = blo[a] + selector.within
    elif isinstance(selector, BoxSelector):
        lo = np.asarray(selector.lower, dtype=float) + origin
        hi = np.asarray(selector.upper, dtype=float) + origin
    else:  # pragma: no cover
        raise TypeError(f"not a box selector: {selector!r}")
    return lo - eps, hi + eps


def exposed_faces(body: Body) -> list[tuple[float, BaseGeometry, int]]:
    """Return the horizontal faces of the body's boundary.

    Returns
    -------
    list of (z, region, sign)
        ``sign = -1`` for downward faces (bottoms), ``+1`` for upward faces (tops).
    """
    s = body.slabs
    out: list[tuple[float, BaseGeometry, int]] = [(s[0].z0, s[0].outline, -1)]
    for a, b in zip(s[:-1], s[1:], strict=True):
        up = shapely.difference(a.outline, b.outline)
        down = shapely.difference(b.outline, a.outline)
        if up.area > 0:
            out.append((a.z1, up, +1))
        if down.area > 0:
            out.append((b.z0, down, -1))
    out.append((s[-1].z1, s[-1].outline, +1))
    return out


def _clip_box(lo: np.ndarray, hi: np.ndarray, body: Body) -> Polygon:
    blo, bhi = body.bounds
    pad = 1.0 + float(np.max(bhi - blo))
    x0 = max(lo[0], blo[0] - pad)
    y0 = max(lo[1], blo[1] - pad)
    x1 = min(hi[0], bhi[0] + pad)
    y1 = min(hi[1], bhi[1] + pad)
    if x1 <= x0 or y1 <= y0:
        return Polygon()
    return shapely.box(x0, y0, x1, y1)


def _lines(g: BaseGeometry) -> BaseGeometry:
    """Keep only the linear parts of an intersection result."""
    if g.is_empty:
        return MultiLineString()
    parts = [p for p in getattr(g, "geoms", [g]) if isinstance(p, (LineString, MultiLineString))]
    lines: list[LineString] = []
    for p in parts:
        lines.extend(getattr(p, "geoms", [p]))
    return MultiLineString([ln for ln in lines if ln.length > 0])


def select(selector: Selector, body: Body, origin: np.ndarray, name: str, role: str) -> Selection:
    """Evaluate one selector on a body.

    Parameters
    ----------
    selector : Selector
    body : Body
        Merged slabs.
    origin : (3,) float, mm
        Frame origin added to the selector's coordinates.
    name, role : str
        Copied into the result.

    Returns
    -------
    Selection
        Possibly empty; the caller reports empty selections.
    """
    if isinstance(selector, HoleSelector):
        return _select_hole(selector, body, origin, name, role)
    lo, hi = box_of(selector, body, origin)
    poly = _clip_box(lo, hi, body)
    lateral = []
    for s in body.slabs:
        z0, z1 = max(s.z0, lo[2]), min(s.z1, hi[2])
        if z1 <= z0 or poly.is_empty:
            continue
        g = _lines(shapely.intersection(s.outline.boundary, poly))
        if g.length > 0:
            lateral.append((float(z0), float(z1), g))
    faces = []
    for z, region, _ in exposed_faces(body):
        if lo[2] <= z <= hi[2] and not poly.is_empty:
            g = shapely.intersection(region, poly)
            if g.area > 0:
                faces.append((float(z), g))
    return Selection(name, role, selector, lo, hi, (), tuple(lateral), tuple(faces))


def nearest_hole(slab_outline: BaseGeometry, point: tuple[float, float]) -> tuple[BaseGeometry | None, float]:
    """Return the interior ring of an outline nearest to a point, and its distance (0 inside it)."""
    rings = [r for p in polygons_of(slab_outline) for r in p.interiors]
    if not rings:
        return None, math.inf
    d = shapely.distance([Polygon(r) for r in rings], Point(point))
    k = int(np.argmin(d))
    return rings[k], float(d[k])


def _select_hole(sel: HoleSelector, body: Body, origin: np.ndarray, name: str, role: str) -> Selection:
    near = (sel.near[0] + float(origin[0]), sel.near[1] + float(origin[1]))
    holes = []
    lateral = []
    for s in body.slabs:
        ring, d = nearest_hole(s.outline, near)
        if ring is None:
            continue
        limit = sel.radius
        if limit is None:  # the hole's own diameter
            x0, y0, x1, y1 = ring.bounds
            limit = max(x1 - x0, y1 - y0)
        if d <= limit:
            holes.append((s.z0, s.z1, ring))
            lateral.append((s.z0, s.z1, MultiLineString([LineString(ring.coords)])))
    return Selection(name, role, sel, None, None, tuple(holes), tuple(lateral), ())
