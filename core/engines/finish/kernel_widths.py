"""Compiled kernels of the layer's finishing widths (:mod:`.widths`): normal rays and centring rounds.

Both search the paths' segments (or points) through a uniform cell grid, :func:`cell_lists`
(every item listed in each cell it passes through, cells widened by a hair, as
:func:`.kernel_geom.cell_grid` lists the boundary), so a search visits only the cells its query
can reach and the exact test decides:

* :func:`normal_hits`: for each point, the first segment of another path crossed by the normal
  line within ``reach`` on either side.  The cells visited are those the chord
  ``p - reach n .. p + reach n`` passes through (column by column, as :func:`cell_lists` lists
  a long segment), so every segment crossing the chord is found, however many segments lie
  nearer the point.
* :func:`settle_moves`: the rounds of :func:`.widths.centre_points`, each checking only the
  (vertex, segment) pairs whose distance can have changed since the last round.

The grids are built on the points as laid; the centring moves each point by at most ``max |move|``
along its normal, so its searches widen their boxes by that much.  :func:`tangents` gives both
the paths' unit tangents; :func:`cell_lists` is also used by :mod:`.ends`.
"""

from __future__ import annotations

import numpy as np
from loadpath.engines.finish import kernel_geom as kg
from loadpath.engines.finish._numba import njit

__all__ = ["tangents", "cell_lists", "normal_hits", "settle_moves"]


@njit
def tangents(points: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """Return the unit tangent at every point of ragged paths (central differences, one-sided at ends).

    Parameters
    ----------
    points : (n, 2) float, mm
        The paths one after the other.
    ends : (p,) int
        One past the last point of each path (increasing, the last one ``n``).

    Returns
    -------
    (n, 2) float
        Zero where the differences vanish (a path of one point, repeated points).
    """
    t = np.zeros_like(points)
    lo = 0
    for hi in ends:
        for i in range(lo, hi):
            nx_ = points[min(i + 1, hi - 1), 0] - points[max(i - 1, lo), 0]
            ny_ = points[min(i + 1, hi - 1), 1] - points[max(i - 1, lo), 1]
            norm = np.sqrt(nx_ * nx_ + ny_ * ny_)
            if norm > 0.0:
                t[i, 0] = nx_ / norm
                t[i, 1] = ny_ / norm
        lo = hi
    return t


_BOX_CELLS = 9
"""An item whose box covers at most this many cells is listed in all of them (the paths' segments,
about a cell long: listing the box is several times faster than tracing the cells crossed, and
lists about 5 % more); a longer one only in the cells it passes through."""


@njit
def cell_lists(
    pts: np.ndarray, seg: np.ndarray, lone: np.ndarray, origin: np.ndarray, cell: float, nx: int, ny: int
) -> tuple[np.ndarray, np.ndarray]:
    """List the paths' segments (and lone points) per cell of a grid.

    Each item is listed in every cell it passes through, a short one (its box at most
    ``_BOX_CELLS`` cells) in every cell of its box.

    Parameters
    ----------
    pts : (n, 2) float, mm
    seg : (s,) int
        Item ``k < s`` is the segment from ``pts[seg[k]]`` to ``pts[seg[k] + 1]``.
    lone : (l,) int
        Item ``s + m`` is the point ``pts[lone[m]]`` (paths of one point).
    origin : (2,) float, mm; cell : float, mm; nx, ny : int
        The grid: cell ``(i, j)`` spans ``origin + [i, i + 1] x [j, j + 1] cell`` (widened by a
        hair), flat index ``i ny + j``; every item lies inside it.

    Returns
    -------
    start : (nx ny + 1,) int32
    items : (start[-1],) int32
        Cell ``c`` lists the items ``items[start[c]:start[c + 1]]``, in increasing order.
    """
    ns = seg.shape[0]
    n_items = ns + lone.shape[0]
    ncell = nx * ny
    buf = np.empty(2 * (nx + ny) + 4, dtype=np.int64)
    # counting sort without a second array the size of the grid (large fresh arrays cost page
    # faults): ``start[c]`` first counts cell c and its predecessors, then, filled from the last
    # item down, falls to the first slot of cell c
    start = np.zeros(ncell + 1, dtype=np.int32)
    for fill in range(2):
        if fill:
            for c in range(1, ncell):
                start[c] += start[c - 1]
            start[ncell] = start[ncell - 1] if ncell else 0
            items = np.empty(start[ncell], dtype=np.int32)
        else:
            items = np.empty(0, dtype=np.int32)
        for kk in range(n_items):
            k = n_items - 1 - kk if fill else kk
            a = seg[k] if k < ns else lone[k - ns]
            b = a + 1 if k < ns else a
            ax, ay, bx, by = pts[a, 0], pts[a, 1], pts[b, 0], pts[b, 1]
            i0, i1 = kg._cell_span(ax, bx, origin[0], cell, nx)
            j0, j1 = kg._cell_span(ay, by, origin[1], cell, ny)
            if (i1 - i0 + 1) * (j1 - j0 + 1) <= _BOX_CELLS:
                for i in range(i0, i1 + 1):
                    for j in range(j0, j1 + 1):
                        c = i * ny + j
                        if fill:
                            start[c] -= 1
                            items[start[c]] = k
                        else:
                            start[c] += 1
            else:
                for m in range(kg._segment_cells(ax, ay, bx, by, origin, cell, nx, ny, buf)):
                    c = buf[m]
                    if fill:
                        start[c] -= 1
                        items[start[c]] = k
                    else:
                        start[c] += 1
    return start, items


@njit
def normal_hits(
    pts: np.ndarray,
    tan: np.ndarray,
    pid: np.ndarray,
    rows: np.ndarray,
    seg: np.ndarray,
    origin: np.ndarray,
    cell: float,
    nx: int,
    ny: int,
    start: np.ndarray,
    items: np.ndarray,
    reach: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Return the distance along the left and the right normal to the first segment of another path.

    The point's frame has ``u`` along the unit tangent ``t`` and ``v`` along the left normal
    ``(-t_y, t_x)``; the normal line ``u = 0`` crosses a segment whose ends lie on both sides of it
    (``u_a u_b <= 0``, ``u_a != u_b``) at ``v = v_a + (v_b - v_a) u_a / (u_a - u_b)``.

    Parameters
    ----------
    pts : (n, 2) float, mm
    tan : (n, 2) float
        Unit tangent per point (zero: no normal, no hit).
    pid : (n,) int
        Path of each point (its own path's segments are not hits).
    rows : (m,) int
        The points to measure.
    seg : (s,) int
        Segment ``k`` runs from ``pts[seg[k]]`` to ``pts[seg[k] + 1]``.
    origin : (2,) float, mm; cell : float, mm; nx, ny : int
        The cell grid; ``start`` (nx ny + 1,) int and ``items`` int list the segments per cell
        (flat cell index ``i ny + j``; :func:`cell_lists` without lone points).
    reach : float, mm
        Hits farther than this are not hits.

    Returns
    -------
    left, right : (m,) float, mm
        ``v`` of the nearest hit with ``0 < v <= reach`` and ``-v`` of the nearest with
        ``-reach <= v < 0``; ``inf`` where none.
    """
    m = rows.shape[0]
    left = np.full(m, np.inf)
    right = np.full(m, np.inf)
    buf = np.empty(2 * (nx + ny) + 4, dtype=np.int64)  # cells of one chord (kernel_geom._segment_cells)
    for r in range(m):
        i = rows[r]
        px, py = pts[i, 0], pts[i, 1]
        tx, ty = tan[i, 0], tan[i, 1]
        own = pid[i]
        # the chord p -/+ reach n, n = (-ty, tx)
        ax, ay = px + reach * ty, py - reach * tx
        bx, by = px - reach * ty, py + reach * tx
        best_l = np.inf
        best_r = np.inf
        for mm in range(kg._segment_cells(ax, ay, bx, by, origin, cell, nx, ny, buf)):
            c = buf[mm]
            for k in range(start[c], start[c + 1]):
                s = seg[items[k]]
                if pid[s] == own:
                    continue
                sax, say = pts[s, 0] - px, pts[s, 1] - py
                sbx, sby = pts[s + 1, 0] - px, pts[s + 1, 1] - py
                ua = sax * tx + say * ty
                ub = sbx * tx + sby * ty
                if not (ua * ub <= 0.0 and ua != ub):
                    continue
                va = say * tx - sax * ty
                vb = sby * tx - sbx * ty
                v = va + (vb - va) * (ua / (ua - ub))
                if v > 0.0:
                    if v <= reach and v < best_l:
                        best_l = v
                elif v < 0.0:
                    if -v <= reach and -v < best_r:
                        best_r = -v
        left[r] = best_l
        right[r] = best_r
    return left, right


@njit
def _point_segment(px: float, py: float, ax: float, ay: float, bx: float, by: float) -> float:
    """Return the distance from ``p`` to the segment ``a b`` (mm)."""
    ex, ey = bx - ax, by - ay
    ll = ex * ex + ey * ey
    t = 0.0
    if ll > 0.0:
        t = min(max(((px - ax) * ex + (py - ay) * ey) / ll, 0.0), 1.0)
    return np.hypot(px - (ax + t * ex), py - (ay + t * ey))


@njit
def _mark(w: int, move: np.ndarray, mark: np.ndarray, back: np.ndarray, nback: int, stamp: int) -> int:
    """Add point ``w`` to ``back[:nback]`` if it moved and is not there yet; returns the new count."""
    if move[w] != 0.0 and mark[w] != stamp:
        mark[w] = stamp
        back[nback] = w
        nback += 1
    return nback


@njit
def _check_pair(
    v: int,
    k: int,
    q: np.ndarray,
    seg: np.ndarray,
    pid: np.ndarray,
    move: np.ndarray,
    min_gap: float,
    mark: np.ndarray,
    back: np.ndarray,
    nback: int,
    stamp: int,
) -> int:
    """Mark the moved ends of the pair (vertex ``v``, segment ``k``) if they are closer than ``min_gap``."""
    s = seg[k]
    if pid[v] == pid[s]:
        return nback
    if move[v] == 0.0 and move[s] == 0.0 and move[s + 1] == 0.0:
        return nback
    if _point_segment(q[v, 0], q[v, 1], q[s, 0], q[s, 1], q[s + 1, 0], q[s + 1, 1]) >= min_gap:
        return nback
    nback = _mark(v, move, mark, back, nback, stamp)
    nback = _mark(s, move, mark, back, nback, stamp)
    return _mark(s + 1, move, mark, back, nback, stamp)


@njit
def _pairs_of_point(
    v: int,
    q: np.ndarray,
    seg: np.ndarray,
    pid: np.ndarray,
    move: np.ndarray,
    min_gap: float,
    radius: float,
    grid: tuple,
    mark: np.ndarray,
    back: np.ndarray,
    nback: int,
    stamp: int,
) -> int:
    """Check point ``v`` against the segments listed in the cells within ``radius`` of it."""
    origin, cell, nx, ny, start, items = grid
    ns = seg.shape[0]
    i0, i1 = kg._cell_span(q[v, 0] - radius, q[v, 0] + radius, origin[0], cell, nx)
    j0, j1 = kg._cell_span(q[v, 1] - radius, q[v, 1] + radius, origin[1], cell, ny)
    for ci in range(i0, i1 + 1):
        for c in range(ci * ny + j0, ci * ny + j1 + 1):
            for m in range(start[c], start[c + 1]):
                if items[m] < ns:
                    nback = _check_pair(
                        v, np.int64(items[m]), q, seg, pid, move, min_gap, mark, back, nback, stamp
                    )
    return nback


@njit
def _pairs_of_segment(
    k: int,
    q: np.ndarray,
    seg: np.ndarray,
    lone: np.ndarray,
    pid: np.ndarray,
    move: np.ndarray,
    min_gap: float,
    radius: float,
    grid: tuple,
    mark: np.ndarray,
    back: np.ndarray,
    nback: int,
    stamp: int,
) -> int:
    """Check segment ``k`` against the points in the cells within ``radius`` of its box.

    The points are the ends of the segments listed there and the lone points.
    """
    origin, cell, nx, ny, start, items = grid
    ns = seg.shape[0]
    a = seg[k]
    i0, i1 = kg._cell_span(
        min(q[a, 0], q[a + 1, 0]) - radius, max(q[a, 0], q[a + 1, 0]) + radius, origin[0], cell, nx
    )
    j0, j1 = kg._cell_span(
        min(q[a, 1], q[a + 1, 1]) - radius, max(q[a, 1], q[a + 1, 1]) + radius, origin[1], cell, ny
    )
    for ci in range(i0, i1 + 1):
        for c in range(ci * ny + j0, ci * ny + j1 + 1):
            for m in range(start[c], start[c + 1]):
                it = items[m]
                if it < ns:
                    nback = _check_pair(seg[it], k, q, seg, pid, move, min_gap, mark, back, nback, stamp)
                    nback = _check_pair(seg[it] + 1, k, q, seg, pid, move, min_gap, mark, back, nback, stamp)
                else:
                    nback = _check_pair(
                        lone[it - ns], k, q, seg, pid, move, min_gap, mark, back, nback, stamp
                    )
    return nback


@njit
def settle_moves(
    pts: np.ndarray,
    nrm: np.ndarray,
    move: np.ndarray,
    seg: np.ndarray,
    lone: np.ndarray,
    pid: np.ndarray,
    min_gap: float,
    rounds: int,
    origin: np.ndarray,
    cell: float,
    nx: int,
    ny: int,
    start: np.ndarray,
    items: np.ndarray,
) -> tuple[np.ndarray, int]:
    """Undo the moves that bring a point within ``min_gap`` of another path, round after round.

    A round places every point at ``pts + move nrm`` and finds the pairs (point, segment of
    another path) where the point or an end of the segment moves and the exact point-to-segment
    distance is below ``min_gap``; their moved points are put back (``move = 0``).  Rounds repeat
    until one finds no such pair; when ``rounds`` rounds are not enough every move is undone.  A
    pair's distance changes only when one of its points was put back, so after the first round
    (which checks the pairs of every moved point) a round checks only the pairs of the points put
    back in the round before; the result is that of checking every pair each round.

    Parameters
    ----------
    pts : (n, 2) float, mm
        The points as laid (the grid holds them there).
    nrm : (n, 2) float
        Unit left normal per point.
    move : (n,) float, mm
        Proposed move along ``nrm`` (0: none).
    seg : (s,) int
        Segment ``k`` runs from point ``seg[k]`` to ``seg[k] + 1``.
    lone : (l,) int
        The points that are not the end of any segment (paths of one point).
    pid : (n,) int
        Path of each point.
    min_gap : float, mm
    rounds : int
    origin : (2,) float, mm; cell : float, mm; nx, ny : int
        The cell grid; ``start``, ``items``: its lists of segments and lone points
        (:func:`cell_lists`).  A search visits the cells of its query's box widened by
        ``min_gap + max |move|`` (the grid holds the points as laid, the distances are measured
        where they moved).

    Returns
    -------
    move : (n,) float, mm
        The moves kept (a copy).
    used : int
        Rounds run; ``rounds + 1`` when they ran out (every move undone).
    """
    n = pts.shape[0]
    ns = seg.shape[0]
    grid = (origin, cell, nx, ny, start, items)
    seg_of = np.empty(n, dtype=np.int64)  # the segment starting at each point, -1: none
    seg_of[:] = -1
    for k in range(ns):
        seg_of[seg[k]] = k
    mv = np.empty(n)
    q = np.empty((n, 2))
    mark = np.zeros(n, dtype=np.int64)  # round stamp: put back in this round
    seen = np.zeros(ns, dtype=np.int64)  # round stamp: segment searched in this round
    back = np.empty(n, dtype=np.int64)
    active = np.empty(n, dtype=np.int64)
    n_active = 0
    radius = min_gap
    for i in range(n):
        mv[i] = move[i]
        if move[i] != 0.0:
            active[n_active] = i
            n_active += 1
            radius = max(radius, min_gap + abs(move[i]))
    for rnd in range(1, rounds + 1):
        if n_active == 0:
            return mv, rnd - 1
        for i in range(n):
            q[i, 0] = pts[i, 0] + mv[i] * nrm[i, 0]
            q[i, 1] = pts[i, 1] + mv[i] * nrm[i, 1]
        nback = 0
        for a in range(n_active):
            v = active[a]
            nback = _pairs_of_point(v, q, seg, pid, mv, min_gap, radius, grid, mark, back, nback, rnd)
        for a in range(n_active):
            v = active[a]
            for s in range(v - 1, v + 1):
                if s >= 0 and seg_of[s] >= 0 and seen[seg_of[s]] != rnd:
                    seen[seg_of[s]] = rnd
                    nback = _pairs_of_segment(
                        seg_of[s], q, seg, lone, pid, mv, min_gap, radius, grid, mark, back, nback, rnd
                    )
        if nback == 0:
            return mv, rnd
        for m in range(nback):
            mv[back[m]] = 0.0
            active[m] = back[m]
        n_active = nback
    mv[:] = 0.0
    return mv, rounds + 1
