"""The areal part of a shapely geometry: the one owner of "which polygons does this hold".

Shapely's set operations on two regions that touch along an edge or at a point return a
GeometryCollection that holds that line or point beside the polygons, and such a collection has no
``boundary``.  Every stage that intersects, subtracts or unites regions (the part body, the layer
geometry, the engines' density zones, the mesher) keeps only the polygons, with these two
functions.  They sit at the bottom of the package stack so that every stage can use them.
"""

from __future__ import annotations

from loadpath._typing import Region
from shapely.geometry import MultiPolygon, Polygon
from shapely.geometry.base import BaseGeometry

__all__ = ["EMPTY", "polygons_of", "as_region"]

EMPTY = Polygon()
"""The empty region."""


def polygons_of(geom: BaseGeometry | None) -> list[Polygon]:
    """Return the non-empty polygons of a Polygon, MultiPolygon or GeometryCollection (nested too).

    Lines and points are dropped; ``None`` and empty geometries give ``[]``.
    """
    if geom is None or geom.is_empty:
        return []
    if isinstance(geom, Polygon):
        return [geom]
    out: list[Polygon] = []
    for g in getattr(geom, "geoms", []):
        out.extend(polygons_of(g))
    return out


def as_region(geom: BaseGeometry | None) -> Region:
    """Keep the areal part of a geometry: a Polygon, a MultiPolygon, or :data:`EMPTY`.

    Polygons of zero area are dropped.
    """
    polys = [p for p in polygons_of(geom) if p.area > 0]
    if not polys:
        return EMPTY
    return polys[0] if len(polys) == 1 else MultiPolygon(polys)
