"""Part outline and infill domain of one object in one layer, from the perimeters the slicer printed.

Two unions of perimeter beads (:func:`loadpath.geometry.ops.bead_union`) give everything; loops whose
ends miss by less than a bead (PrusaSlicer clips every loop end) are closed rings already:

``wall band`` (bead widths)
    Every perimeter centre line buffered by half its bead width (``;WIDTH:``, or the flow width when
    the file has none).  Its outer rings are the outside of the external perimeter: the **part
    outline**.  Each of its inner rings bounds either air (a hole of the part) or the inside of the
    innermost perimeter.  A ring bounds air when nothing but perimeters lies inside it (nested
    islands excluded) and most of the perimeter next to it is an external perimeter; otherwise it is
    filled.  Inner rings whose region is thinner on average than ``2 * TOL.snap_mm`` are slits
    between loops that (nearly) touch, not rings: they are filled.
``flow band``
    The same centre lines buffered by half their **flow width** (extruded cross-section / height:
    for PrusaSlicer ``w - h (1 - pi/4)``, which is also its perimeter spacing).  The **infill domain**
    is what its inner rings enclose inside the part (holes and slits left out).

So for PrusaSlicer's classic and Arachne perimeters on a straight wall, with ``n >= 2`` loops, external
bead width ``we`` and spacings ``se``, ``sp``, the domain edge lies ``we/2 + (se + sp)/2 + (n - 2) sp +
sp/2`` inside the sliced contour; see ``tests/geometry/test_geo_layers.py`` for the analytic check.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from loadpath._typing import Bools, Floats, Region
from loadpath.areal import EMPTY, as_region, polygons_of
from loadpath.geometry.ops import bead_union
from loadpath.tolerances import TOL
from shapely.geometry import LinearRing, Polygon

__all__ = ["Walls", "walls"]


@dataclass(frozen=True)
class Walls:
    """The perimeters of one object in one layer, as regions.

    Attributes
    ----------
    outline : Polygon or MultiPolygon
        Part outline (outer rings counter-clockwise).
    domain : Polygon or MultiPolygon
        Infill domain (possibly empty).
    band : Polygon or MultiPolygon
        The perimeters' beads at their flow width (what the walls cover).
    """

    outline: Region
    domain: Region
    band: Region


def walls(x0: Floats, y0: Floats, x1: Floats, y1: Floats, bead: Floats, flow: Floats, external: Bools,
          inside_x: Floats, inside_y: Floats) -> Walls:
    """Outline, domain and wall band from perimeter segments.

    Parameters
    ----------
    x0, y0, x1, y1 : (n,) float, mm
        Perimeter extrusions of one object in one layer, in print order.
    bead : (n,) float, mm
        Bead width of each segment.
    flow : (n,) float, mm
        Flow width of each segment.
    external : (n,) bool
        External (outermost) perimeter segments.
    inside_x, inside_y : (m,) float, mm
        Points of the object's other extrusions in the layer (infill, gap fill): material that marks
        the inside of the innermost perimeter.

    Returns
    -------
    Walls
    """
    snap = TOL.snap_mm
    wide = bead_union(x0, y0, x1, y1, bead / 2)
    polys = polygons_of(wide)
    if not polys:
        return Walls(EMPTY, EMPTY, EMPTY)
    shells, rings = _shells_and_rings(polys, snap)
    pts = shapely.points(np.column_stack([inside_x, inside_y])) if len(inside_x) else None
    seg_tree = None
    air = []
    for ring, direct in rings:
        if pts is not None and shapely.contains(direct, pts).any():
            continue  # material inside: the inside of the innermost perimeter
        if seg_tree is None:
            seg_tree = shapely.STRtree(shapely.linestrings(
                np.stack([np.column_stack([x0, y0]), np.column_stack([x1, y1])], axis=1)))
        if _mostly_external(ring, seg_tree, external):
            air.append(direct)
    outline = shapely.union_all(shells)
    if air:  # the direct regions exclude nested islands, so an island inside a hole stays
        outline = shapely.difference(outline, shapely.union_all(air))
    outline = as_region(outline)
    outline = as_region(shapely.orient_polygons(outline)) if hasattr(shapely, "orient_polygons") else outline
    same = np.array_equal(bead, flow)
    band = wide if same else bead_union(x0, y0, x1, y1, flow / 2)
    if not same:
        _, rings = _shells_and_rings(polygons_of(band), snap)
    # the domain: inside the flow band's inner rings that lie in the part (not holes, not slivers)
    shapely.prepare(outline)
    pieces = [direct for _, direct in rings
              if not direct.is_empty and outline.contains_properly(direct.representative_point())]
    domain = as_region(shapely.union_all(pieces)) if pieces else EMPTY
    return Walls(outline, domain, band)


def _shells_and_rings(polys: list[Polygon],
                      snap: float) -> tuple[list[Polygon], list[tuple[LinearRing, Region]]]:
    """Fill the outer rings of a band's polygons; pair each inner ring with the region directly inside it.

    The direct region of an inner ring is the ring's polygon minus the filled polygons nested in it.
    Direct regions narrower on average than ``2 * snap`` (``area / length <= snap``: the slit between
    two loops that touch, a seam) are no rings at all and are left out.
    """
    shells = [Polygon(p.exterior) for p in polys]
    tree = shapely.STRtree(shells)
    rings = []
    for p in polys:
        for ring in p.interiors:
            hole = Polygon(ring)
            nested = [shells[j] for j in tree.query(hole, predicate="contains_properly")]
            direct = as_region(shapely.difference(hole, shapely.union_all(nested)) if nested else hole)
            if direct.area <= snap * direct.length:
                continue  # a slit between loops, not a region
            rings.append((ring, direct))
    return shells, rings


def _mostly_external(ring: LinearRing, seg_tree: shapely.STRtree, external: Bools) -> bool:
    """Most of the perimeter next to ``ring`` is external perimeter (the ring faces air)."""
    pts = shapely.points(np.asarray(ring.coords)[:-1])
    if len(pts) == 0:
        return True
    nearest = seg_tree.nearest(pts)
    return bool(external[nearest].mean() >= 0.5)
