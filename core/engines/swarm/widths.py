"""The local pitch of every path point from the finished layer: the flow width that tiles.

During a step the swarm knows only the agents of its own chain, so its pitch estimate misses the
paths of other chains and of later swarms (fill swarms laid in the gaps next to it).  Once all
paths of the layer are laid, :func:`local_pitch` measures at every point the distance to the
neighbouring paths along the normal, to the left ``L`` and to the right ``R`` (the first other
path hit by the ray, within ``cap`` pitches), and sets the bead width to ``(L + R) / 2``: in one
dimension, beads of that width centred on the paths tile the gap exactly.  Where a side has no
path within reach the bead reaches the region's boundary along the normal (twice the way to it),
up to ``cap`` pitches.
"""

from __future__ import annotations

import numpy as np
from loadpath._typing import Floats, Points2, Region
from loadpath.engines.swarm.boundary import Domain
from scipy.spatial import cKDTree

__all__ = ["local_pitch"]


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
) -> list[Floats]:
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

    Returns
    -------
    list of (n_i,) float, mm
        In ``[pitch / 4, cap * pitch]``.
    """
    if not paths:
        return []
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
        kk = min(k, len(a2))
        _, idx = tree.query(pts[sel], k=kk, distance_upper_bound=reach + 0.5 * pitch)
        idx = idx.reshape(len(sel), kk)
        ok = idx < len(a2)
        idx = np.where(ok, idx, 0)
        ok &= sid2[idx] != pid[sel, None]
        n_all = len(pts)
        pts, tan = pts[sel], tan[sel]
        nrm = np.stack([-tan[:, 1], tan[:, 0]], axis=1)
        # candidate segment ends in the point's frame: along the tangent (u) and the normal (v);
        # the normal line (u = 0) crosses a segment whose ends lie on both sides of it, at
        # v = va + (vb - va) ua / (ua - ub): v > 0 on the left, v < 0 on the right
        px, py = pts[:, 0:1], pts[:, 1:2]
        tx, ty = tan[:, 0:1], tan[:, 1:2]
        ax_, ay_ = a2[idx, 0] - px, a2[idx, 1] - py
        bx_, by_ = b2[idx, 0] - px, b2[idx, 1] - py
        ua, ub = ax_ * tx + ay_ * ty, bx_ * tx + by_ * ty
        va, vb = ay_ * tx - ax_ * ty, by_ * tx - bx_ * ty
        cross = ok & (ua * ub <= 0) & (ua != ub)
        v = va + (vb - va) * (ua / np.where(cross, ua - ub, 1.0))
        hits = [
            np.min(np.where(cross & (v > 0), v, np.inf), axis=1),
            np.min(np.where(cross & (v < 0), -v, np.inf), axis=1),
        ]
        # no path on a side: the bead reaches the layer's edge along the normal (twice the way to
        # it), so the outermost paths cover the strip at the edge and path ends at the edge keep
        # their width
        sides = []
        edge = Domain(region, 0.0)
        for h, d in zip(hits, (nrm, -nrm), strict=True):
            miss = np.flatnonzero(~np.isfinite(h))
            if len(miss):
                dist, _, _, _ = edge.ray(pts[miss], d[miss], 0.5 * reach)
                h = h.copy()
                h[miss] = 2.0 * dist
            sides.append(h)
        left, right = sides
        out = np.full(n_all, reach)
        out[sel] = 0.5 * (np.minimum(left, reach) + np.minimum(right, reach))
    out = np.clip(out, 0.25 * pitch, reach)
    return np.split(out, np.cumsum(counts)[:-1])
