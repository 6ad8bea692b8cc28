"""The region a swarm fills, as the boundary agents see it (paper Sec. III-B4).

A :class:`Domain` holds the region's boundary as an array of segments (outer rings, holes, and for
a fill swarm the edges of the beads already laid), and answers, vectorized (compiled kernels of
:mod:`.kernel_geom`, which the swarm's step calls directly on :attr:`Domain.data`):

* :meth:`Domain.inside` — is a point far enough inside to carry a moving agent (at least
  ``margin`` from the boundary: inside shapely's ``buffer(-margin)`` of the region)?  An agent whose
  next position fails this is removed (its path ends), which is how the front stops at the far
  end, splits at holes and concave corners, and never runs into paths laid before.
* :meth:`Domain.ray` — the first boundary point along a ray: where a chain end's boundary agent
  sits (``x in dP`` of Eq. 12).
* :meth:`Domain.project_local` — the nearest boundary point near a known segment: a boundary agent
  moves along the tangent in the QP and is then projected back onto the boundary.
* :meth:`Domain.crosses` — whether segments touch the boundary.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from loadpath._typing import Bools, Floats, Ints, Points2, Region
from loadpath.engines.finish import kernel_geom as kg

__all__ = ["Domain", "boundary_segments"]

_CELLS_PER_SEGMENT = 4
"""The cell grids of a domain have about this many cells per boundary segment."""
_MAX_CELLS_PER_AXIS = 2048


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


def _frame(a: Points2, b: Points2) -> tuple[np.ndarray, float, int, int]:
    """Origin, cell, nx, ny of a cell grid over segments (about 4 cells per segment, one cell of margin)."""
    if not len(a):
        return np.zeros(2), 1.0, 1, 1
    lo = np.minimum(a.min(axis=0), b.min(axis=0))
    hi = np.maximum(a.max(axis=0), b.max(axis=0))
    w, h = hi - lo
    span = max(w, h, 1e-9)
    cell = float(np.sqrt(max(w * h, span * span * 1e-6) / (_CELLS_PER_SEGMENT * len(a))))
    cell = max(cell, span / _MAX_CELLS_PER_AXIS)
    origin = lo - cell
    nx = int(np.ceil(w / cell)) + 3
    ny = int(np.ceil(h / cell)) + 3
    return origin, cell, nx, ny


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
        self.seg_a, self.seg_b, ring = boundary_segments(self.region)
        # first segment and length of each segment's ring (for walking along a ring)
        first = np.ones(len(ring), dtype=bool)
        first[1:] = ring[1:] != ring[:-1]
        starts = np.flatnonzero(first)
        counts = np.diff(np.append(starts, len(ring)))
        self.ring_start = np.repeat(starts, counts).astype(np.int64)
        self.ring_len = np.repeat(counts, counts).astype(np.int64)
        if self.edge_of is None:
            self.edge = np.ones(len(self.seg_a), dtype=bool)
        else:
            mid = shapely.points(0.5 * (self.seg_a + self.seg_b))
            self.edge = shapely.distance(self.edge_of.boundary, mid) <= 1e-3 * max(self.margin, 1e-3)
        d = self.seg_b - self.seg_a
        self.seg_len = np.linalg.norm(d, axis=1)
        self.seg_dir = d / self.seg_len[:, None] if len(d) else np.zeros((0, 2))
        sg_origin, sg_cell, sg_nx, sg_ny = _frame(self.seg_a, self.seg_b)
        sg_start, sg_items = kg.cell_grid(self.seg_a, self.seg_b, sg_origin, sg_cell, sg_nx, sg_ny)
        if self.inner.is_empty:  # nothing is far enough inside: inside() is False everywhere
            in_a, in_b = np.zeros((0, 2)), np.zeros((0, 2))
        else:
            in_a, in_b, _ = boundary_segments(self.inner)
        ip_origin, ip_cell, ip_nx, ip_ny = _frame(in_a, in_b)
        ip_start, ip_items = kg.cell_grid(in_a, in_b, ip_origin, ip_cell, ip_nx, ip_ny)
        self.data = kg.DomainData(
            seg_a=np.ascontiguousarray(self.seg_a, dtype=float),
            seg_b=np.ascontiguousarray(self.seg_b, dtype=float),
            seg_dir=np.ascontiguousarray(self.seg_dir, dtype=float),
            ring_start=self.ring_start,
            ring_len=self.ring_len,
            edge=np.ascontiguousarray(self.edge, dtype=np.bool_),
            sg_origin=sg_origin,
            sg_cell=sg_cell,
            sg_nx=sg_nx,
            sg_ny=sg_ny,
            sg_start=sg_start,
            sg_items=sg_items,
            in_a=np.ascontiguousarray(in_a, dtype=float),
            in_b=np.ascontiguousarray(in_b, dtype=float),
            ip_origin=ip_origin,
            ip_cell=ip_cell,
            ip_nx=ip_nx,
            ip_ny=ip_ny,
            ip_start=ip_start,
            ip_items=ip_items,
            ip_status=kg.pip_status(in_a, in_b, ip_origin, ip_cell, ip_nx, ip_ny),
        )

    def inside(self, points: Points2) -> Bools:
        """Points at least ``margin`` inside the region, (n,) bool."""
        p = np.ascontiguousarray(np.asarray(points, dtype=float).reshape(-1, 2))
        return kg.inside(self.data, p)

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
        o = np.ascontiguousarray(np.asarray(origins, dtype=float).reshape(-1, 2))
        d = np.ascontiguousarray(np.asarray(directions, dtype=float).reshape(-1, 2))
        return kg.ray(self.data, o, d, float(max_dist))

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
        p = np.ascontiguousarray(np.asarray(points, dtype=float).reshape(-1, 2))
        s = np.ascontiguousarray(np.asarray(segment, dtype=np.int64))
        return kg.project_local(self.data, p, s, int(reach))

    def crosses(self, a: Points2, b: Points2) -> Bools:
        """Whether segments ``a -> b`` touch or cross the boundary, (m,) bool."""
        a = np.ascontiguousarray(np.asarray(a, dtype=float).reshape(-1, 2))
        b = np.ascontiguousarray(np.asarray(b, dtype=float).reshape(-1, 2))
        return kg.crosses(self.data, a, b)
