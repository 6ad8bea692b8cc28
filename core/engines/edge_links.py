"""The pieces of a region's edge that boundary links follow, many at once.

A boundary link (:mod:`loadpath.engines.linking`) joins two path ends near the edge of the replace
region by the piece of the edge between them, taken at the ends' own inset: the region shrunk by
the inset, the ring nearest the first end, from one end's projection onto it to the other's, the
shorter way round.  A layer has a thousand or more such candidates (each pair of ends near the edge,
both ways); one by one, each cost a dozen small shapely calls (issue 17: a sparse layer asked for
15,000).  Here all the candidates of one inset are made together: the ends' distances and
projections in one shapely call each, the pieces' ends interpolated in one, the ring vertices
between them found by their running lengths (:func:`ring_pieces`).

The points are exactly those of the one-by-one construction with ``shapely.ops.substring``
(``tests/engines/test_linking.py``): the same shapely calls give the ends, the vertices between
are chosen by the same comparisons on the same running lengths, and the arithmetic on the arc
lengths is the same float operations in numpy as it was in Python.

The shrunk rings depend only on the region and the inset: they are kept across layers
(:func:`shrunk_rings`; a part's layers mostly share their region, and the staggered copies and
principal directions link the same region again).
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass

import numpy as np
import shapely
from loadpath._typing import Points2, Region

__all__ = ["Rings", "shrunk_rings", "ring_pieces", "substrings"]


@dataclass(frozen=True)
class Rings:
    """The edge of a region shrunk by one inset.

    Attributes
    ----------
    rings : (r,) object array of LineString / LinearRing
        The rings of the shrunk region's boundary (none when the inset leaves nothing).
    closed : (r,) bool
    total : (r,) float, mm
        Each ring's length (shapely's).
    xy : (v, 2) float, mm
        Every ring's vertices, ring after ring ...
    run : (v,) float, mm
        ... their running length along their ring, summed one segment at a time as
        ``shapely.ops.substring`` does;
    first : (r + 1,) int
        where each ring's vertices start in ``xy`` (and where the last ends).
    """

    rings: np.ndarray
    closed: np.ndarray
    total: np.ndarray
    xy: np.ndarray
    run: np.ndarray
    first: np.ndarray

    @classmethod
    def of(cls, region: Region, inset: float) -> Rings:
        """``region``'s edge shrunk by ``inset`` mm (``quad_segs = 4``; the region itself at 0)."""
        inner = region.buffer(-inset, quad_segs=4) if inset > 1e-6 else region
        rings = shapely.get_parts(shapely.get_parts(shapely.boundary(inner))) if not inner.is_empty else []
        rings = np.asarray(rings, dtype=object)
        xy = [shapely.get_coordinates(r) for r in rings]
        run = []
        for c in (x.tolist() for x in xy):  # one by one, with substring's own arithmetic
            acc = [0.0]
            for (x1, y1), (x2, y2) in zip(c[:-1], c[1:], strict=True):
                acc.append(acc[-1] + ((x2 - x1) ** 2 + (y2 - y1) ** 2) ** 0.5)
            run.append(np.array(acc))
        return cls(
            rings,
            shapely.is_closed(rings) if len(rings) else np.zeros(0, dtype=bool),
            shapely.length(rings) if len(rings) else np.zeros(0),
            np.concatenate(xy) if xy else np.zeros((0, 2)),
            np.concatenate(run) if run else np.zeros(0),
            np.concatenate([[0], np.cumsum([len(x) for x in xy])]).astype(np.int64),
        )

    @classmethod
    def concat(cls, parts: list[Rings]) -> tuple[Rings, np.ndarray]:
        """The rings of several insets as one; returns it and where each part's rings start in it
        (len(parts) + 1,) int."""
        n_ring = np.array([len(p.rings) for p in parts], dtype=np.int64)
        n_vert = np.array([len(p.xy) for p in parts], dtype=np.int64)
        shift = np.concatenate([[0], np.cumsum(n_vert)[:-1]])
        empty = np.zeros(0, dtype=object)
        return cls(
            np.concatenate([p.rings for p in parts] + [empty]),
            np.concatenate([p.closed for p in parts] + [np.zeros(0, dtype=bool)]),
            np.concatenate([p.total for p in parts] + [np.zeros(0)]),
            np.concatenate([p.xy for p in parts] + [np.zeros((0, 2))]),
            np.concatenate([p.run for p in parts] + [np.zeros(0)]),
            np.concatenate([p.first[:-1] + d for p, d in zip(parts, shift, strict=True)] + [[n_vert.sum()]]),
        ), np.concatenate([[0], np.cumsum(n_ring)])


_RINGS: OrderedDict[tuple[bytes, float], Rings] = OrderedDict()
_RINGS_KEPT = 256
"""Shrunk rings kept across layers (:func:`shrunk_rings`), the least recently used dropped first:
a region's ~50 insets (every 0.01 mm up to the edge reach) for a few regions."""


def shrunk_rings(region: Region, inset: float, key: bytes | None = None) -> Rings:
    """:meth:`Rings.of` ``(region, inset)``, kept across calls under the region's WKB (``key``, made
    here when not given) and the inset."""
    k = (shapely.to_wkb(region) if key is None else key, inset)
    got = _RINGS.get(k)
    if got is None:
        got = _RINGS[k] = Rings.of(region, inset)
        if len(_RINGS) > _RINGS_KEPT:
            _RINGS.popitem(last=False)
    else:
        _RINGS.move_to_end(k)
    return got


def _ranges(start: np.ndarray, count: np.ndarray, step: np.ndarray) -> np.ndarray:
    """``start[i] + step[i] * arange(count[i])`` for every ``i``, back to back (int)."""
    rep = np.repeat(np.arange(len(count)), count)
    k = np.arange(len(rep)) - np.repeat(np.cumsum(count) - count, count)
    return start[rep] + step[rep] * k


def _gather(
    pool: Points2, start: np.ndarray, count: np.ndarray, step: np.ndarray
) -> tuple[Points2, np.ndarray]:
    """Pieces made of blocks of ``pool``: row ``i`` of ``start``, ``count``, ``step`` (c, blocks) int
    lists piece ``i``'s blocks in order, each ``count`` points from ``start`` by ``step``.

    Returns the points (m, 2), piece after piece, and where each piece starts (c + 1,) int.
    """
    flat = _ranges(start.ravel(), count.ravel(), step.ravel())
    return pool[flat], np.concatenate([[0], np.cumsum(count.sum(axis=1))])


@dataclass(frozen=True)
class _Parts:
    """Substrings of rings as blocks (:func:`_parts`), c of them.

    Attributes
    ----------
    lo, hi : (c, 2) float, mm
        The interpolated first and last point;
    start, count : (c,) int
        the ring vertices between them, ``Rings.xy[start : start + count]``;
    has_hi : (c,) int
        1 when the last point belongs to the piece (0: the piece is its first point alone).
    """

    lo: Points2
    hi: Points2
    start: np.ndarray
    count: np.ndarray
    has_hi: np.ndarray


def _parts(
    rg: Rings, k: np.ndarray, lo: np.ndarray, hi: np.ndarray, used: np.ndarray | None = None
) -> _Parts:
    """``shapely.ops.substring(rg.rings[k[i]], lo[i], hi[i])`` for every ``i`` (``lo <= hi``, mm),
    as blocks: its ends interpolated by shapely, the ring's vertices (all but its last) whose
    running length lies strictly between ``lo`` and ``hi``; only the first end when they are equal.
    The ends are interpolated only where ``used`` (c,) bool (default: all; zeros elsewhere)."""
    ring = rg.rings[k]
    p_lo, p_hi = np.zeros((len(k), 2)), np.zeros((len(k), 2))
    u = slice(None) if used is None else used
    p_lo[u] = shapely.get_coordinates(shapely.line_interpolate_point(ring[u], lo[u]))
    p_hi[u] = shapely.get_coordinates(shapely.line_interpolate_point(ring[u], hi[u]))
    start = np.zeros(len(k), dtype=np.int64)
    count = np.zeros(len(k), dtype=np.int64)
    for r in np.unique(k):
        at = np.flatnonzero(k == r)
        inner = rg.run[rg.first[r] : rg.first[r + 1] - 1]  # nondecreasing: those vertices are a range
        i0 = np.searchsorted(inner, lo[at], side="right")
        i1 = np.searchsorted(inner, hi[at], side="left")
        start[at] = rg.first[r] + i0
        count[at] = np.maximum(i1 - i0, 0)
    return _Parts(p_lo, p_hi, start, count, (lo != hi).astype(np.int64))


def substrings(rg: Rings, k: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> tuple[Points2, np.ndarray]:
    """The vertices of ``shapely.ops.substring(rg.rings[k[i]], lo[i], hi[i])`` for every ``i``
    (``lo <= hi``, mm; :func:`_parts`).

    Returns the points (m, 2), piece after piece, and where each starts (c + 1,) int.
    """
    c = len(k)
    p = _parts(rg, k, np.asarray(lo, dtype=float), np.asarray(hi, dtype=float))
    pool = np.concatenate([p.lo, p.hi, rg.xy])
    i = np.arange(c)
    one = np.ones(c, dtype=np.int64)
    start = np.stack([i, 2 * c + p.start, c + i], axis=1)
    count = np.stack([one, p.count, p.has_hi], axis=1)
    return _gather(pool, start, count, np.ones_like(start))


def _nearest_ring(
    rg: Rings, groups: np.ndarray, g: np.ndarray, pts: Points2, ea: np.ndarray, eb: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """For each ``i``: the ring of group ``g[i]`` (``rg.rings[groups[g] : groups[g + 1]]``)
    nearest ``pts[ea[i]]`` (the first of equals, as ``np.argmin``), and both ends' distances to it.

    Each end's distances to its group's rings are measured once.  Returns the ring (c,) int (into
    ``rg``), ``da``, ``db`` (c,) float mm, and whether the group has a ring at all (c,) bool.
    """
    c = len(ea)
    n_g = len(groups) - 1
    combo, inv = np.unique(np.concatenate([ea, eb]) * n_g + np.concatenate([g, g]), return_inverse=True)
    end_u, g_u = combo // n_g, combo % n_g
    n_r = groups[g_u + 1] - groups[g_u]
    pair_ring = _ranges(groups[g_u], n_r, np.ones(len(combo), dtype=np.int64))
    pair_u = np.repeat(np.arange(len(combo)), n_r)
    if not len(pair_ring):
        return np.zeros(c, dtype=np.int64), np.full(c, np.inf), np.full(c, np.inf), np.zeros(c, dtype=bool)
    d = shapely.distance(rg.rings[pair_ring], shapely.points(pts[end_u])[pair_u])
    seg = np.cumsum(n_r) - n_r  # where each end's distances start in ``d``
    has = n_r > 0
    low = np.full(len(combo), np.inf)
    low[has] = np.minimum.reduceat(d, seg[has])
    at_min = np.flatnonzero(d == low[pair_u])
    _, first = np.unique(pair_u[at_min], return_index=True)
    nearest = np.zeros(len(combo), dtype=np.int64)
    nearest[has] = pair_ring[at_min[first]]
    ua, ub = inv[:c], inv[c:]
    k = nearest[ua]
    ok = has[ua]
    da = low[ua]
    db = np.where(ok, d[np.where(ok, seg[ub] + k - groups[g], 0)], np.inf)
    return k, da, db, ok


def _projections(
    rg: Rings, k: np.ndarray, pts: Points2, ea: np.ndarray, eb: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """How far along ring ``k[i]`` the points ``pts[ea[i]]`` and ``pts[eb[i]]`` project (mm, (c,)
    each; shapely's ``project``), each end onto each ring once."""
    c = len(k)
    n_r = len(rg.rings)
    pair, inv = np.unique(np.concatenate([ea, eb]) * n_r + np.concatenate([k, k]), return_inverse=True)
    along = shapely.line_locate_point(rg.rings[pair % n_r], shapely.points(pts[pair // n_r]))
    return along[inv[:c]], along[inv[c:]]


def ring_pieces(
    rg: Rings, groups: np.ndarray, g: np.ndarray, e_pt: Points2, ea: np.ndarray, eb: np.ndarray, limit: float
) -> tuple[Points2, np.ndarray, np.ndarray]:
    """Boundary links from end ``ea[i]`` to ``eb[i]`` (indices into ``e_pt``, (c,) int each) on the
    rings of group ``g[i]`` (one inset's rings: ``rg.rings[groups[g] : groups[g + 1]]``,
    :meth:`Rings.concat`): the ring nearest ``ea[i]``, from its projection to ``eb[i]``'s the
    shorter way.

    A link exists when both ends lie within ``limit / 2`` mm of that ring and the piece between
    their projections is at most ``limit`` mm long.  Its points are its first end, the piece (the
    ring's substring, reversed when it runs the other way; round the ring's start: the substring to
    its end, then the one from its start without its first point), its last end, each point
    dropped that lies within 1e-6 mm of the one before; a link of fewer than two points does not
    exist.

    Returns the points (m, 2), link after link (an empty slice for a link that does not exist),
    where each starts (c + 1,) int, and which exist (c,) bool.
    """
    c = len(ea)
    if not len(rg.rings) or not c:
        return np.zeros((0, 2)), np.zeros(c + 1, dtype=np.int64), np.zeros(c, dtype=bool)
    k, da, db, ok = _nearest_ring(rg, groups, g, e_pt, ea, eb)
    ok &= ~((da > 0.5 * limit) | (db > 0.5 * limit))
    sel = np.flatnonzero(ok)
    k, ea_s, eb_s = k[sel], ea[sel], eb[sel]
    sa, sb = _projections(rg, k, e_pt, ea_s, eb_s)
    total, closed = rg.total[k], rg.closed[k]
    # a closed ring: the shorter way round, maybe across its start; an open one: between the two
    with np.errstate(invalid="ignore", divide="ignore"):
        fwd = np.mod(sb - sa, total)
    back = total - fwd
    way = fwd <= back
    first = np.where(closed, np.where(way, sa, sb), np.minimum(sa, sb))
    end = np.where(closed, first + np.where(way, fwd, back), np.maximum(sa, sb))
    flip = np.where(closed, ~way, sa > sb)
    fits = np.where(closed, ~(np.minimum(fwd, back) > limit), ~(end - first > limit))
    sel, k, first, end, total, flip = sel[fits], k[fits], first[fits], end[fits], total[fits], flip[fits]
    wrap = closed[fits] & (end > total)
    pts, at, n = _assemble(rg, k, first, end, total, wrap, flip, e_pt[ea[sel]], e_pt[eb[sel]])
    exists = np.zeros(c, dtype=bool)
    exists[sel] = n >= 2
    counts = np.zeros(c, dtype=np.int64)
    counts[sel] = np.where(n >= 2, n, 0)
    return pts, np.concatenate([[0], np.cumsum(counts)]), exists


def _assemble(
    rg: Rings, k, first, end, total, wrap, flip, pa: Points2, pb: Points2
) -> tuple[Points2, np.ndarray, np.ndarray]:
    """The points of :func:`ring_pieces`'s links that fit, s of them: ``pa``, the piece of ring
    ``k`` from ``first`` to ``end`` mm (past ``total`` when it ``wrap`` s round the ring's start),
    reversed where ``flip``, ``pb``; each point within 1e-6 mm of the one before dropped.

    Returns the points of the links of at least two points (m, 2), where each link starts in the
    points before the drop (s + 1,) int, and how many points each keeps (s,) int.
    """
    s = len(k)
    one = wrap.astype(np.int64)
    p1 = _parts(rg, k, first, np.where(wrap, total, end))
    p2 = _parts(rg, k, np.zeros(s), np.where(wrap, end - total, 0.0), wrap)  # its first point dropped
    i = np.arange(s)
    pool = np.concatenate([pa, p1.lo, p1.hi, p2.hi, pb, rg.xy])
    ones = np.ones(s, dtype=np.int64)
    # the link's blocks in order: first end, substring to the ring's end, the one from its start, last end
    blocks = [
        (i, ones),
        (s + i, ones),
        (5 * s + p1.start, p1.count),
        (2 * s + i, p1.has_hi),
        (5 * s + p2.start, p2.count * one),
        (3 * s + i, p2.has_hi * one),
        (4 * s + i, ones),
    ]
    start = np.stack([b[0] for b in blocks], axis=1)
    count = np.stack([b[1] for b in blocks], axis=1)
    step = np.ones_like(start)
    # reversed pieces: the inner five blocks in reverse order, each read backwards
    f = np.flatnonzero(flip)
    start[f, 1:6] = (start[f, 1:6] + np.maximum(count[f, 1:6] - 1, 0))[:, ::-1]
    count[f, 1:6] = count[f, 1:6][:, ::-1]
    step[f, 1:6] = -1
    pts, at = _gather(pool, start, count, step)
    keep = np.ones(len(pts), dtype=bool)
    keep[1:] = np.hypot(*np.diff(pts, axis=0).T) > 1e-6
    keep[at[:-1]] = True  # never a link's first point
    n = np.add.reduceat(keep.astype(np.int64), at[:-1]) if s else np.zeros(0, dtype=np.int64)
    keep &= np.repeat(n >= 2, np.diff(at))
    return pts[keep], at, n
