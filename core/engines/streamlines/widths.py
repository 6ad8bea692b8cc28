"""Variable bead width: every bead fills its own cell between its neighbours.

Beyond the thesis (its Sec. 4.3 and Ch. 5 name variable-width filaments as the cure for its 87-90 %
coverage).  At each vertex the distance to the nearest other path is measured on the left (``a``)
and on the right (``b``); the region boundary counts double (``2 e``), because one bead alone must
reach it.  The vertex's *cell* is the strip from half-way to the left neighbour to half-way to the
right neighbour, ``[-a/2, +b/2]`` across the path: neighbouring cells meet exactly, so the beads
tile.  The bead is that cell: width ``(a + b) / 2`` (the local pitch written for the splicer) and
centre line moved across by ``(b - a) / 4``.  A bead only as wide as the mean of its two gaps but
left on the streamline would leave a strip uncovered beside the wider gap and overlap beside the
narrower one; with paths placed by independent seeds, neighbouring gaps of 0.45 and 0.65 mm are
common, and those strips cost several percent of coverage.

The move is at most a quarter of the larger gap (0.16 mm at the widest bead of a 0.4 mm nozzle),
smoothed along the path, and never puts two paths closer than ``min_spacing``: the centres of two
neighbouring cells are ``(2 b + a + c) / 4 >= min(a, b, c)`` apart, and any vertex that would still
violate the spacing (path ends, corners), or leave the region, keeps its streamline position.
Widths are clamped to ``[width_min, width_max]``, what the nozzle can print; a side with nothing
within ``width_max`` counts as ``width_max``.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from loadpath._typing import Bools, Floats, Points2, Region
from loadpath.engines.streamlines._lines import Lines
from loadpath.engines.streamlines.density import conflicts
from loadpath.engines.streamlines.seeding import rings, sample_ring
from scipy.spatial import cKDTree

__all__ = ["tile", "side_distances"]



def _normals(lines: Lines) -> Points2:
    p = lines.points
    n = len(p)
    vl = lines.vertex_line
    ar = np.arange(n)
    nxt = np.where(vl[np.minimum(ar + 1, n - 1)] == vl, np.minimum(ar + 1, n - 1), ar)
    prv = np.where(vl[np.maximum(ar - 1, 0)] == vl, np.maximum(ar - 1, 0), ar)
    t = p[nxt] - p[prv]
    ln = np.linalg.norm(t, axis=1)
    t = t / np.where(ln > 0, ln, 1.0)[:, None]
    return np.stack([-t[:, 1], t[:, 0]], axis=1)  # left normal


def side_distances(lines: Lines, region: Region, reach: float) -> tuple[Floats, Floats]:
    """Distance from every vertex to the nearest other path on its left and on its right.

    The region boundary counts as twice its distance.  Sides with nothing within ``reach``
    get ``inf``.

    Parameters
    ----------
    lines : Lines
    region : Polygon or MultiPolygon, mm
    reach : float, mm

    Returns
    -------
    left, right : (N,) float, mm
    """
    p = lines.points
    n = len(p)
    start, owner = lines.segments()
    a = [p[start]]
    b = [p[start + 1]]
    own = [owner]
    seg_max = float(np.max(np.linalg.norm(p[start + 1] - p[start], axis=1))) if len(start) else reach
    for r in rings(region):
        rp = sample_ring(r, seg_max)[0]  # short boundary segments keep the search radius small
        if len(rp) < 2:
            continue
        rp = np.concatenate([rp, rp[:1]])
        a.append(rp[:-1])
        b.append(rp[1:])
        own.append(np.full(len(rp) - 1, -1))
    A = np.concatenate(a)
    B = np.concatenate(b)
    own_all = np.concatenate(own)
    left = np.full(n, np.inf)
    right = np.full(n, np.inf)
    if len(A) == 0 or n == 0:
        return left, right
    mid = 0.5 * (A + B)
    half = 0.5 * float(np.max(np.linalg.norm(B - A, axis=1)))
    sd = cKDTree(p).sparse_distance_matrix(cKDTree(mid), reach + half, output_type="ndarray")
    v = sd["i"].astype(np.int64)
    sg = sd["j"].astype(np.int64)
    vl = lines.vertex_line
    keep = own_all[sg] != vl[v]
    v, sg = v[keep], sg[keep]
    px, py = p[v, 0], p[v, 1]
    ax, ay = A[sg, 0], A[sg, 1]
    abx, aby = B[sg, 0] - ax, B[sg, 1] - ay
    den = abx * abx + aby * aby
    u = ((px - ax) * abx + (py - ay) * aby) / np.where(den > 0, den, 1.0)
    np.clip(u, 0.0, 1.0, out=u)
    rx = ax + u * abx - px
    ry = ay + u * aby - py
    d = np.hypot(rx, ry)
    d = np.where(own_all[sg] < 0, 2.0 * d, d)
    nrm = _normals(lines)
    side = rx * nrm[v, 0] + ry * nrm[v, 1]
    ok = d <= reach
    lf = ok & (side > 0)
    rt = ok & (side <= 0)
    np.minimum.at(left, v[lf], d[lf])
    np.minimum.at(right, v[rt], d[rt])
    return left, right


def _smooth(values: Floats, lines: Lines, passes: int = 1) -> Floats:
    n = len(values)
    vl = lines.vertex_line
    ar = np.arange(n)
    nxt = np.where(vl[np.minimum(ar + 1, n - 1)] == vl, np.minimum(ar + 1, n - 1), ar)
    prv = np.where(vl[np.maximum(ar - 1, 0)] == vl, np.maximum(ar - 1, 0), ar)
    for _ in range(passes):
        values = 0.25 * values[prv] + 0.5 * values + 0.25 * values[nxt]
    return values


def tile(
    lines: Lines,
    region: Region,
    width_min: float,
    width_max: float,
    min_spacing: float,
    inside: Callable[[Points2], Bools],
    max_turn_deg: float = 180.0,
) -> tuple[Lines, Floats]:
    """Bead cells: moved centre lines and local pitch (module docstring).

    Parameters
    ----------
    lines : Lines
    region : Polygon or MultiPolygon, mm
    width_min, width_max : float, mm
    min_spacing : float, mm
    inside : callable
        ``inside(points (n, 2)) -> (n,) bool``.
    max_turn_deg : float, degrees
        A vertex whose move would turn the path by more than this (or more than it already
        turns) keeps its streamline position.

    Returns
    -------
    lines : Lines
        Same vertex count, centre lines moved into their cells.
    pitch : (N,) float, mm
        Local pitch (bead width) per vertex.
    """
    n = len(lines.points)
    if n == 0:
        return lines, np.zeros(0)
    left, right = side_distances(lines, region, width_max)
    a = np.minimum(left, width_max)
    b = np.minimum(right, width_max)
    width = np.clip(_smooth(0.5 * (a + b), lines), width_min, width_max)
    shift = _smooth(0.25 * (a - b), lines)  # along the left normal: towards the wider side
    nrm = _normals(lines)
    moved = lines.points + shift[:, None] * nrm
    ok = inside(moved)
    pts = np.where(ok[:, None], moved, lines.points)
    limit = np.maximum(_turns(lines.points, lines), np.radians(max_turn_deg))
    for _ in range(4):
        sharp = _turns(pts, lines) > limit + 1e-9
        if not np.any(sharp):
            break
        vl = lines.vertex_line
        spread = sharp.copy()
        spread[:-1] |= sharp[1:] & (vl[:-1] == vl[1:])
        spread[1:] |= sharp[:-1] & (vl[1:] == vl[:-1])
        pts = np.where(spread[:, None], lines.points, pts)
    else:
        sharp = _turns(pts, lines) > limit + 1e-9
        if np.any(sharp):
            involved = np.isin(lines.vertex_line, np.unique(lines.vertex_line[sharp]))
            pts = np.where(involved[:, None], lines.points, pts)
    out = Lines(pts, lines.offsets)
    # keep the spacing guarantee: vertices of segments that now violate it go back
    for _ in range(6):
        bad = _violating_vertices(out, min_spacing)
        if not np.any(bad):
            return out, width
        pts = np.where(bad[:, None], lines.points, pts)
        out = Lines(pts, lines.offsets)
    bad = _violating_vertices(out, min_spacing)
    if np.any(bad):  # give up moving the paths involved
        vl = lines.vertex_line
        involved = np.isin(vl, np.unique(vl[bad]))
        out = Lines(np.where(involved[:, None], lines.points, pts), lines.offsets)
        if np.any(_violating_vertices(out, min_spacing)):
            out = lines
    return out, width


def _turns(points: Points2, lines: Lines) -> Floats:
    """Return the turning angle at every vertex (0 at path ends, next to zero-length segments), rad."""
    n = len(points)
    vl = lines.vertex_line
    ar = np.arange(n)
    nxt = np.minimum(ar + 1, n - 1)
    prv = np.maximum(ar - 1, 0)
    interior = (vl[nxt] == vl) & (vl[prv] == vl) & (nxt != ar) & (prv != ar)
    a = points - points[prv]
    b = points[nxt] - points
    na = np.linalg.norm(a, axis=1)
    nb = np.linalg.norm(b, axis=1)
    good = interior & (na > 1e-12) & (nb > 1e-12)
    c = np.sum(a * b, axis=1) / np.where(good, na * nb, 1.0)
    return np.where(good, np.arccos(np.clip(c, -1.0, 1.0)), 0.0)


def _violating_vertices(lines: Lines, min_spacing: float) -> np.ndarray:
    """Vertices of segments that come closer than ``min_spacing`` to another path."""
    start, _ = lines.segments()
    bad = np.zeros(len(lines.points), dtype=bool)
    ca, _ = conflicts(lines, min_spacing * (1.0 - 1e-9))
    bad[start[ca]] = True
    bad[start[ca] + 1] = True
    return bad
