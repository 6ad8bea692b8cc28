"""A static spatial index of accepted path segments, answering exact spacing queries.

Segments are indexed by their midpoints in a ``cKDTree``: if segment ``P`` (length ``h_p``) is within
``r`` of segment ``S`` (length ``h_s``), their midpoints are within ``r + h_p / 2 + h_s / 2``, so a
ball query around the query midpoint finds every candidate and :func:`segment_distance` settles
it exactly.  The index is rebuilt once per filling round (the accepted set only grows between
rounds); queries are vectorized over many query segments.
"""

from __future__ import annotations

import numpy as np
from loadpath._typing import Bools, Floats, Points2
from loadpath.engines.streamlines._lines import Lines, point_segment_distance, segment_distance
from scipy.spatial import cKDTree

__all__ = ["SegmentIndex"]

_K = 16


class SegmentIndex:
    """Exact distances from query segments or points to a fixed set of segments.

    Parameters
    ----------
    lines : Lines
        The accepted paths.
    extra : list of (m_i, 2) arrays, optional
        More polylines (e.g. the region boundary) to include.
    """

    def __init__(self, lines: Lines, extra: list[Points2] | None = None) -> None:
        all_lines = lines if not extra else Lines.from_list(lines.to_list() + list(extra))
        start, _ = all_lines.segments()
        self.a = all_lines.points[start]
        self.b = all_lines.points[start + 1]
        self.n = len(start)
        if self.n:
            mid = 0.5 * (self.a + self.b)
            self.half = 0.5 * float(np.max(np.linalg.norm(self.b - self.a, axis=1)))
            self.tree: cKDTree | None = cKDTree(mid)
        else:
            self.half = 0.0
            self.tree = None

    def _pairs(self, q: Points2, bound: float) -> tuple[np.ndarray, np.ndarray]:
        """(query row, indexed segment) pairs whose midpoints are within ``bound``; rows sorted."""
        assert self.tree is not None
        rows_out, segs_out = [], []
        todo = np.arange(len(q))
        for k in (_K, 4 * _K):
            k = min(k, self.n)
            dist, idx = self.tree.query(q[todo], k=k, distance_upper_bound=bound)
            if k == 1:
                dist, idx = dist[:, None], idx[:, None]
            found = np.isfinite(dist)
            full = found[:, -1] if k < self.n else np.zeros(len(todo), dtype=bool)
            done = ~full
            r, c = np.nonzero(found & done[:, None])
            rows_out.append(todo[r])
            segs_out.append(idx[r, c])
            todo = todo[full]
            if len(todo) == 0:
                break
        if len(todo):  # still more than 4 K segments within the bound: search those rows fully
            extra = self.tree.query_ball_point(q[todo], bound, return_sorted=False)
            rows_out.append(np.repeat(todo, [len(e) for e in extra]))
            segs_out.append(np.concatenate([np.asarray(e, dtype=np.int64) for e in extra]))
        rows = np.concatenate(rows_out)
        segs = np.concatenate(segs_out).astype(np.int64)
        order = np.argsort(rows, kind="stable")
        return rows[order], segs[order]

    def segment_distance(self, p0: Points2, p1: Points2, radius: float) -> Floats:
        """Distance from each query segment to the nearest indexed segment, capped at ``radius``.

        Parameters
        ----------
        p0, p1 : (n, 2) float, mm
        radius : float, mm
            Distances at or above this are reported as ``radius`` (not searched further).

        Returns
        -------
        (n,) float, mm
        """
        n = len(p0)
        out = np.full(n, float(radius))
        if self.tree is None or n == 0:
            return out
        mid = 0.5 * (p0 + p1)
        hq = 0.5 * np.linalg.norm(p1 - p0, axis=1)
        rows, segs = self._pairs(mid, radius + self.half + float(np.max(hq)))
        if len(rows) == 0:
            return out
        d = segment_distance(p0[rows], p1[rows], self.a[segs], self.b[segs])
        starts = np.flatnonzero(np.concatenate([[True], rows[1:] != rows[:-1]]))
        out[rows[starts]] = np.minimum(out[rows[starts]], np.minimum.reduceat(d, starts))
        return out

    def clear_fraction(self, p0: Points2, p1: Points2, radius: float, iterations: int = 5) -> Floats:
        """Largest ``t`` in [0, 1] (bisection) with ``[p0, p0 + t (p1 - p0)]`` clear by ``radius``.

        The candidate segments are found once for the whole query segment; the bisection then
        only re-measures those.
        """
        n = len(p0)
        lo = np.zeros(n)
        if self.tree is None or n == 0:
            return np.ones(n)
        mid = 0.5 * (p0 + p1)
        hq = 0.5 * np.linalg.norm(p1 - p0, axis=1)
        rows, segs = self._pairs(mid, radius + self.half + float(np.max(hq)))
        hi = np.ones(n)
        if len(rows) == 0:
            return hi
        qa, qb = self.a[segs], self.b[segs]
        starts = np.flatnonzero(np.concatenate([[True], rows[1:] != rows[:-1]]))
        has = rows[starts]
        free = np.ones(n, dtype=bool)
        free[has] = False
        lo[free] = 1.0
        for _ in range(iterations):
            t = 0.5 * (lo + hi)
            end = p0 + t[:, None] * (p1 - p0)
            d = segment_distance(p0[rows], end[rows], qa, qb)
            ok = np.ones(n, dtype=bool)
            ok[has] = np.minimum.reduceat(d, starts) >= radius
            lo = np.where(ok & ~free, t, lo)
            hi = np.where(ok | free, hi, t)
        return lo

    def clear(self, p0: Points2, p1: Points2, radius: float) -> Bools:
        """Whether each query segment stays at least ``radius`` from every indexed segment."""
        return self.segment_distance(p0, p1, radius) >= radius

    def point_distance(self, points: Points2, radius: float) -> Floats:
        """Distance from points to the nearest indexed segment, capped at ``radius``, (n,) mm."""
        p = np.asarray(points, dtype=float)
        out = np.full(len(p), float(radius))
        if self.tree is None or len(p) == 0:
            return out
        rows, segs = self._pairs(p, radius + self.half)
        if len(rows) == 0:
            return out
        d = point_segment_distance(p[rows], self.a[segs], self.b[segs])
        starts = np.flatnonzero(np.concatenate([[True], rows[1:] != rows[:-1]]))
        out[rows[starts]] = np.minimum(out[rows[starts]], np.minimum.reduceat(d, starts))
        return out
