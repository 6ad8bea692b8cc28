"""Compiled geometry kernels of the swarm: occupancy grid, domain queries, stress-raster lookup.

The data live in the Python objects (:class:`~.grid.Occupancy`, :class:`~.boundary.Domain`,
:class:`~.raster.FieldRaster`), which hand them to the kernels as named tuples of arrays
(:class:`GridData`, :class:`DomainData`, :class:`RasterData`); each kernel is the loop form of the
numpy expression it replaced (same formulas, same order of operations where that order decides a
result), so the engine's paths are the same up to rounding.

Domain queries use two uniform cell grids built once per domain:

* a **segment grid** (every boundary segment listed in each cell it passes through) for rays and
  segment crossings: the first hit of a ray is searched among the segments of the cells its box
  overlaps (the exact test decides; the grid only skips far segments);
* a **point-in-polygon grid** of the inner region (the region shrunk by the margin, from
  shapely's buffer): each cell knows whether a reference point inside it is inside the region (a
  scanline with the half-open crossing rule), and a query point flips that answer once per inner
  boundary edge crossed on the way to the reference point, so a query costs the edges of one
  cell (usually none).
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from loadpath.engines.finish._numba import njit, njit_inline

__all__ = [
    "GridData",
    "DomainData",
    "RasterData",
    "cell_grid",
    "pip_status",
    "grid_free_for",
    "grid_free_path",
    "grid_cells",
    "grid_free_cells",
    "grid_mark",
    "grid_mark_cells",
    "grid_clear_of",
    "inside",
    "ray",
    "project_local",
    "crosses",
    "raster_sample",
]

GridData = namedtuple("GridData", "owner point origin cell ny hi ring")
"""Occupancy grid (:class:`~.grid.Occupancy`): owner (N,) int, point (N, 2), origin (2,), cell,
ny, hi (2,) float (largest cell index used per axis), ring (25,) int (flat offsets of the 5 x 5
neighbourhood)."""

DomainData = namedtuple(
    "DomainData",
    "seg_a seg_b seg_dir ring_start ring_len edge "
    "sg_origin sg_cell sg_nx sg_ny sg_start sg_items "
    "in_a in_b ip_origin ip_cell ip_nx ip_ny ip_start ip_items ip_status",
)
"""Domain (:class:`~.boundary.Domain`): boundary segments (s, 2) with direction, ring start and
length per segment, edge flags; the segment grid (origin, cell, nx, ny, CSR start/items); the
inner region's edges and its point-in-polygon grid (same layout plus a status per cell)."""

RasterData = namedtuple("RasterData", "tensor origin cell ny imax principal scale aniso_min")
"""Stress raster (:class:`~.raster.FieldRaster`): tensor (nx * ny, 3) MPa, origin (2,), cell, ny,
imax (2,) float, principal (0 tensile, 1 compressive, 2 max_abs, 3 min_abs), scale, aniso_min."""

# reference point of a point-in-polygon cell, as fractions of the cell (off the centre, so a
# boundary through cell centres, e.g. an axis-parallel edge at a round coordinate, never hits it)
_REF_X = 0.5123
_REF_Y = 0.4871


# ----------------------------------------------------------------------------------------------
# cell grids
# ----------------------------------------------------------------------------------------------


@njit_inline
def _cell_span(v0: float, v1: float, origin: float, cell: float, n: int) -> tuple[int, int]:
    """Cells ``[i0, i1]`` covering ``[v0, v1]`` (widened by a hair, clipped to ``[0, n - 1]``)."""
    pad = 1e-9 * cell
    i0 = int(np.floor((min(v0, v1) - pad - origin) / cell))
    i1 = int(np.floor((max(v0, v1) + pad - origin) / cell))
    return max(i0, 0), min(i1, n - 1)


@njit
def _segment_cells(
    ax: float,
    ay: float,
    bx: float,
    by: float,
    origin: np.ndarray,
    cell: float,
    nx: int,
    ny: int,
    out: np.ndarray,
) -> int:
    """Flat indices of the cells a segment passes through (column by column), written to ``out``."""
    c0, c1 = _cell_span(ax, bx, origin[0], cell, nx)
    k = 0
    for i in range(c0, c1 + 1):
        if bx != ax:
            x0 = max(min(ax, bx), origin[0] + i * cell)
            x1 = min(max(ax, bx), origin[0] + (i + 1) * cell)
            y0 = ay + (x0 - ax) * (by - ay) / (bx - ax)
            y1 = ay + (x1 - ax) * (by - ay) / (bx - ax)
        else:
            y0, y1 = ay, by
        r0, r1 = _cell_span(y0, y1, origin[1], cell, ny)
        for j in range(r0, r1 + 1):
            if k < out.shape[0]:
                out[k] = i * ny + j
            k += 1
    return k


@njit
def cell_grid(
    a: np.ndarray, b: np.ndarray, origin: np.ndarray, cell: float, nx: int, ny: int
) -> tuple[np.ndarray, np.ndarray]:
    """CSR lists of the segments ``a -> b`` passing through each cell: ``start`` (nx ny + 1), ``items``."""
    ncell = nx * ny
    count = np.zeros(ncell + 1, dtype=np.int64)
    buf = np.zeros(64, dtype=np.int64)
    for s in range(a.shape[0]):
        k = _segment_cells(a[s, 0], a[s, 1], b[s, 0], b[s, 1], origin, cell, nx, ny, buf)
        if k > buf.shape[0]:
            buf = np.zeros(2 * k, dtype=np.int64)
            k = _segment_cells(a[s, 0], a[s, 1], b[s, 0], b[s, 1], origin, cell, nx, ny, buf)
        for m in range(k):
            count[buf[m] + 1] += 1
    start = np.cumsum(count)
    items = np.zeros(start[-1], dtype=np.int64)
    fill = start[:-1].copy()
    for s in range(a.shape[0]):
        k = _segment_cells(a[s, 0], a[s, 1], b[s, 0], b[s, 1], origin, cell, nx, ny, buf)
        for m in range(k):
            items[fill[buf[m]]] = s
            fill[buf[m]] += 1
    return start, items


@njit
def pip_status(a: np.ndarray, b: np.ndarray, origin: np.ndarray, cell: float, nx: int, ny: int) -> np.ndarray:
    """Whether each cell's reference point is inside the polygon with edges ``a -> b``, (nx ny,) bool.

    A scanline per row of cells (the half-open rule ``(ya > y) != (yb > y)``), edges bucketed by
    the rows their y-range covers.
    """
    status = np.zeros(nx * ny, dtype=np.bool_)
    ne = a.shape[0]
    count = np.zeros(ny + 1, dtype=np.int64)
    for s in range(ne):
        r0, r1 = _cell_span(a[s, 1], b[s, 1], origin[1], cell, ny)
        for j in range(r0, r1 + 1):
            count[j + 1] += 1
    start = np.cumsum(count)
    items = np.zeros(start[-1], dtype=np.int64)
    fill = start[:-1].copy()
    for s in range(ne):
        r0, r1 = _cell_span(a[s, 1], b[s, 1], origin[1], cell, ny)
        for j in range(r0, r1 + 1):
            items[fill[j]] = s
            fill[j] += 1
    xs = np.zeros(max(ne, 1))
    for j in range(ny):
        y = origin[1] + (j + _REF_Y) * cell
        m = 0
        for p in range(start[j], start[j + 1]):
            s = items[p]
            if (a[s, 1] > y) != (b[s, 1] > y):
                xs[m] = a[s, 0] + (y - a[s, 1]) * (b[s, 0] - a[s, 0]) / (b[s, 1] - a[s, 1])
                m += 1
        for p in range(1, m):  # insertion sort (a row crosses few edges; np.sort compiles slowly)
            v = xs[p]
            q = p - 1
            while q >= 0 and xs[q] > v:
                xs[q + 1] = xs[q]
                q -= 1
            xs[q + 1] = v
        p = 0
        for i in range(nx):
            x = origin[0] + (i + _REF_X) * cell
            while p < m and xs[p] < x:
                p += 1
            status[i * ny + j] = p % 2 == 1
    return status


# ----------------------------------------------------------------------------------------------
# occupancy grid
# ----------------------------------------------------------------------------------------------


@njit_inline
def _gidx(g: GridData, x: float, y: float) -> int:
    """Flat cell of a point, clamped two cells inside the grid's edge (as ``Occupancy._index``)."""
    fx = min(max(np.floor((x - g.origin[0]) / g.cell), 2.0), g.hi[0])
    fy = min(max(np.floor((y - g.origin[1]) / g.cell), 2.0), g.hi[1])
    return int(fx) * g.ny + int(fy)


@njit
def _nsamples(g: GridData, a: np.ndarray, b: np.ndarray) -> int:
    """Count the samples per segment: every half cell along the longest of the segments ``a -> b``."""
    m = 0.0
    for i in range(a.shape[0]):
        dx = b[i, 0] - a[i, 0]
        dy = b[i, 1] - a[i, 1]
        m = max(m, dx * dx + dy * dy)
    return max(2, int(np.ceil(2.0 * np.sqrt(m) / g.cell)) + 1)


@njit
def grid_free_for(g: GridData, p: np.ndarray, pid: np.ndarray) -> np.ndarray:
    """Whether each point's cell is empty or owned by the given path, (n,) bool."""
    out = np.zeros(p.shape[0], dtype=np.bool_)
    for i in range(p.shape[0]):
        o = g.owner[_gidx(g, p[i, 0], p[i, 1])]
        out[i] = o < 0 or o == pid[i]
    return out


@njit
def grid_cells(g: GridData, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cells and sample points along segments ``a -> b``: (n, k) flat indices, (n, k, 2) mm."""
    n = a.shape[0]
    k = _nsamples(g, a, b)
    step = 1.0 / (k - 1)
    idx = np.zeros((n, k), dtype=np.int64)
    pts = np.zeros((n, k, 2))
    for i in range(n):
        dx = b[i, 0] - a[i, 0]
        dy = b[i, 1] - a[i, 1]
        for s in range(k):
            f = s * step if s < k - 1 else 1.0
            x = a[i, 0] + f * dx
            y = a[i, 1] + f * dy
            pts[i, s, 0] = x
            pts[i, s, 1] = y
            idx[i, s] = _gidx(g, x, y)
    return idx, pts


@njit
def grid_free_cells(g: GridData, idx: np.ndarray, pid: np.ndarray) -> np.ndarray:
    """Whether all cells of each row of ``idx`` are empty or the row's path's, (n,) bool."""
    out = np.ones(idx.shape[0], dtype=np.bool_)
    for i in range(idx.shape[0]):
        for s in range(idx.shape[1]):
            o = g.owner[idx[i, s]]
            if o >= 0 and o != pid[i]:
                out[i] = False
                break
    return out


@njit
def grid_free_path(g: GridData, a: np.ndarray, b: np.ndarray, pid: np.ndarray) -> np.ndarray:
    """Whether every cell along segments ``a -> b`` is empty or the given path's, (n,) bool."""
    if a.shape[0] == 0:
        return np.zeros(0, dtype=np.bool_)
    idx, _ = grid_cells(g, a, b)
    return grid_free_cells(g, idx, pid)


@njit
def grid_mark_cells(g: GridData, idx: np.ndarray, pts: np.ndarray, pid: np.ndarray) -> None:
    """Give the cells of :func:`grid_cells` to their paths (later rows win a shared cell)."""
    for i in range(idx.shape[0]):
        for s in range(idx.shape[1]):
            c = idx[i, s]
            g.owner[c] = pid[i]
            g.point[c, 0] = pts[i, s, 0]
            g.point[c, 1] = pts[i, s, 1]


@njit
def grid_mark(g: GridData, a: np.ndarray, b: np.ndarray, pid: np.ndarray) -> None:
    """Give the cells along segments ``a -> b`` to their paths."""
    if a.shape[0] == 0:
        return
    idx, pts = grid_cells(g, a, b)
    grid_mark_cells(g, idx, pts, pid)


@njit
def grid_clear_of(g: GridData, p: np.ndarray, pid: np.ndarray, radius: float) -> np.ndarray:
    """Whether no trail sample of another path lies within ``radius`` of each point, (n,) bool."""
    out = np.ones(p.shape[0], dtype=np.bool_)
    r2 = radius * radius
    for i in range(p.shape[0]):
        base = _gidx(g, p[i, 0], p[i, 1])
        for r in range(g.ring.shape[0]):
            c = base + g.ring[r]
            o = g.owner[c]
            if o >= 0 and o != pid[i]:
                dx = g.point[c, 0] - p[i, 0]
                dy = g.point[c, 1] - p[i, 1]
                if dx * dx + dy * dy < r2:
                    out[i] = False
                    break
    return out


# ----------------------------------------------------------------------------------------------
# domain
# ----------------------------------------------------------------------------------------------


@njit_inline
def _inside1(d: DomainData, px: float, py: float) -> bool:
    cell = d.ip_cell
    fi = np.floor((px - d.ip_origin[0]) / cell)
    fj = np.floor((py - d.ip_origin[1]) / cell)
    if not (fi >= 0 and fj >= 0 and fi < d.ip_nx and fj < d.ip_ny):
        return False
    c = int(fi) * d.ip_ny + int(fj)
    state = d.ip_status[c]
    rx = d.ip_origin[0] + (fi + _REF_X) * cell
    ry = d.ip_origin[1] + (fj + _REF_Y) * cell
    dx = rx - px
    dy = ry - py
    for m in range(d.ip_start[c], d.ip_start[c + 1]):
        s = d.ip_items[m]
        ax = d.in_a[s, 0] - px
        ay = d.in_a[s, 1] - py
        bx = d.in_b[s, 0] - px
        by = d.in_b[s, 1] - py
        sa = dx * ay - dy * ax
        sb = dx * by - dy * bx
        if (sa > 0.0) == (sb > 0.0):
            continue
        ex = bx - ax
        ey = by - ay
        t = (ax * ey - ay * ex) / (dx * ey - dy * ex)
        if t >= 0.0 and t <= 1.0:
            state = not state
    return state


@njit
def inside(d: DomainData, p: np.ndarray) -> np.ndarray:
    """Points at least the margin inside the domain (inside its inner region), (n,) bool."""
    out = np.zeros(p.shape[0], dtype=np.bool_)
    for i in range(p.shape[0]):
        out[i] = _inside1(d, p[i, 0], p[i, 1])
    return out


@njit
def ray(
    d: DomainData, o: np.ndarray, u: np.ndarray, max_dist: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """First boundary crossing along rays ``o + s u``, ``0 < s <= max_dist`` (see ``Domain.ray``).

    Returns dist (m,) (inf: none), point (m, 2), tangent (m, 2) (NaN: none), segment (m,) (-1: none).
    """
    m = o.shape[0]
    dist = np.full(m, np.inf)
    point = np.full((m, 2), np.nan)
    tangent = np.full((m, 2), np.nan)
    seg = np.full(m, -1, dtype=np.int64)
    half = 0.5 * max_dist
    for q in range(m):
        ox, oy = o[q, 0], o[q, 1]
        dx, dy = u[q, 0], u[q, 1]
        cx = ox + half * dx
        cy = oy + half * dy
        i0, i1 = _cell_span(cx - half, cx + half, d.sg_origin[0], d.sg_cell, d.sg_nx)
        j0, j1 = _cell_span(cy - half, cy + half, d.sg_origin[1], d.sg_cell, d.sg_ny)
        best = np.inf
        bs = -1
        for i in range(i0, i1 + 1):
            for j in range(j0, j1 + 1):
                c = i * d.sg_ny + j
                for k in range(d.sg_start[c], d.sg_start[c + 1]):
                    s = d.sg_items[k]
                    ax, ay = d.seg_a[s, 0], d.seg_a[s, 1]
                    ex = d.seg_b[s, 0] - ax
                    ey = d.seg_b[s, 1] - ay
                    wx = ax - ox
                    wy = ay - oy
                    den = dx * ey - dy * ex
                    if not abs(den) > 1e-15:
                        continue
                    sr = (wx * ey - wy * ex) / den  # along the ray
                    r = (wx * dy - wy * dx) / den  # along the segment
                    if sr > 0 and sr <= max_dist and r >= 0 and r <= 1:
                        if sr < best or (sr == best and s < bs):
                            best = sr
                            bs = s
        if bs >= 0:
            dist[q] = best
            seg[q] = bs
            point[q, 0] = ox + best * dx
            point[q, 1] = oy + best * dy
            tangent[q, 0] = d.seg_dir[bs, 0]
            tangent[q, 1] = d.seg_dir[bs, 1]
    return dist, point, tangent, seg


@njit
def project_local(d: DomainData, p: np.ndarray, segment: np.ndarray, reach: int) -> np.ndarray:
    """Nearest boundary point within ``reach`` segments of a known segment along its ring, (m, 2)."""
    m = p.shape[0]
    out = np.zeros((m, 2))
    for q in range(m):
        s0 = segment[q]
        rs = d.ring_start[s0]
        rl = d.ring_len[s0]
        best = np.inf
        for k in range(-reach, reach + 1):
            c = rs + (s0 - rs + k) % rl
            ax, ay = d.seg_a[c, 0], d.seg_a[c, 1]
            ex = d.seg_b[c, 0] - ax
            ey = d.seg_b[c, 1] - ay
            t = ((p[q, 0] - ax) * ex + (p[q, 1] - ay) * ey) / (ex * ex + ey * ey)
            t = min(max(t, 0.0), 1.0)
            x = ax + t * ex
            y = ay + t * ey
            dd = (x - p[q, 0]) ** 2 + (y - p[q, 1]) ** 2
            if dd < best:
                best = dd
                out[q, 0] = x
                out[q, 1] = y
    return out


@njit_inline
def _orient(ax: float, ay: float, bx: float, by: float, cx: float, cy: float) -> float:
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


@njit_inline
def _on_segment(ax: float, ay: float, bx: float, by: float, px: float, py: float) -> bool:
    return min(ax, bx) <= px <= max(ax, bx) and min(ay, by) <= py <= max(ay, by)


@njit_inline
def _segments_meet(
    ax: float, ay: float, bx: float, by: float, cx: float, cy: float, dx: float, dy: float
) -> bool:
    """Whether closed segments ``a b`` and ``c d`` share a point."""
    d1 = _orient(cx, cy, dx, dy, ax, ay)
    d2 = _orient(cx, cy, dx, dy, bx, by)
    d3 = _orient(ax, ay, bx, by, cx, cy)
    d4 = _orient(ax, ay, bx, by, dx, dy)
    if ((d1 > 0 and d2 < 0) or (d1 < 0 and d2 > 0)) and ((d3 > 0 and d4 < 0) or (d3 < 0 and d4 > 0)):
        return True
    if d1 == 0 and _on_segment(cx, cy, dx, dy, ax, ay):
        return True
    if d2 == 0 and _on_segment(cx, cy, dx, dy, bx, by):
        return True
    if d3 == 0 and _on_segment(ax, ay, bx, by, cx, cy):
        return True
    return d4 == 0 and _on_segment(ax, ay, bx, by, dx, dy)


@njit
def crosses(d: DomainData, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Whether segments ``a -> b`` touch or cross the boundary, (m,) bool."""
    m = a.shape[0]
    out = np.zeros(m, dtype=np.bool_)
    for q in range(m):
        i0, i1 = _cell_span(a[q, 0], b[q, 0], d.sg_origin[0], d.sg_cell, d.sg_nx)
        j0, j1 = _cell_span(a[q, 1], b[q, 1], d.sg_origin[1], d.sg_cell, d.sg_ny)
        for i in range(i0, i1 + 1):
            for j in range(j0, j1 + 1):
                c = i * d.sg_ny + j
                for k in range(d.sg_start[c], d.sg_start[c + 1]):
                    s = d.sg_items[k]
                    if _segments_meet(
                        a[q, 0],
                        a[q, 1],
                        b[q, 0],
                        b[q, 1],
                        d.seg_a[s, 0],
                        d.seg_a[s, 1],
                        d.seg_b[s, 0],
                        d.seg_b[s, 1],
                    ):
                        out[q] = True
                        break
                if out[q]:
                    break
            if out[q]:
                break
    return out


# ----------------------------------------------------------------------------------------------
# stress raster
# ----------------------------------------------------------------------------------------------


@njit
def raster_sample(r: RasterData, p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Followed principal direction (sign arbitrary), virtual mass and validity at points.

    Bilinear interpolation of the tensor, closed-form decomposition (see ``FieldRaster.sample``).
    """
    n = p.shape[0]
    direction = np.zeros((n, 2))
    mass = np.zeros(n)
    valid = np.zeros(n, dtype=np.bool_)
    T = r.tensor
    ny = r.ny
    for q in range(n):
        fx = (p[q, 0] - r.origin[0]) / r.cell
        fy = (p[q, 1] - r.origin[1]) / r.cell
        ix = min(max(np.floor(fx), 0.0), r.imax[0])
        iy = min(max(np.floor(fy), 0.0), r.imax[1])
        wx = min(max(fx - ix, 0.0), 1.0)
        wy = min(max(fy - iy, 0.0), 1.0)
        k = int(ix * ny + iy)
        t = np.zeros(3)
        for c in range(3):
            a = T[k, c] + wy * (T[k + 1, c] - T[k, c])
            b = T[k + ny, c] + wy * (T[k + ny + 1, c] - T[k + ny, c])
            t[c] = a + wx * (b - a)
        sxx, syy, sxy = t[0], t[1], t[2]
        cc = 0.5 * (sxx + syy)
        rr = np.hypot(0.5 * (sxx - syy), sxy)
        theta = 0.5 * np.arctan2(2.0 * sxy, sxx - syy)
        if r.principal == 0:
            first = True
        elif r.principal == 1:
            first = False
        elif r.principal == 2:
            first = abs(cc + rr) >= abs(cc - rr)
        else:
            first = abs(cc + rr) < abs(cc - rr)
        if not first:
            theta = theta + 0.5 * np.pi
        sigma = cc + rr if first else cc - rr
        direction[q, 0] = np.cos(theta)
        direction[q, 1] = np.sin(theta)
        mass[q] = min(abs(sigma) / r.scale, 1.0)
        valid[q] = 2.0 * rr > r.aniso_min
    return direction, mass, valid
