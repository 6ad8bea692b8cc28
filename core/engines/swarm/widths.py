"""The local pitch of every path point from the finished layer: the flow width that tiles.

During a step the swarm knows only the agents of its own chain, so its pitch estimate misses the
paths of other chains and of later swarms (fill swarms laid in the gaps next to it).  Once all
paths of the layer are laid, :func:`local_pitch` measures at every point the distance to the
neighbouring paths along the normal, to the left ``L`` and to the right ``R`` (the first other
path hit by the ray, within ``cap`` pitches), and sets the bead width to ``(L + R) / 2``: in one
dimension, beads of that width centred on the paths tile the gap exactly.  Where a side has no
path within reach the bead reaches the region's boundary along the normal (twice the way to it),
up to ``cap`` pitches.

A bead of width ``(L + R) / 2`` tiles both gaps only when its path lies midway between the
mid-gaps, that is ``(L - R) / 4`` to the left of where it is; where the neighbours are uneven (a
path squeezed toward one side as fronts converge) it covers the nearer one instead.
:func:`centre_points` moves the points there (clipped, and never closer than the engines' half
pitch to another path).
"""

from __future__ import annotations

import numpy as np
from loadpath._typing import Floats, Points2, Region
from loadpath.engines.swarm.boundary import Domain
from scipy.spatial import cKDTree

__all__ = ["local_pitch", "centre_points"]

_MIN_MOVE = 0.05
"""Moves shorter than this share of ``min_gap`` are not made (about 0.01 mm at a 0.4 mm pitch: no
visible change of the tiling, and evenly spaced paths, most of a layer, are then left alone)."""


def _tangents(points: Points2, starts: np.ndarray) -> Points2:
    """Return the unit tangent at every vertex of ragged paths (central differences, one-sided at ends)."""
    n = len(points)
    nxt = np.arange(1, n + 1)
    prv = np.arange(-1, n - 1)
    ends = np.append(starts[1:], n) - 1
    nxt[ends] = ends
    prv[starts] = starts
    t = points[nxt] - points[prv]
    norm = np.sqrt(np.sum(t * t, axis=1))
    return t / np.where(norm > 0, norm, 1.0)[:, None]


def local_pitch(
    paths: list[Points2],
    region: Region,
    pitch: float,
    cap: float = 1.5,
    k: int = 12,
    only: list[np.ndarray] | None = None,
    sides: bool = False,
) -> list[Floats] | tuple[list[Floats], list[Floats], list[Floats]]:
    """Flow width at every point of the layer's paths (mm).

    Parameters
    ----------
    paths : list of (n_i, 2) float, mm
    region : Polygon or MultiPolygon, mm
    pitch : float, mm
    cap : float
        Largest width, in pitches; also how far the rays look.
    k : int
        Nearest segments examined per point.
    only : list of (n_i,) bool, optional
        Measure only these points (the others get ``cap * pitch``, to be replaced by the caller).

    sides : bool
        Also return, per point, the distances ``L`` and ``R`` to the left and right (mm, at most
        ``cap`` pitches; ``cap`` pitches where not measured).

    Returns
    -------
    list of (n_i,) float, mm
        In ``[pitch / 4, cap * pitch]``.
    list of (n_i,) float, mm; list of (n_i,) float, mm
        Only with ``sides``: ``L`` and ``R``.
    """
    if not paths:
        return ([], [], []) if sides else []
    counts = np.array([len(p) for p in paths])
    pts = np.concatenate(paths)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    pid = np.repeat(np.arange(len(paths)), counts)
    tan = _tangents(pts, starts)
    # segments of all paths, split so none is longer than half a pitch (midpoints find them)
    last = np.zeros(len(pts), dtype=bool)
    last[np.cumsum(counts) - 1] = True
    a, b, sid = pts[:-1][~last[:-1]], pts[1:][~last[:-1]], pid[:-1][~last[:-1]]
    reach = cap * pitch
    out = np.full(len(pts), reach)
    lefts, rights = np.full(len(pts), reach), np.full(len(pts), reach)
    if len(a):
        seg = np.sqrt(np.sum((b - a) ** 2, axis=1))
        parts = np.maximum(1, np.ceil(seg / (0.5 * pitch)).astype(np.int64))
        rep = np.repeat(np.arange(len(a)), parts)
        frac = np.arange(len(rep)) - np.repeat(np.cumsum(parts) - parts, parts)
        s0 = (frac / parts[rep])[:, None]
        s1 = ((frac + 1) / parts[rep])[:, None]
        e = b[rep] - a[rep]
        a2, b2, sid2 = a[rep] + s0 * e, a[rep] + s1 * e, sid[rep]
        sel = np.flatnonzero(np.concatenate(only)) if only is not None else np.arange(len(pts))
        tree = cKDTree(0.5 * (a2 + b2))
        n_all = len(pts)
        pts, tan, psel = pts[sel], tan[sel], pid[sel]
        nrm = np.stack([-tan[:, 1], tan[:, 0]], axis=1)

        def rays(rows: np.ndarray, kk: int) -> list[np.ndarray]:
            """Distance to the first other path along the left and the right normal (inf: none)."""
            kk = min(kk, len(a2))
            _, idx = tree.query(pts[rows], k=kk, distance_upper_bound=reach + 0.5 * pitch)
            idx = idx.reshape(len(rows), kk)
            ok = idx < len(a2)
            idx = np.where(ok, idx, 0)
            ok &= sid2[idx] != psel[rows, None]
            # candidate segment ends in the point's frame: along the tangent (u) and the normal
            # (v); the normal line (u = 0) crosses a segment whose ends lie on both sides of it,
            # at v = va + (vb - va) ua / (ua - ub): v > 0 on the left, v < 0 on the right
            px, py = pts[rows, 0:1], pts[rows, 1:2]
            tx, ty = tan[rows, 0:1], tan[rows, 1:2]
            ax_, ay_ = a2[idx, 0] - px, a2[idx, 1] - py
            bx_, by_ = b2[idx, 0] - px, b2[idx, 1] - py
            ua, ub = ax_ * tx + ay_ * ty, bx_ * tx + by_ * ty
            va, vb = ay_ * tx - ax_ * ty, by_ * tx - bx_ * ty
            cross = ok & (ua * ub <= 0) & (ua != ub)
            v = va + (vb - va) * (ua / np.where(cross, ua - ub, 1.0))
            return [
                np.min(np.where(cross & (v > 0), v, np.inf), axis=1),
                np.min(np.where(cross & (v < 0), -v, np.inf), axis=1),
            ]

        hits = rays(np.arange(len(sel)), k)
        # a side may be hidden behind the k nearest pieces (own path, the near side's path):
        # look again, four times as far down the list, where a side found nothing
        again = np.flatnonzero(~np.isfinite(hits[0]) | ~np.isfinite(hits[1]))
        if len(again):
            more = rays(again, 4 * k)
            for h, m in zip(hits, more, strict=True):
                h[again] = np.minimum(h[again], m)
        # no path on a side: the bead reaches the layer's edge along the normal (twice the way to
        # it), so the outermost paths cover the strip at the edge and path ends at the edge keep
        # their width
        lr = []
        edge = Domain(region, 0.0)
        for h, d in zip(hits, (nrm, -nrm), strict=True):
            miss = np.flatnonzero(~np.isfinite(h))
            if len(miss):
                dist, _, _, _ = edge.ray(pts[miss], d[miss], 0.5 * reach)
                h = h.copy()
                h[miss] = 2.0 * dist
            lr.append(h)
        left, right = lr
        out = np.full(n_all, reach)
        left, right = np.minimum(left, reach), np.minimum(right, reach)
        out[sel] = 0.5 * (left + right)
        lefts[sel], rights[sel] = left, right
    out = np.clip(out, 0.25 * pitch, reach)
    cuts = np.cumsum(counts)[:-1]
    if sides:
        return np.split(out, cuts), np.split(lefts, cuts), np.split(rights, cuts)
    return np.split(out, cuts)


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
    is (after ``rounds`` rounds every move is undone).

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
    counts = np.array([len(p) for p in paths])
    pts = np.concatenate(paths)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    pid = np.repeat(np.arange(len(paths)), counts)
    tan = _tangents(pts, starts)
    nrm = np.stack([-tan[:, 1], tan[:, 0]], axis=1)
    L, R = np.concatenate(left), np.concatenate(right)
    toward = np.where(L > R, L, R)  # the side the point moves to
    size = np.minimum(np.minimum(0.25 * np.abs(L - R), limit), np.maximum(0.5 * (toward - min_gap), 0.0))
    move = np.where(L > R, size, -size)
    last = np.zeros(len(pts), dtype=bool)
    last[np.cumsum(counts) - 1] = True
    move[np.abs(move) < _MIN_MOVE * min_gap] = 0.0
    seg = np.flatnonzero(~last)  # segment k runs from vertex seg[k] to seg[k] + 1
    for _ in range(rounds):
        if not np.any(move != 0.0):
            break
        q = pts + move[:, None] * nrm
        a, b = q[seg], q[seg + 1]
        half = 0.5 * np.hypot(*(b - a).T)
        reach = min_gap + float(half.max(initial=0.0))
        mid_tree = cKDTree(0.5 * (a + b))
        # pairs (vertex, segment of another path) near enough to matter, where the vertex or the
        # segment moved; exact point-to-segment distances decide
        mv = np.flatnonzero(move != 0.0)
        seg_mv = np.flatnonzero((move[seg] != 0.0) | (move[seg + 1] != 0.0))
        p1 = cKDTree(q[mv]).sparse_distance_matrix(mid_tree, reach, output_type="ndarray")
        p2 = cKDTree(q).sparse_distance_matrix(
            cKDTree(0.5 * (a[seg_mv] + b[seg_mv])), reach, output_type="ndarray"
        )
        v = np.concatenate([mv[p1["i"]], p2["i"]])
        k = np.concatenate([p1["j"], seg_mv[p2["j"]]])
        keep = pid[v] != pid[seg[k]]
        v, k = v[keep], k[keep]
        ab = b[k] - a[k]
        t = np.clip(np.sum((q[v] - a[k]) * ab, axis=1) / np.maximum(np.sum(ab * ab, axis=1), 1e-24), 0.0, 1.0)
        d = np.hypot(*(q[v] - (a[k] + t[:, None] * ab)).T)
        close = d < min_gap
        back = np.unique(np.concatenate([v[close], seg[k[close]], seg[k[close]] + 1]))
        back = back[move[back] != 0.0]
        if not len(back):
            break
        move[back] = 0.0
    else:
        move[:] = 0.0  # not settled within the rounds: no move at all keeps the layer as laid
    out = pts + move[:, None] * nrm
    return np.split(out, np.cumsum(counts)[:-1])
