"""The region a swarm fills, as the boundary agents see it (paper Sec. III-B4).

A :class:`Domain` holds the region's boundary as an array of segments (outer rings, holes, and for
a fill swarm the edges of the beads already laid), and answers, vectorized:

* :meth:`Domain.inside` — is a point far enough inside to carry a moving agent (at least
  ``margin`` from the boundary)?  An agent whose next position fails this is removed (its path
  ends), which is how the front stops at the far end, splits at holes and concave corners, and
  never runs into paths laid before.
* :meth:`Domain.ray` — the first boundary point along a ray: where a chain end's boundary agent
  sits (``x in dP`` of Eq. 12).
* :meth:`Domain.project` — the nearest boundary point and the tangent there: a boundary agent
  moves along the tangent in the QP and is then projected back onto the boundary.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from loadpath._typing import Bools, Floats, Ints, Points2, Region

__all__ = ["Domain", "boundary_segments"]


def boundary_segments(region: Region) -> tuple[Points2, Points2, Ints]:
    """All boundary segments of a polygon or multipolygon, ring by ring, in ring order.

    Returns
    -------
    a, b : (s, 2) float, mm
        Start and end points.
    ring : (s,) int
        Index of the ring each segment belongs to.
    """
    rings = shapely.get_rings(shapely.get_parts(region))
    a, b, ring = [], [], []
    for k, r in enumerate(rings):
        c = np.asarray(r.coords)
        c = c[np.concatenate([[True], np.any(c[1:] != c[:-1], axis=1)])]
        if len(c) >= 2:
            a.append(c[:-1])
            b.append(c[1:])
            ring.append(np.full(len(c) - 1, k, dtype=np.int64))
    if not a:
        return np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0, dtype=np.int64)
    return np.concatenate(a), np.concatenate(b), np.concatenate(ring)


@dataclass
class Domain:
    """A region to fill and its boundary (mm).

    Parameters
    ----------
    region : Polygon or MultiPolygon
    margin : float, mm
        Moving agents keep at least this far inside.
    edge_of : Polygon or MultiPolygon, optional
        The layer's whole region, for a fill swarm's domain: :attr:`edge` tells which boundary
        segments lie on the layer's boundary (the others run along beads already laid).
    """

    region: Region
    margin: float
    edge_of: Region | None = None

    def __post_init__(self) -> None:
        self.inner = self.region.buffer(-self.margin) if self.margin > 0 else self.region
        shapely.prepare(self.inner)
        self.seg_a, self.seg_b, ring = boundary_segments(self.region)
        # first segment and length of each segment's ring (for walking along a ring)
        first = np.ones(len(ring), dtype=bool)
        first[1:] = ring[1:] != ring[:-1]
        starts = np.flatnonzero(first)
        counts = np.diff(np.append(starts, len(ring)))
        self.ring_start = np.repeat(starts, counts)
        self.ring_len = np.repeat(counts, counts)
        if self.edge_of is None:
            self.edge = np.ones(len(self.seg_a), dtype=bool)
        else:
            mid = shapely.points(0.5 * (self.seg_a + self.seg_b))
            self.edge = shapely.distance(self.edge_of.boundary, mid) <= 1e-3 * max(self.margin, 1e-3)
        d = self.seg_b - self.seg_a
        self.seg_len = np.linalg.norm(d, axis=1)
        self.seg_dir = d / self.seg_len[:, None]
        mid = 0.5 * (self.seg_a + self.seg_b)
        self._tree = shapely.STRtree(shapely.linestrings(np.stack([self.seg_a, self.seg_b], axis=1)))
        self._mid = mid

    def inside(self, points: Points2) -> Bools:
        """Points at least ``margin`` inside the region, (n,) bool."""
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        return shapely.contains_xy(self.inner, p[:, 0], p[:, 1])

    def _near(self, points: Points2, radius: float) -> tuple[np.ndarray, np.ndarray]:
        """Pairs (query index, segment index) of segments within ``radius`` of each point."""
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        boxes = shapely.box(p[:, 0] - radius, p[:, 1] - radius, p[:, 0] + radius, p[:, 1] + radius)
        return self._tree.query(boxes)

    def ray(
        self, origins: Points2, directions: Points2, max_dist: float
    ) -> tuple[Floats, Points2, Points2, Ints]:
        """First boundary crossing along rays ``o + s d``, ``0 < s <= max_dist``.

        Parameters
        ----------
        origins : (m, 2) float, mm
        directions : (m, 2) float
            Unit vectors.
        max_dist : float, mm

        Returns
        -------
        dist : (m,) float, mm
            Distance to the hit (``inf`` where none).
        point : (m, 2) float, mm
            The hit (NaN where none).
        tangent : (m, 2) float
            Unit tangent of the boundary there (NaN where none).
        segment : (m,) int
            Index of the boundary segment hit (-1 where none).
        """
        o = np.asarray(origins, dtype=float).reshape(-1, 2)
        d = np.asarray(directions, dtype=float).reshape(-1, 2)
        m = len(o)
        dist = np.full(m, np.inf)
        seg = np.full(m, -1)
        if m and len(self.seg_a):
            qi, si = self._near(o + 0.5 * max_dist * d, 0.5 * max_dist)
            if len(qi):
                a = self.seg_a[si]
                e = self.seg_b[si] - a
                w = a - o[qi]
                dd = d[qi]
                den = dd[:, 0] * e[:, 1] - dd[:, 1] * e[:, 0]
                ok = np.abs(den) > 1e-15
                den_safe = np.where(ok, den, 1.0)
                s = (w[:, 0] * e[:, 1] - w[:, 1] * e[:, 0]) / den_safe  # along the ray
                r = (w[:, 0] * dd[:, 1] - w[:, 1] * dd[:, 0]) / den_safe  # along the segment
                ok &= (s > 0) & (s <= max_dist) & (r >= 0) & (r <= 1)
                s = np.where(ok, s, np.inf)
                order = np.lexsort((s, qi))
                qi_s, s_s, si_s = qi[order], s[order], si[order]
                first = np.ones(len(qi_s), dtype=bool)
                first[1:] = qi_s[1:] != qi_s[:-1]
                dist[qi_s[first]] = s_s[first]
                seg[qi_s[first]] = np.where(np.isfinite(s_s[first]), si_s[first], -1)
        hit = seg >= 0
        point = np.full((m, 2), np.nan)
        tangent = np.full((m, 2), np.nan)
        point[hit] = o[hit] + dist[hit, None] * d[hit]
        tangent[hit] = self.seg_dir[seg[hit]]
        return dist, point, tangent, seg

    def project_local(self, points: Points2, segment: Ints, reach: int = 6) -> Points2:
        """Nearest point on the boundary near a known segment (within ``reach`` segments along its ring).

        A boundary agent slides along the tangent of its segment by at most half a step; this puts
        it back onto the boundary without a global search.

        Parameters
        ----------
        points : (m, 2) float, mm
        segment : (m,) int
            A segment near each point (where the agent was on the boundary).
        reach : int

        Returns
        -------
        (m, 2) float, mm
        """
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        seg = np.asarray(segment, dtype=np.int64)
        rs, rl = self.ring_start[seg], self.ring_len[seg]
        k = np.arange(-reach, reach + 1)
        cand = rs[:, None] + (seg[:, None] - rs[:, None] + k[None, :]) % rl[:, None]
        a = self.seg_a[cand]
        e = self.seg_b[cand] - a
        u = np.clip(np.sum((p[:, None, :] - a) * e, axis=2) / np.sum(e * e, axis=2), 0.0, 1.0)
        q = a + u[..., None] * e
        best = np.argmin(np.sum((q - p[:, None, :]) ** 2, axis=2), axis=1)
        return q[np.arange(len(p)), best]

    def project(self, points: Points2) -> tuple[Points2, Points2, Floats]:
        """Nearest boundary point, the boundary tangent there, and the distance.

        Parameters
        ----------
        points : (m, 2) float, mm

        Returns
        -------
        nearest : (m, 2) float, mm
        tangent : (m, 2) float
        dist : (m,) float, mm
        """
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        m = len(p)
        nearest = np.full((m, 2), np.nan)
        tangent = np.full((m, 2), np.nan)
        dist = np.full(m, np.inf)
        if not m or not len(self.seg_a):
            return nearest, tangent, dist
        nearest_idx = self._tree.query_nearest(shapely.points(p), all_matches=False)
        qi, si = nearest_idx
        a = self.seg_a[si]
        e = self.seg_b[si] - a
        u = np.clip(np.sum((p[qi] - a) * e, axis=1) / np.sum(e * e, axis=1), 0.0, 1.0)
        q = a + u[:, None] * e
        nearest[qi] = q
        tangent[qi] = self.seg_dir[si]
        dist[qi] = np.linalg.norm(p[qi] - q, axis=1)
        return nearest, tangent, dist

    def crosses(self, a: Points2, b: Points2) -> Bools:
        """Whether segments ``a -> b`` cross the boundary, (m,) bool."""
        lines = shapely.linestrings(np.stack([np.asarray(a), np.asarray(b)], axis=1))
        qi, _ = self._tree.query(lines, predicate="intersects")
        out = np.zeros(len(lines), dtype=bool)
        out[qi] = True
        return out
