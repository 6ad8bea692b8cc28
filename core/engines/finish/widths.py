"""The local pitch of every path point from the finished layer: the flow width that tiles.

During a step the swarm knows only the agents of its own chain, so its pitch estimate misses the
paths of other chains and of later swarms (fill swarms laid in the gaps next to it).  Once all
paths of the layer are laid, :func:`local_pitch` measures at every point the distance to the
neighbouring paths along the normal, to the left ``L`` and to the right ``R`` (the first other
path hit by the ray, within ``cap`` pitches), and sets the bead width to ``(L + R) / 2``: in one
dimension, beads of that width centred on the paths tile the gap exactly.  Where a side has no
path within reach the bead reaches the region's boundary along the normal (twice the way to it),
up to ``cap`` pitches.  Near a path's end the normal can pass just beyond a neighbour that ends
there too: with ``ends``, within a pitch of the end each side is then held to its distance just
inward (:func:`_end_sides`).

A bead of width ``(L + R) / 2`` tiles both gaps only when its path lies midway between the
mid-gaps, that is ``(L - R) / 4`` to the left of where it is; where the neighbours are uneven (a
path squeezed toward one side as fronts converge) it covers the nearer one instead.
:func:`centre_points` moves the points there (clipped, and never closer than the engines' half
pitch to another path).

Both searches are exact and compiled (:mod:`.kernel_widths`): the rays test every segment of
another path that the normal crosses within reach, found through a cell grid of the segments, and
the centring's rounds check every (point, segment) pair of another path that a move brought
closer than the half pitch.
"""

from __future__ import annotations

import numpy as np
from loadpath._typing import Floats, Points2, Region
from loadpath.engines.finish import kernel_widths as kw
from loadpath.engines.finish.boundary import Domain

__all__ = ["local_pitch", "centre_points"]

_MIN_MOVE = 0.05
"""Moves shorter than this share of ``min_gap`` are not made (about 0.01 mm at a 0.4 mm pitch: no
visible change of the tiling, and evenly spaced paths, most of a layer, are then left alone)."""

_CELLS_PER_ITEM = 4
"""Most cells a search grid has per segment (or point) it lists: half-pitch cells over a layer of
paths at the pitch with points a third of a pitch apart (the specimen) are about four per segment;
a few paths on a large bed get larger cells."""


def _tangents(points: Points2, starts: np.ndarray) -> Points2:
    """Return the unit tangent (n, 2) at every vertex of ragged paths starting at ``starts`` (p,).

    Central differences, one-sided at ends (:func:`.kernel_widths.tangents`); :mod:`.gaps` uses it too.
    """
    ends = np.append(np.asarray(starts[1:], dtype=np.int64), len(points))
    return kw.tangents(np.ascontiguousarray(points, dtype=float), ends)


def _split(values: np.ndarray, counts: np.ndarray) -> list[np.ndarray]:
    """Cut ``values`` (n, ...) into consecutive pieces of ``counts`` (p,) rows (views, as ``np.split``)."""
    ends = np.cumsum(counts).tolist()
    return [values[a:b] for a, b in zip([0, *ends[:-1]], ends, strict=True)]


def _frame(points: Points2, pad: float, cell: float, n_items: int) -> tuple[np.ndarray, float, int, int]:
    """Return a cell grid over ``points`` widened by ``pad`` (mm): origin (2,), cell (mm), nx, ny.

    Cells of side ``cell``, made larger where the box would need more than
    ``_CELLS_PER_ITEM`` cells per listed item (a sparse layer on a large bed).
    """
    x, y = points[:, 0], points[:, 1]  # column by column: numpy's axis-0 min of (n, 2) is 30x slower
    lo = np.array([x.min(), y.min()]) - pad
    hi = np.array([x.max(), y.max()]) + pad
    w, h = hi - lo
    cell = max(float(cell), float(np.sqrt(w * h / (_CELLS_PER_ITEM * n_items + 1024))))
    return lo - cell, cell, int(np.ceil(w / cell)) + 3, int(np.ceil(h / cell)) + 3


def _layer(paths: list[Points2]) -> tuple[Points2, np.ndarray, np.ndarray, np.ndarray, Points2]:
    """Return the points (n, 2) mm, counts (p,), path ids (n,), segment starts (s,), tangents (n, 2)."""
    counts = np.array([len(p) for p in paths])
    pts = np.ascontiguousarray(np.concatenate(paths), dtype=float)
    ends = np.cumsum(counts)
    pid = np.repeat(np.arange(len(paths), dtype=np.int64), counts)
    last = np.zeros(len(pts), dtype=bool)
    last[ends - 1] = True
    seg = np.flatnonzero(~last)  # segment k runs from point seg[k] to seg[k] + 1
    return pts, counts, pid, seg, kw.tangents(pts, ends)


END_ZONE = 1.0
"""Pitches from a path's end within which each side's distance is at most the side's distance just
inward of that (:func:`_end_sides`)."""


def _end_sides(h: Floats, sel: np.ndarray, pts: Points2, pid: np.ndarray, zone: float) -> Floats:
    """One side's distances ``h`` (m,) at points ``sel`` (m,), corrected near path ends.

    Neighbouring paths often end together at the region's edge (level sets contoured on one grid
    end on the same grid line).  The normal at an end point is tilted by the path's slant, so on one
    side it passes just beyond the neighbour's end: it finds nothing (the edge rule then gave the
    bead up to ``cap`` pitches) or the path after it, two pitches away.  So 1.4-2.5x the path's
    width at over half of all level-set path ends of the bench's solid layers: too much plastic
    at the perimeter, and on a 2.3 mm strip whose lines are mostly ends, 15-40 % more than the strip
    holds.  Within ``zone`` (mm, along the path) of either end a side's distance is therefore at most
    the one at the anchor, the nearest point inward beyond the zone (the path's middle on a path
    shorter than two zones); an anchor that missed (no neighbour on that side: the outermost path)
    leaves the side as it is.  Misses NaN or inf, as :func:`.kernel_widths.normal_hits` gives them.
    """
    m = len(h)
    if not m:
        return h
    p = pid[sel]
    step = np.hypot(*np.diff(pts[sel], axis=0).T)
    same = p[1:] == p[:-1]
    idx = np.arange(m)
    s = np.concatenate([[0.0], np.cumsum(np.where(same, step, 0.0))])  # along the path (the samples)
    s -= s[np.maximum.accumulate(np.where(np.r_[True, ~same], idx, 0))]
    to_end = s[np.minimum.accumulate(np.where(np.r_[~same, True], idx, m)[::-1])[::-1]] - s
    depth = np.minimum(s, to_end)
    inner = depth > zone
    nxt = np.minimum.accumulate(np.where(inner, idx, m)[::-1])[::-1]
    prv = np.maximum.accumulate(np.where(inner, idx, -1))
    order = np.lexsort((depth, p))  # by path, deepest last
    ps = p[order]
    change = ps[1:] != ps[:-1]
    group = np.cumsum(np.r_[True, change]) - 1
    anchor = np.empty(m, dtype=np.int64)
    anchor[order] = order[np.flatnonzero(np.r_[change, True])[group]]  # each path's deepest point
    ok_n = (nxt < m) & (p[np.minimum(nxt, m - 1)] == p)
    ok_p = (prv >= 0) & (p[np.maximum(prv, 0)] == p)
    head = ~inner & (s <= to_end)
    anchor[head & ok_n] = nxt[head & ok_n]
    anchor[~head & ~inner & ok_p] = prv[~head & ~inner & ok_p]
    ref = h[anchor]
    fix = ~inner & np.isfinite(ref) & ~(h <= ref)  # larger, or missed, beside a measured anchor
    out = h.copy()
    out[fix] = ref[fix]
    return out


def local_pitch(
    paths: list[Points2],
    region: Region,
    pitch: float,
    cap: float = 1.5,
    only: list[np.ndarray] | None = None,
    sides: bool = False,
    ends: bool = False,
) -> list[Floats] | tuple[list[Floats], list[Floats], list[Floats]]:
    """Flow width at every point of the layer's paths (mm).

    The rays are exact: every segment of another path crossed by the normal within ``cap``
    pitches is found (a cell grid of the segments, :func:`.kernel_widths.normal_hits`).

    Parameters
    ----------
    paths : list of (n_i, 2) float, mm
    region : Polygon or MultiPolygon, mm
    pitch : float, mm
    cap : float
        Largest width, in pitches; also how far the rays look.
    only : list of (n_i,) bool, optional
        Measure only these points (the others get ``cap * pitch``, to be replaced by the caller).
    sides : bool
        Also return, per point, the distances ``L`` and ``R`` to the left and right (mm, at most
        ``cap`` pitches; ``cap`` pitches where not measured).
    ends : bool
        Hold each side within :data:`END_ZONE` pitches of a path's end to its distance just inward
        (:func:`_end_sides`): for paths that end side by side, as the level sets do.  Not for the
        swarm, whose ends meet fronts and voids: its finishing with it (``bearing`` layer of the
        engine tests) covered 97.8 % of the region against 98.5 % without (overlap 3.4 % / 4.5 %).

    Returns
    -------
    list of (n_i,) float, mm
        In ``[pitch / 4, cap * pitch]``.
    list of (n_i,) float, mm; list of (n_i,) float, mm
        Only with ``sides``: ``L`` and ``R``.
    """
    if not paths:
        return ([], [], []) if sides else []
    pts, counts, pid, seg, tan = _layer(paths)
    reach = cap * pitch
    out = np.full(len(pts), reach)
    lefts, rights = np.full(len(pts), reach), np.full(len(pts), reach)
    if len(seg):
        sel = np.flatnonzero(np.concatenate(only)) if only is not None else np.arange(len(pts))
        origin, cell, nx, ny = _frame(pts, reach, 0.5 * pitch, len(seg))
        start, items = kw.cell_lists(pts, seg, seg[:0], origin, cell, nx, ny)
        hits = list(kw.normal_hits(pts, tan, pid, sel, seg, origin, cell, nx, ny, start, items, reach))
        if ends:
            hits = [_end_sides(h, sel, pts, pid, END_ZONE * pitch) for h in hits]
        # no path on a side: the bead reaches the layer's edge along the normal (twice the way to
        # it), so the outermost paths cover the strip at the edge and path ends at the edge keep
        # their width
        nrm = np.stack([-tan[sel, 1], tan[sel, 0]], axis=1)
        edge = Domain(region, 0.0)
        for h, d in zip(hits, (nrm, -nrm), strict=True):
            miss = np.flatnonzero(~np.isfinite(h))
            if len(miss):
                dist, _, _, _ = edge.ray(pts[sel[miss]], d[miss], 0.5 * reach)
                h[miss] = 2.0 * dist
        left, right = np.minimum(hits[0], reach), np.minimum(hits[1], reach)
        out[sel] = 0.5 * (left + right)
        lefts[sel], rights[sel] = left, right
    out = np.clip(out, 0.25 * pitch, reach)
    if sides:
        return _split(out, counts), _split(lefts, counts), _split(rights, counts)
    return _split(out, counts)


def centre_points(
    paths: list[Points2],
    left: list[Floats],
    right: list[Floats],
    limit: float,
    min_gap: float,
    rounds: int = 20,
) -> list[Points2]:
    """Move points along their normal to sit midway between the mid-gaps to their neighbours.

    The move is ``(L - R) / 4`` along the left normal (module docstring), at most ``limit``, and
    toward a side at most ``(d - min_gap) / 2`` for the distance ``d`` to that side: two
    neighbours moving toward each other then still keep ``min_gap``.  The distances are measured
    along the normal, so for converging paths they exceed the true ones; moved points that end up
    closer than ``min_gap`` to another path's segments (exact point-to-segment distances), or whose
    segments come that close to another path's vertex, are put back, round after round until none
    is (after ``rounds`` rounds every move is undone; :func:`.kernel_widths.settle_moves`).

    Parameters
    ----------
    paths : list of (n_i, 2) float, mm
    left, right : list of (n_i,) float, mm
        Distances to the neighbouring paths (:func:`local_pitch` with ``sides=True``).
    limit : float, mm
        Largest move.
    min_gap : float, mm
        Smallest centre-line distance to another path after the move.
    rounds : int

    Returns
    -------
    list of (n_i, 2) float, mm
    """
    if not paths:
        return []
    pts, counts, pid, seg, tan = _layer(paths)
    nrm = np.stack([-tan[:, 1], tan[:, 0]], axis=1)
    L, R = np.concatenate(left), np.concatenate(right)
    toward = np.where(L > R, L, R)  # the side the point moves to
    size = np.minimum(np.minimum(0.25 * np.abs(L - R), limit), np.maximum(0.5 * (toward - min_gap), 0.0))
    move = np.where(L > R, size, -size)
    move[np.abs(move) < _MIN_MOVE * min_gap] = 0.0
    if np.any(move != 0.0):
        radius = min_gap + float(np.max(np.abs(move)))
        lone = np.flatnonzero(counts == 1)
        lone = np.cumsum(counts)[lone] - 1  # paths of one point: no segment lists them
        origin, cell, nx, ny = _frame(pts, radius, radius, len(seg) + len(lone))
        start, items = kw.cell_lists(pts, seg, lone, origin, cell, nx, ny)
        move, _ = kw.settle_moves(
            pts, nrm, move, seg, lone, pid, float(min_gap), int(rounds), origin, cell, nx, ny, start, items
        )
    out = pts + move[:, None] * nrm
    return _split(out, counts)
