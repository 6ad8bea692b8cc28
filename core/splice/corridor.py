"""Corridor fit: fewer vertices than Ramer-Douglas-Peucker for the same deviation bound.

RDP keeps vertices *of* the path, so every chord lies on the inside of a curve: over a gently
curving line all the deviation is on one side, and the chord's sag (``L^2 / 8R`` for a segment of
length ``L`` on a radius ``R``) uses the whole bound.  Here the kept interior vertices may move
sideways, within the bound, so the new segment runs down the middle of the corridor its dropped
vertices span: a segment on a curve may then sag twice as far for the same largest deviation,
``sqrt(2)`` times the length.  The material stays exactly where the plan put it: a kept vertex
still stands for its own index along the path, so the filament between two kept vertices is the
plan's between them (:mod:`loadpath.splice.beadruns`).

Per piece (a polyline between two fixed ends):

1. RDP at twice the bound (:func:`loadpath.splice.plan.simplify_mask`, position and the cumulative
   extrusion) picks the first kept vertices.
2. Each segment's dropped vertices lie between signed distances ``d-`` and ``d+`` of its chord;
   the segment wants to move sideways by ``(d+ + d-) / 2``.  A kept vertex goes where the two
   moved segments through it meet (the offset lines' intersection), at most ``tol`` from where it
   was; the piece's ends, and vertices where the path turns by more than ``fixed_turn`` (a linked
   run's hairpins and link corners), do not move.
3. Every dropped vertex is tested against its moved segment: within ``tol`` of it, and its
   cumulative extrusion within ``shift`` of the one interpolated at its projection.  Each segment
   that fails keeps its worst vertex, and 2-3 repeat until none fails (each round keeps more
   vertices; with all kept nothing is tested).

One numpy pass per round over every segment of every piece.
"""

from __future__ import annotations

import numpy as np
from loadpath._typing import Floats, Ints, Points2
from loadpath.splice.plan import simplify_mask

__all__ = ["corridor_fit"]


def corridor_fit(
    points: Points2,
    g: Floats,
    sizes: Ints,
    tol: float,
    shift: float,
    min_segment: float = 0.05,
    fixed_turn: float = 60.0,
) -> tuple[np.ndarray, Points2]:
    """Vertices kept and where they go, for pieces given as one ragged array (module docstring).

    Parameters
    ----------
    points : (N, 2) float, mm
        The vertices of every piece, one piece after the other.
    g : (N,) float, mm
        Cumulative extrusion along each piece (non-decreasing inside a piece).
    sizes : (P,) int
        Vertices per piece (each >= 1); they sum to N.
    tol : float, mm
        Largest distance of a dropped vertex from the printed segment, and of a kept vertex from
        its own position.
    shift : float, mm
        Largest difference of a dropped vertex's ``g`` from the one interpolated along its segment.
    min_segment : float, mm
        For the first RDP pass (:func:`loadpath.splice.plan.simplify_mask`).
    fixed_turn : float, degrees
        Kept vertices where the simplified path turns by more than this stay in place.

    Returns
    -------
    keep : (N,) bool
        Kept vertices (every piece's first and last among them).
    moved : (N, 2) float, mm
        Their positions (the input's where not kept); ``|moved - points| <= tol``.
    """
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    g = np.asarray(g, dtype=float)
    sizes = np.asarray(sizes, dtype=np.int64)
    n = len(pts)
    keep = simplify_mask(pts, g, sizes, 2.0 * tol, shift, min_segment) if n else np.zeros(0, dtype=bool)
    moved = pts.copy()
    if not n or tol <= 0:
        return np.ones(n, dtype=bool), moved
    piece = np.repeat(np.arange(len(sizes)), sizes)
    ends = np.cumsum(sizes)
    end_v = np.zeros(n, dtype=bool)
    end_v[ends - sizes] = end_v[ends - 1] = True
    cos_fixed = np.cos(np.radians(fixed_turn))
    for _ in range(n):
        kv = np.flatnonzero(keep)
        a, z = kv[:-1], kv[1:]
        same = piece[a] == piece[z]
        a, z = a[same], z[same]
        # 2. each segment's sideways move, from the signed distances of its dropped vertices
        inner = z - a - 1
        seg_id = np.repeat(np.arange(len(a)), inner)
        idx = np.arange(int(inner.sum())) + np.repeat(a + 1 - (np.cumsum(inner) - inner), inner)
        d = pts[z] - pts[a]
        ln = np.hypot(*d.T)
        nrm = np.stack([-d[:, 1], d[:, 0]], axis=1) / np.where(ln > 0, ln, 1.0)[:, None]
        sd = np.sum((pts[idx] - pts[a][seg_id]) * nrm[seg_id], axis=1)
        hi = np.zeros(len(a))
        lo = np.zeros(len(a))
        np.maximum.at(hi, seg_id, sd)
        np.minimum.at(lo, seg_id, sd)
        want = np.where(ln > 0, 0.5 * (hi + lo), 0.0)
        # kept vertex between segments s (before) and s + 1 (after): the offset lines' meeting point
        moved[:] = pts
        mid = np.flatnonzero(z[:-1] == a[1:])  # segment s ends where s + 1 starts
        v = z[mid]
        n1, n2 = nrm[mid], nrm[mid + 1]
        m1, m2 = want[mid], want[mid + 1]
        det = n1[:, 0] * n2[:, 1] - n1[:, 1] * n2[:, 0]
        cos = np.sum(n1 * n2, axis=1)
        solve = np.abs(det) > 0.05
        safe = np.where(solve, det, 1.0)
        o = np.where(
            solve[:, None],
            np.stack(
                [(m1 * n2[:, 1] - m2 * n1[:, 1]) / safe, (n1[:, 0] * m2 - n2[:, 0] * m1) / safe], axis=1
            ),
            0.5 * (m1 + m2)[:, None] * (n1 + n2) / np.maximum(np.hypot(*(n1 + n2).T), 1e-12)[:, None],
        )
        r = np.hypot(*o.T)
        o *= np.minimum(1.0, tol / np.maximum(r, 1e-12))[:, None]
        o[(cos < cos_fixed) | end_v[v]] = 0.0
        moved[v] = pts[v] + o
        # 3. every dropped vertex against its moved segment
        qa, qb = moved[a][seg_id], moved[z][seg_id]
        qd = qb - qa
        q2 = np.sum(qd * qd, axis=1)
        rel = pts[idx] - qa
        t = np.clip(np.sum(rel * qd, axis=1) / np.where(q2 > 0, q2, 1.0), 0.0, 1.0)
        dist = np.hypot(*(rel - t[:, None] * qd).T)
        dg = np.abs(g[idx] - (g[a][seg_id] + t * (g[z] - g[a])[seg_id]))
        err = np.maximum(dist / tol, dg / shift if shift > 0 else np.where(dg > 0, np.inf, 0.0))
        bad = err > 1.0 + 1e-9
        if not bad.any():
            break
        worst = np.full(len(a), -1.0)
        np.maximum.at(worst, seg_id, np.where(bad, err, -1.0))
        pick = bad & (err == worst[seg_id])
        keep[idx[pick]] = True
    moved[~keep] = pts[~keep]
    return keep, moved
