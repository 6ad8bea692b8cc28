"""Footprints and regions of the infill blocks of one island, and the check against their extrusions.

Words (interface.md): the **infill domain** is inside the innermost perimeter; a block's
**footprint** is the area its beads cover, closed over its own pitch (so parallel lines become the
area they fill); a block's **region** is the domain minus the footprints of the island's other
blocks; the **replace region** for a set of kinds is the domain minus the footprints of the blocks
that are kept.

Footprints, in two passes:

1. Dense blocks (pitch at most :data:`DENSE_PITCH` flow widths): ``closing(beads, r) & domain`` with
   ``r = 0.55 * pitch``.  Their edges are accurate to a fraction of a bead.
2. Sparse blocks cannot be closed that way: where their lines meet a boundary at a slant, the line
   ends stand ``pitch / sin(angle)`` apart along it.  A single sparse block takes what the dense
   blocks leave of the domain.  Several sparse blocks in one island (rare) are each closed over their
   own pitch, walls included (their last line can stand up to a pitch away from a wall):
   ``closing(beads | walls, r) & domain``, minus the dense footprints.

Every block is then checked: its centre lines must lie inside its region within
``TOL.region_check_rel`` flow widths (slicers run infill a little into the innermost perimeter).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from loadpath._typing import Floats, Region
from loadpath.geometry.ops import EMPTY, as_region, bead_union, clean
from loadpath.tolerances import TOL

__all__ = ["BlockLines", "footprints", "regions", "outside_distance", "check_tolerance",
           "DENSE_PITCH"]

DENSE_PITCH = 1.5
"""A block whose pitch is at most this many flow widths is dense (its beads nearly touch)."""

_CLOSE = 0.55  # closing radius / pitch: neighbouring lines at one pitch merge, with a margin


@dataclass(frozen=True)
class BlockLines:
    """The extruding segments of one block inside one island.

    Attributes
    ----------
    x0, y0, x1, y1 : (n,) float, mm
    flow_width : float, mm
    pitch : float, mm
        Line spacing (estimated; never NaN here: the caller falls back to an area estimate).
    """

    x0: Floats
    y0: Floats
    x1: Floats
    y1: Floats
    flow_width: float
    pitch: float

    @property
    def dense(self) -> bool:
        """Beads at most :data:`DENSE_PITCH` flow widths apart."""
        return bool(self.pitch <= DENSE_PITCH * self.flow_width)

    def beads(self, grow: float = 0.0) -> Region:
        """Union of the block's beads (flow width), dilated by ``grow`` mm.

        Gaps up to ``2 grow`` between consecutive lines are bridged: a dilation by ``grow`` covers them
        anyway, and one long zigzag buffers much faster than hundreds of separate lines.
        """
        half = np.full(len(self.x0), self.flow_width / 2)
        return bead_union(self.x0, self.y0, self.x1, self.y1, half, grow=grow, bridge=2 * grow)


def footprints(blocks: list[BlockLines], domain: Region, walls: Region) -> list[Region]:
    """Footprint of every block of an island (see the module docstring).

    Parameters
    ----------
    blocks : list of BlockLines
    domain : Polygon or MultiPolygon
        The island's infill domain.
    walls : Polygon or MultiPolygon
        The island's outline minus its domain (perimeters and what lies outside).

    Returns
    -------
    list of Polygon or MultiPolygon, one per block
    """
    out: list[Region] = [EMPTY] * len(blocks)
    if domain.is_empty:
        return out
    if len(blocks) == 1:
        return [domain]  # the only block of the island fills its domain
    shapely.prepare(domain)
    for i, b in enumerate(blocks):
        if b.dense:
            r = _CLOSE * max(b.pitch, b.flow_width)
            closed = as_region(shapely.buffer(b.beads(grow=r), -r, quad_segs=4))
            out[i] = as_region(shapely.intersection(closed, domain))
    dense = [out[j] for j, b in enumerate(blocks) if b.dense and not out[j].is_empty]
    sparse = [i for i, b in enumerate(blocks) if not b.dense]
    if len(sparse) == 1:
        rest = shapely.difference(domain, shapely.union_all(dense)) if dense else domain
        out[sparse[0]] = clean(rest)
        return out
    for i in sparse:
        b = blocks[i]
        r = _CLOSE * b.pitch
        grown = shapely.union(b.beads(grow=r), shapely.buffer(walls, r, quad_segs=4))
        fp = shapely.intersection(as_region(shapely.buffer(grown, -r, quad_segs=4)), domain)
        if dense:
            fp = shapely.difference(fp, shapely.union_all(dense))
        out[i] = as_region(fp)
    return out


def regions(domain: Region, prints: list[Region]) -> list[Region]:
    """Region of every block: the domain minus the other blocks' footprints (cleaned)."""
    if len(prints) == 1:
        return [domain]
    out = []
    for i in range(len(prints)):
        others = [p for j, p in enumerate(prints) if j != i and not p.is_empty]
        out.append(clean(shapely.difference(domain, shapely.union_all(others))) if others else domain)
    return out


def outside_distance(b: BlockLines, region: Region) -> float:
    """Largest distance of the block's centre lines (ends and midpoints) outside ``region``, mm."""
    if len(b.x0) == 0:
        return 0.0
    if region.is_empty:
        return float("inf")
    x = np.concatenate([b.x0, b.x1, (b.x0 + b.x1) / 2])
    y = np.concatenate([b.y0, b.y1, (b.y0 + b.y1) / 2])
    shapely.prepare(region)
    inside = shapely.contains_xy(region, x, y)
    if inside.all():
        return 0.0
    pts = shapely.points(np.column_stack([x[~inside], y[~inside]]))
    return float(shapely.distance(region, pts).max())


def check_tolerance(flow_width: float) -> float:
    """How far a block's centre lines may lie outside its region, mm (``TOL.region_check_rel`` widths)."""
    return TOL.region_check_rel * flow_width
