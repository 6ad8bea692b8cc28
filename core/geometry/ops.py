"""Vectorized shapely 2 operations on extrusion moves: chains, bead footprints, region cleaning.

Extrusions arrive as rows of :data:`loadpath.gcode.MOVE_DTYPE`.  Consecutive rows whose ends meet are
joined into **chains** (polylines) with numpy, so a perimeter loop or a zigzag of rectilinear infill is
one shapely geometry, not hundreds; a chain whose two ends are closer than ``TOL.loop_close_rel`` bead
widths becomes a closed ring (PrusaSlicer clips the end of every loop by 0.15 x the nozzle diameter,
so loops are never closed exactly).  Chains whose width varies (Arachne) are buffered segment by
segment, each with its own width.  All buffers are one ``shapely.buffer`` call with per-geometry
distances.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from loadpath._typing import Bools, Floats, Ints, Region
from loadpath.areal import EMPTY, as_region, polygons_of
from loadpath.tolerances import TOL
from shapely.geometry import MultiPolygon, Polygon
from shapely.geometry.base import BaseGeometry

__all__ = [
    "Chains",
    "chains",
    "bead_union",
    "clean",
    "closing",
    "opening",
    "region_difference",
]

_MITRE_LIMIT = 2.0  # mitre joins keep the slicer's sharp corners; spikes sharper than ~60 deg are cut


@dataclass(frozen=True)
class Chains:
    """Extrusion rows joined into polylines.

    Attributes
    ----------
    chain : (n,) int64
        Chain number of every input row (rows of one chain are consecutive).
    start : (c + 1,) int64
        Row ranges ``start[k]:start[k+1]`` of chain ``k``.
    closed : (c,) bool
        The chain's ends meet within the loop-closing tolerance: a loop.
    uniform : (c,) bool
        One width along the whole chain (else it is buffered segment by segment).
    length : (c,) float, mm
    """

    chain: Ints
    start: Ints
    closed: Bools
    uniform: Bools
    length: Floats

    @property
    def count(self) -> int:
        """Number of chains."""
        return len(self.closed)


def chains(x0: Floats, y0: Floats, x1: Floats, y1: Floats, width: Floats,
           group: Ints | None = None, bridge: float = 0.0) -> Chains:
    """Join consecutive segments whose ends meet into chains.

    Parameters
    ----------
    x0, y0, x1, y1 : (n,) float, mm
        Segments in print order.
    width : (n,) float, mm
        Bead width of each segment (decides loop closing and uniformity).
    group : (n,) int, optional
        Segments of different groups (object, block, role) never join.
    bridge : float, mm
        Also join a segment to the next when the gap between them is at most this (the travel
        between two neighbouring infill lines), for footprints that are closed over that gap anyway.

    Returns
    -------
    Chains
    """
    n = len(x0)
    if n == 0:
        z = np.zeros(0, dtype=np.int64)
        return Chains(z, np.zeros(1, dtype=np.int64), np.zeros(0, bool), np.zeros(0, bool), np.zeros(0))
    brk = np.ones(n, dtype=bool)
    gap = np.hypot(x0[1:] - x1[:-1], y0[1:] - y1[:-1])
    # G-code prints 3 decimals: ends that print alike meet
    brk[1:] = gap > max(bridge, 1e-3 + 10 * TOL.length_mm)
    if group is not None:
        brk[1:] |= group[1:] != group[:-1]
    chain = np.cumsum(brk) - 1
    start = np.append(np.flatnonzero(brk), n)
    seg = np.hypot(x1 - x0, y1 - y0)
    length = np.add.reduceat(seg, start[:-1])
    first, last = start[:-1], start[1:] - 1
    wmax = np.maximum.reduceat(width, start[:-1])
    wmin = np.minimum.reduceat(width, start[:-1])
    uniform = (wmax - wmin) <= 0.02 * wmax
    end_gap = np.hypot(x0[first] - x1[last], y0[first] - y1[last])
    closed = (end_gap <= TOL.loop_close_rel * wmax) & (length > 4 * wmax) & (last - first >= 2)
    return Chains(chain, start, closed, uniform, length)


def _chain_geometries(x0: Floats, y0: Floats, x1: Floats, y1: Floats, ch: Chains, which: Bools) -> np.ndarray:
    """LineStrings (open chains) or LinearRings (closed chains) of the chains selected by ``which``.

    A row contributes its end point, and its start point too when that is not where the previous row
    ended (first row of a chain, or a bridged gap).
    """
    ks = np.flatnonzero(which)
    if len(ks) == 0:
        return np.zeros(0, dtype=object)
    first, stop = ch.start[ks], ch.start[ks + 1]
    counts = stop - first
    rows = np.repeat(first - np.cumsum(np.append(0, counts[:-1])), counts) + np.arange(counts.sum())
    chain_of_row = np.repeat(np.arange(len(ks)), counts)
    need_start = np.ones(len(rows), dtype=bool)
    cont = np.flatnonzero(rows[1:] == rows[:-1] + 1) + 1  # rows continuing the previous row of the list
    cont = cont[chain_of_row[cont] == chain_of_row[cont - 1]]
    prev = rows[cont] - 1
    need_start[cont] = np.hypot(x0[rows[cont]] - x1[prev], y0[rows[cont]] - y1[prev]) > 1e-9
    per_row = 1 + need_start
    end_pos = np.cumsum(per_row) - 1
    pts = np.zeros((int(per_row.sum()), 2))
    pts[end_pos] = np.column_stack([x1[rows], y1[rows]])
    pts[end_pos[need_start] - 1] = np.column_stack([x0[rows[need_start]], y0[rows[need_start]]])
    idx = np.repeat(chain_of_row, per_row)
    closed = ch.closed[ks]
    out = np.zeros(len(ks), dtype=object)
    if (~closed).any():
        m = ~closed[idx]
        out[~closed] = shapely.linestrings(pts[m], indices=np.searchsorted(np.flatnonzero(~closed), idx[m]))
    if closed.any():
        m = closed[idx]
        out[closed] = shapely.linearrings(pts[m], indices=np.searchsorted(np.flatnonzero(closed), idx[m]))
    return out


def bead_union(x0: Floats, y0: Floats, x1: Floats, y1: Floats, half: Floats, group: Ints | None = None,
               grow: float = 0.0, ch: Chains | None = None, bridge: float = 0.0) -> Region:
    """Union of the beads of extrusion segments: each centre line buffered by its half width (+ ``grow``).

    Uniform-width chains are buffered as polylines / rings with mitre joins (sharp corners as sliced);
    variable-width chains segment by segment with round caps.

    Parameters
    ----------
    x0, y0, x1, y1 : (n,) float, mm
    half : (n,) float, mm
        Half bead width of each segment.
    group : (n,) int, optional
        See :func:`chains`.
    grow : float, mm
        Added to every half width (a dilation, e.g. the first half of a morphological closing).
    ch : Chains, optional
        Precomputed :func:`chains` of the same rows.
    bridge : float, mm
        See :func:`chains`: gaps up to this are bridged (and buffered like beads).

    Returns
    -------
    Polygon or MultiPolygon
    """
    if len(x0) == 0:
        return EMPTY
    if ch is None:
        ch = chains(x0, y0, x1, y1, 2 * half, group, bridge)
    uni = ch.uniform
    geoms = []
    if uni.any():
        g = _chain_geometries(x0, y0, x1, y1, ch, uni)
        d = np.maximum.reduceat(half, ch.start[:-1])[uni] + grow
        geoms.append(shapely.buffer(g, d, quad_segs=4, join_style="mitre", mitre_limit=_MITRE_LIMIT))
    if (~uni).any():
        rows = np.flatnonzero(~uni[ch.chain])
        seg = shapely.linestrings(
            np.stack([np.column_stack([x0[rows], y0[rows]]), np.column_stack([x1[rows], y1[rows]])], axis=1))
        geoms.append(shapely.buffer(seg, half[rows] + grow, quad_segs=4))
    return as_region(shapely.union_all(np.concatenate(geoms)))


def closing(region: Region, r: float) -> Region:
    """Close morphologically (dilate, then erode by ``r`` mm): fill gaps and notches narrower than ``2 r``."""
    if r <= 0 or region.is_empty:
        return region
    return as_region(shapely.buffer(shapely.buffer(region, r, quad_segs=4, join_style="mitre",
                                                   mitre_limit=_MITRE_LIMIT), -r, quad_segs=4,
                                    join_style="mitre", mitre_limit=_MITRE_LIMIT))


def opening(region: Region, r: float) -> Region:
    """Open morphologically (erode, then dilate by ``r`` mm): drop slivers thinner than ``2 r``."""
    if r <= 0 or region.is_empty:
        return region
    return as_region(shapely.buffer(shapely.buffer(region, -r, quad_segs=4, join_style="mitre",
                                                   mitre_limit=_MITRE_LIMIT), r, quad_segs=4,
                                    join_style="mitre", mitre_limit=_MITRE_LIMIT))


def clean(region: BaseGeometry, sliver: float = TOL.snap_mm) -> Region:
    """Make a region valid, without slivers thinner than ``2 * sliver`` and without specks.

    Parameters
    ----------
    region : shapely geometry
    sliver : float, mm
        Opening radius.
    """
    region = as_region(shapely.make_valid(region) if not region.is_valid else region)
    region = opening(region, sliver)
    polys = [p for p in polygons_of(region) if p.area > (2 * sliver) ** 2]
    if not polys:
        return EMPTY
    return polys[0] if len(polys) == 1 else MultiPolygon(polys)


def region_difference(a: Region, b: Region) -> float:
    """Mean distance between two regions: ``area(a xor b) / perimeter``, mm (0 for equal regions).

    The perimeter is the larger of the two boundary lengths (at least ``TOL.length_mm``).  Two layers
    are the same region when this is below ``TOL.region_compare_mm``.
    """
    if a.is_empty and b.is_empty:
        return 0.0
    per = max(a.length, b.length, TOL.length_mm)
    return float(shapely.symmetric_difference(a, b).area / per)
