"""Voids next to path ends: windows around the ends less the beads and less the outside.

The gap fill (:mod:`.gaps`) needs the uncovered area near path ends.  :func:`find_voids` computes
it as one polygon clipping by Clipper (through ``pyclipper``) on integer coordinates of 2^-20 mm:
subject the windows (32-gons around the ends), clip the beads near the ends as ribbons
(:func:`ribbons`: one per run of segments, mitred joints, square ends) and the frame around the
windows less the region.  GEOS needs one overlay per ribbon for the same union: on the specimen
(337 ribbons, 4,000 vertices, 312 windows) its union and difference took ~40 ms and the chunked
ribbons of the earlier version ~100 ms; the Clipper sweep takes ~10 ms.  Clipper's result is the
same region to a nanometre (``tests/engines/swarm/test_gaps.py`` compares it with GEOS).
"""

from __future__ import annotations

import gc
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np
import pyclipper
import shapely
from loadpath._typing import Floats, Points2, Region
from scipy.spatial import cKDTree

__all__ = ["find_voids", "ribbons"]

_SCALE = float(2**20)
"""Clipper's integer units per mm (about 1 nm, far below the gap fill's 0.02-pitch tolerances); a
layer up to ~1 m across stays in Clipper's fast 30-bit range, a larger one uses its 62-bit range."""

_QUAD_SEGS = 8
"""Segments per quarter circle of a window (a 32-gon inscribed in the window's circle)."""


@contextmanager
def _gc_paused() -> Iterator[None]:
    """Pause Python's cyclic garbage collector while Clipper's integer lists are made and used.

    The windows and ribbons become ~15,000 short-lived lists (Clipper takes nested sequences); a
    collection they trigger scans the engine's whole heap (up to 65 ms measured on the specimen,
    against 2 ms for making the lists).  They hold no cycles and are freed on return.
    """
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


def _area2(ring: Points2) -> float:
    """Twice the signed area of a ring (positive counter-clockwise), mm² (or Clipper units²)."""
    x, y = ring[:, 0], ring[:, 1]
    return float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def _ints(ring: Points2, o: np.ndarray, ccw: bool | None = None) -> list:
    """Return a ring as a Clipper path (integer units of :data:`_SCALE` from ``o``).

    ``ccw`` True or False orients it counter-clockwise or clockwise; None keeps its orientation.
    """
    q = ring if ccw is None or (_area2(ring) >= 0) == ccw else ring[::-1]
    return np.round((q - o) * _SCALE).astype(np.int64).tolist()


def ribbons(pts: Points2, w: Floats, starts: np.ndarray, seg: np.ndarray) -> tuple[Points2, np.ndarray]:
    """Rings of the beads along the segments ``seg``: one ribbon per run of consecutive segments.

    A ribbon is the centre line offset by half the flow width on either side (mitred joints, square
    ends).  A ribbon that crosses itself (a bend tighter than half the width) is replaced by its
    valid pieces (``shapely.make_valid``), as the chunks of the earlier version were.

    Parameters
    ----------
    pts : (n, 2) float, mm
        All paths' points, path after path (path ``i`` starts at ``starts[i]``).
    w : (n,) float, mm
        Flow width at every point.
    starts : (p,) int, sorted
    seg : (s,) int, sorted
        Segments ``pts[seg] -> pts[seg + 1]`` to draw (never from the last point of a path).

    Returns
    -------
    coords : (m, 2) float, mm
        The rings one after another, without closing points: counter-clockwise around covered
        area (a clockwise ring is a hole in the ribbon before it).
    offsets : (r + 1,) int
        Ring ``i`` is ``coords[offsets[i]:offsets[i + 1]]``.
    """
    if not len(seg):
        return np.zeros((0, 2)), np.zeros(1, dtype=np.int64)
    cut = np.flatnonzero(np.diff(seg) != 1) + 1
    lo = seg[np.r_[0, cut]]
    nv = seg[np.r_[cut - 1, len(seg) - 1]] + 2 - lo  # vertices per run
    run = np.repeat(np.arange(len(lo)), nv)
    k = np.arange(nv.sum()) - np.repeat(np.cumsum(nv) - nv, nv)  # vertex index within its run
    vid = lo[run] + k
    # central-difference tangents (one-sided at path ends), of the drawn vertices only
    path_of = np.searchsorted(starts, vid, side="right") - 1
    last = np.append(starts[1:], len(pts)) - 1
    nxt = np.where(vid == last[path_of], vid, vid + 1)
    prv = np.where(vid == starts[path_of], vid, vid - 1)
    tan = pts[nxt] - pts[prv]
    norm = np.hypot(tan[:, 0], tan[:, 1])
    off = (0.5 * w[vid] / np.where(norm > 0, norm, 1.0))[:, None] * np.stack([-tan[:, 1], tan[:, 0]], axis=1)
    # right side forward, left side back: counter-clockwise unless the ribbon crosses itself
    offsets = np.r_[0, np.cumsum(2 * nv)]
    coords = np.empty((2 * len(vid), 2))
    coords[offsets[run] + k] = pts[vid] - off
    coords[offsets[run] + 2 * nv[run] - 1 - k] = pts[vid] + off
    polys = shapely.polygons(shapely.linearrings(coords, indices=np.repeat(np.arange(len(nv)), 2 * nv)))
    bad = np.flatnonzero(~shapely.is_valid(polys))
    if not len(bad):
        return coords, offsets
    keep = np.ones(len(coords), dtype=bool)
    keep[np.concatenate([np.arange(offsets[i], offsets[i + 1]) for i in bad])] = False
    rings = [coords[keep]]
    sizes = np.delete(2 * nv, bad).tolist()
    for g in shapely.get_parts(shapely.make_valid(polys[bad])):
        if shapely.get_type_id(g) == 3:  # polygons (the collapsed bits are lines)
            g = shapely.orient_polygons(g)
            for r in [g.exterior, *g.interiors]:
                rings.append(np.asarray(r.coords)[:-1])
                sizes.append(len(rings[-1]))
    return np.concatenate(rings), np.r_[0, np.cumsum(sizes)]


def find_voids(
    ends: Points2, radius: float, region: Region, ribbons: tuple[Points2, np.ndarray], min_area: float
) -> list:
    """Return the windows around the path ends less the ribbons and less all outside the region.

    One Clipper difference: subject the windows (non-zero fill), clip the ribbons and the frame
    around the windows less the region (covered where the winding number is positive).

    Parameters
    ----------
    ends : (e, 2) float, mm
    radius : float, mm
        Window radius (a 32-gon inscribed in the circle, the same as ``shapely.buffer`` draws).
    region : Polygon or MultiPolygon, mm
    ribbons : ((m, 2) float, (r + 1,) int)
        Ribbon rings (mm) and their offsets (:func:`ribbons`), oriented.
    min_area : float, mm²
        Voids of smaller area are dropped.

    Returns
    -------
    list of Polygon, mm
        The voids of at least ``min_area``, in Clipper's (deterministic) output order.
    """
    disc = shapely.get_coordinates(shapely.buffer(shapely.Point(0.0, 0.0), radius, quad_segs=_QUAD_SEGS))[:-1]
    if _area2(disc) < 0:
        disc = disc[::-1]
    ends = np.unique(ends, axis=0)
    # Clipper sweeps a horizontal line upward, and its cost grows with the edges the line meets:
    # where the ends stand side by side along x (a seam across the sweep), the layer is turned by
    # a quarter (exact: a swap and a sign) so that they line up along the sweep (bracket: 2x faster)
    turn = False
    if len(ends) > 1:
        _, j = cKDTree(ends).query(ends, k=2)
        step = np.abs(ends[j[:, 1]] - ends)
        turn = bool(np.median(step[:, 0]) > np.median(step[:, 1]))
    fwd = (lambda xy: np.stack([xy[..., 1], -xy[..., 0]], axis=-1)) if turn else (lambda xy: xy)
    ends = fwd(ends)
    o = ends.min(axis=0) - radius
    lo, hi = o - radius, ends.max(axis=0) + 2.0 * radius
    frame = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])
    # a window's vertex that lies, with both its neighbours, in the nearest other window bounds no
    # part of the union: dropping it cuts off a triangle of that (convex) window, so the union is
    # the same, edge for edge, and Clipper has a third fewer vertices to sweep
    verts = ends[:, None, :] + disc[None]
    drop = np.zeros(verts.shape[:2], dtype=bool)
    if len(ends) > 1:
        gap = verts - ends[j[:, 1]][:, None, :]
        inside = np.hypot(gap[..., 0], gap[..., 1]) < radius * np.cos(np.pi / len(disc)) * (1.0 - 1e-9)
        drop = inside & np.roll(inside, 1, axis=1) & np.roll(inside, -1, axis=1)
    kept = np.cumsum(np.r_[0, (~drop).sum(axis=1)]).tolist()
    coords, offsets = ribbons
    with _gc_paused():
        c = pyclipper.Pyclipper()
        flat = np.round((verts[~drop] - o) * _SCALE).astype(np.int64).tolist()
        c.AddPaths([flat[i:j] for i, j in zip(kept[:-1], kept[1:], strict=True)], pyclipper.PT_SUBJECT, True)
        # winding 1 outside the region inside a frame around the windows, 0 inside the region
        clip = [_ints(frame, o, True)]
        for poly in shapely.get_parts(region):
            clip.append(_ints(fwd(np.asarray(poly.exterior.coords)[:-1]), o, False))
            clip += [_ints(fwd(np.asarray(h.coords)[:-1]), o, True) for h in poly.interiors]
        flat = np.round((fwd(coords) - o) * _SCALE).astype(np.int64).tolist()
        clip += [flat[i:j] for i, j in zip(offsets[:-1].tolist(), offsets[1:].tolist(), strict=True)]
        c.AddPaths(clip, pyclipper.PT_CLIP, True)
        del clip, flat
        tree = c.Execute2(pyclipper.CT_DIFFERENCE, pyclipper.PFT_NONZERO, pyclipper.PFT_POSITIVE)
        out = []
        stack = list(tree.Childs)[::-1]
        while stack:
            node = stack.pop()
            holes = node.Childs
            area = abs(pyclipper.Area(node.Contour)) - sum(abs(pyclipper.Area(h.Contour)) for h in holes)
            if area >= min_area * _SCALE**2:
                rings = [np.asarray(r.Contour) / _SCALE + o for r in [node, *holes]]
                if turn:  # back: (u, v) -> (-v, u)
                    rings = [np.stack([-r[:, 1], r[:, 0]], axis=1) for r in rings]
                out.append(shapely.Polygon(rings[0], rings[1:]))
            for h in holes[::-1]:
                stack.extend(list(h.Childs)[::-1])
        del tree, stack
    # Clipper may return a ring that touches itself at a vertex where GEOS returns two polygons
    pieces = np.array(out, dtype=object)
    bad = ~shapely.is_valid(pieces)
    if bad.any():
        parts = shapely.get_parts(shapely.make_valid(pieces[bad]))
        parts = parts[(shapely.get_type_id(parts) == 3) & (shapely.area(parts) >= min_area)]
        pieces = np.concatenate([pieces[~bad], parts])
    return list(pieces)
