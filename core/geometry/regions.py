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
   blocks leave of the domain.  Several sparse blocks in one island share what the dense blocks
   leave: each point of it goes to the block whose centre lines are nearest (a Voronoi split of
   points sampled along the lines).  Bambu Studio and OrcaSlicer print one sparse fill in several
   pieces (before and after a ring of solid infill, or a piece per corner), and a piece's notch in
   another piece's lines is as wide as the piece: closing each piece over its own pitch, as this
   module once did, let the large piece swallow the small one (layer 39 of the Bambu Studio A1
   hook: the small piece's region came out empty).

Every block is then checked: its centre lines must lie inside its region within
``TOL.region_check_rel`` flow widths (slicers run infill a little into the innermost perimeter).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from loadpath import budget
from loadpath._typing import Floats, Region
from loadpath.areal import EMPTY, as_region
from loadpath.geometry.ops import bead_union, clean
from loadpath.tolerances import TOL

__all__ = ["BlockLines", "footprints", "regions", "nearest_split", "outside_distance", "check_tolerance",
           "DENSE_PITCH"]

DENSE_PITCH = 1.5
"""A block whose pitch is at most this many flow widths is dense (its beads nearly touch)."""

_CLOSE = 0.55  # closing radius / pitch: neighbouring lines at one pitch merge, with a margin
_GRID = 1e-5  # mm: snap-rounded union of Voronoi cells (exact unions fail on their near-degenerate edges)


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


def footprints(blocks: list[BlockLines], domain: Region) -> list[Region]:
    """Footprint of every block of an island (see the module docstring).

    Parameters
    ----------
    blocks : list of BlockLines
    domain : Polygon or MultiPolygon
        The island's infill domain.

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
    if not sparse:
        return out
    rest = clean(shapely.difference(domain, shapely.union_all(dense))) if dense else domain
    if len(sparse) == 1:
        out[sparse[0]] = rest
        return out
    for i, part in zip(sparse, nearest_split(rest, [blocks[i] for i in sparse]), strict=True):
        out[i] = part
    return out


def nearest_split(area: Region, blocks: list[BlockLines]) -> list[Region]:
    """Split ``area`` among blocks: every point goes to the block whose centre lines are nearest.

    The lines are sampled every flow width (at least every quarter of the smallest pitch), and the
    Voronoi cells of the samples are merged per block; the split is exact to about a sample spacing.

    Parameters
    ----------
    area : Polygon or MultiPolygon
    blocks : list of BlockLines

    Returns
    -------
    list of Polygon or MultiPolygon, one per block (they tile ``area``)
    """
    n = len(blocks)
    if area.is_empty or n == 0:
        return [EMPTY] * n
    step = min(min(b.flow_width, 0.25 * b.pitch) for b in blocks)
    x0 = np.concatenate([b.x0 for b in blocks])
    y0 = np.concatenate([b.y0 for b in blocks])
    x1 = np.concatenate([b.x1 for b in blocks])
    y1 = np.concatenate([b.y1 for b in blocks])
    owner = np.repeat(np.arange(n), [len(b.x0) for b in blocks])
    k = np.ceil(np.hypot(x1 - x0, y1 - y0) / step) + 1  # samples per segment, ends included
    budget.check(float(k.sum()), budget.SPLIT_SAMPLES, "", "samples of the nearest-lines split of its sparse "
                 f"infill (lines {float(np.hypot(x1 - x0, y1 - y0).sum()):.0f} mm long sampled every {step:.2g} mm)",
                 "the infill's bead width or pitch is implausibly small: check the ;WIDTH: lines and the "
                 "extrusion (E) of the layer's infill, or re-slice the part")
    k = k.astype(np.int64)
    seg = np.repeat(np.arange(len(k)), k)
    t = (np.arange(k.sum()) - np.repeat(np.cumsum(k) - k, k)) / np.repeat(k - 1, k).clip(min=1)
    pts = np.column_stack([x0[seg] + t * (x1[seg] - x0[seg]), y0[seg] + t * (y1[seg] - y0[seg])])
    pts, first = np.unique(np.round(pts, 4), axis=0, return_index=True)  # GEOS merges equal points
    who = owner[seg[first]]
    if len(np.unique(who)) == 1:
        return [area if i == who[0] else EMPTY for i in range(n)]
    cells = shapely.voronoi_polygons(shapely.multipoints(pts), extend_to=area, ordered=True)
    cells = shapely.get_parts(cells)
    bad = ~shapely.is_valid(cells)  # GEOS may return a cell with a bow-tie vertex (points nearly collinear)
    cells[bad] = shapely.make_valid(cells[bad])
    out = []
    for i in range(n):
        mine = cells[who == i]
        if len(mine) == 0:
            out.append(EMPTY)
            continue
        out.append(clean(shapely.intersection(shapely.union_all(mine, grid_size=_GRID), area)))
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
