"""Filling the gaps left between the continuous filaments (thesis Sec. 4.1.2, Eq. 4.6, App. C).

Faithful mode, :func:`thesis_gap_fill` - one largest empty circle at a time
    Delaunay-triangulate the accepted filaments; seed a streamline at the centre of the largest
    circumcircle; trace it; remove the *new* streamline's vertices of triangles with a diameter below
    ``w + G_p`` (old filaments are never touched); what survives are discontinuous filaments; repeat.
    Settled on purpose:

    * Gap test: the text's Eq. 4.6, ``D >= 2 (w + G_p)`` (a gap that holds one more filament at the
      required spacing on both sides).  App. C's ``r_max > 0.5 w`` (``D > w``) would seed gaps where
      every point of the new streamline violates the spacing, which is exactly its endless loop.
    * The region boundary, sampled every ``d_L``, is in the triangulation (the thesis's boundary
      nodes), so empty circles stop at the boundary; triangles with a boundary vertex are not
      spacing tests (a streamline legitimately ends on the boundary), and circles whose centre is
      outside the region (inside a hole, across a notch) are never seeds - the thesis's convex-hull
      triangles across holes.
    * Termination: every circle tried is remembered and never seeded again (a seed whose streamline
      is removed entirely would otherwise bring back the same largest circle for ever), and the loop
      is bounded by ``max_fill_iterations``.

Default mode, :func:`fill_rounds` - many gaps per round
    Each round rasterises the accepted paths, finds with a distance transform every point at least
    ``fill_spacing`` from all paths (so wider than the widest bead can close) and at least half the
    minimum spacing inside the boundary, checks those distances exactly, seeds the largest empty
    circle of each ``10 pitch`` square, traces all seeds at once with the Jobard-Lefer stop against
    the accepted paths, and selects like the first round.  Termination: a seed that yields nothing
    marks its neighbourhood exhausted; every round therefore adds path length or exhausts raster
    cells, and the number of rounds is bounded by ``max_waves``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from loadpath._typing import Bools, Points2, Region
from loadpath.engines.streamlines._lines import Lines
from loadpath.engines.streamlines.density import Selected, circumcircles, select
from loadpath.engines.streamlines.directions import DirectionGrid
from loadpath.engines.streamlines.integrate import TraceSettings, trace
from loadpath.engines.streamlines.seeding import gap_seeds, rings, sample_ring
from loadpath.engines.streamlines.segindex import SegmentIndex
from scipy import ndimage
from scipy.spatial import Delaunay, QhullError, cKDTree

__all__ = ["Raster", "fill_rounds", "thesis_gap_fill"]


@dataclass
class Raster:
    """A square raster over a region: cell centres, inside mask and distance to the boundary.

    Parameters
    ----------
    region : Polygon or MultiPolygon, mm
    cell : float, mm
    """

    region: Region
    cell: float

    def __post_init__(self) -> None:
        x0, y0, x1, y1 = self.region.bounds
        c = self.cell
        self.x0, self.y0 = x0, y0
        self.nx = max(int(np.ceil((x1 - x0) / c)), 1)
        self.ny = max(int(np.ceil((y1 - y0) / c)), 1)
        xs = x0 + c * (np.arange(self.nx) + 0.5)
        ys = y0 + c * (np.arange(self.ny) + 0.5)
        gx, gy = np.meshgrid(xs, ys)
        self.centres = np.stack([gx.ravel(), gy.ravel()], axis=1)
        shapely.prepare(self.region)
        self.inside = shapely.contains_xy(self.region, gx, gy)
        # distance from each cell centre to the nearest outside cell centre, minus half a cell
        padded = np.pad(self.inside, 1, constant_values=False)
        self.boundary_distance = (ndimage.distance_transform_edt(padded)[1:-1, 1:-1] - 0.5) * c

    def mark(self, lines: Lines) -> np.ndarray:
        """Boolean raster of the cells the polylines pass through (sampled every half cell)."""
        marks = np.zeros((self.ny, self.nx), dtype=bool)
        start, _ = lines.segments()
        if len(start) == 0:
            return marks
        a = lines.points[start]
        b = lines.points[start + 1]
        n = np.maximum(np.ceil(np.linalg.norm(b - a, axis=1) / (0.5 * self.cell)).astype(np.int64), 1)
        seg = np.repeat(np.arange(len(a)), n + 1)
        first = np.repeat(np.cumsum(n + 1) - (n + 1), n + 1)
        t = (np.arange(len(seg)) - first) / n[seg]
        p = a[seg] + t[:, None] * (b[seg] - a[seg])
        ix = np.clip(((p[:, 0] - self.x0) / self.cell).astype(np.int64), 0, self.nx - 1)
        iy = np.clip(((p[:, 1] - self.y0) / self.cell).astype(np.int64), 0, self.ny - 1)
        marks[iy, ix] = True
        return marks

    def distance_to(self, lines: Lines) -> np.ndarray:
        """Approximate distance from each cell centre to the polylines, (ny, nx) mm.

        Error at most ``cell / sqrt(2)`` (marked cell centre vs sample point); inf if none.
        """
        marks = self.mark(lines)
        if not np.any(marks):
            return np.full(marks.shape, np.inf)
        return ndimage.distance_transform_edt(~marks) * self.cell


def fill_rounds(
    region: Region,
    grid: DirectionGrid,
    accepted: list[Selected],
    settings: TraceSettings,
    *,
    min_spacing: float,
    fill_spacing: float,
    min_length: float,
    seed_cell: float,
    seed_across: float,
    max_waves: int,
    raster: Raster,
) -> tuple[list[Selected], list[dict[str, float]]]:
    """Default-mode gap filling (module docstring).

    Seeds of a round: the gap cells (at least ``fill_spacing`` from every path), largest
    clearance first, each suppressing the cells within ``seed_cell`` along the field and
    ``seed_across`` across it (:func:`~.seeding.gap_seeds`).

    Parameters
    ----------
    region : Polygon or MultiPolygon, mm
    grid : DirectionGrid
    accepted : list of Selected
        What earlier rounds kept.
    settings : TraceSettings
        With ``clearance = min_spacing``.
    min_spacing, fill_spacing, min_length, seed_cell, seed_across : float, mm
    max_waves : int
    raster : Raster

    Returns
    -------
    added : list of Selected
        One per round that added something.
    rounds : list of dict
        Per round: candidate cells, seeds, traced lines, pieces kept, length kept (mm).
    """
    exhausted = np.zeros((raster.ny, raster.nx), dtype=bool)
    added: list[Selected] = []
    log: list[dict[str, float]] = []
    edge_clearance = 0.5 * min_spacing
    slack = raster.cell / np.sqrt(2.0)
    first = Lines.from_list([p for s in accepted for p in s.lines.to_list()])
    marks = raster.mark(first)
    total_length = float(np.sum(first.lengths())) if len(first) else 0.0
    for _ in range(max_waves):
        if np.any(marks):
            dist = ndimage.distance_transform_edt(~marks) * raster.cell
        else:
            dist = np.full(marks.shape, np.inf)
        cand = raster.inside & ~exhausted & (dist + slack >= fill_spacing)
        cand &= raster.boundary_distance >= edge_clearance
        flat = np.flatnonzero(cand.ravel())
        if len(flat) == 0:
            break
        current = Lines.from_list([p for s in accepted + added for p in s.lines.to_list()])
        index = SegmentIndex(current)
        pts = raster.centres[flat]
        # the raster distance is within [-cell/4 - slack, +slack] of the true one: only cells in
        # that band need the exact distance
        approx = dist.ravel()[flat]
        unsure = approx - 0.25 * raster.cell - slack < fill_spacing
        exact = approx.copy()
        exact[unsure] = index.point_distance(pts[unsure], 1.25 * fill_spacing)
        ok = exact >= fill_spacing
        # cells that are not gaps after all will never become gaps again (paths only get added)
        exhausted.ravel()[flat[~ok]] = True
        flat, pts, exact = flat[ok], pts[ok], exact[ok]
        if len(flat) == 0:
            break
        clearance = np.minimum(exact, raster.boundary_distance.ravel()[flat] + min_spacing)
        dirs, _ = grid(pts)
        pick = gap_seeds(pts, clearance, dirs, along=seed_cell, across=seed_across)
        seeds = pts[pick]
        traced = trace(seeds, grid, settings, obstacles=index, seed_clearance=fill_spacing)
        sel = select(traced, min_spacing, min_length, runs="seed")
        productive = np.zeros(len(seeds), dtype=bool)
        if len(sel.source):
            productive[traced.seed[sel.source]] = True
        # exhaust the neighbourhood of seeds that gave nothing
        dead = seeds[~productive]
        if len(dead):
            tree = cKDTree(pts)
            for hits in tree.query_ball_point(dead, fill_spacing):
                exhausted.ravel()[flat[np.asarray(hits, dtype=np.int64)]] = True
        kept = float(np.sum(sel.lines.lengths())) if len(sel.lines) else 0.0
        log.append(
            {
                "candidates": float(len(flat)),
                "seeds": float(len(seeds)),
                "traced": float(len(traced.lines)),
                "pieces": float(len(sel.lines)),
                "length_mm": kept,
            }
        )
        if len(sel.lines):
            added.append(sel)
            marks |= raster.mark(sel.lines)
        # diminishing returns: stop once a round adds less than 1 % of what is there
        if kept < 0.01 * total_length:
            break
        total_length += kept
    return added, log


def _boundary_points(region: Region, step: float) -> Points2:
    pts = [sample_ring(r, step)[0] for r in rings(region)]
    return np.concatenate(pts) if pts else np.zeros((0, 2))


def thesis_gap_fill(
    region: Region,
    grid: DirectionGrid,
    filaments: Lines,
    settings: TraceSettings,
    *,
    spacing: float,
    gap_diameter: float,
    max_iterations: int,
) -> tuple[list[Points2], dict[str, int]]:
    """Fill gaps as the thesis does, one largest empty circle per iteration (module docstring).

    Parameters
    ----------
    region : Polygon or MultiPolygon, mm
    grid : DirectionGrid
    filaments : Lines
        The continuous filaments.
    settings : TraceSettings
        The thesis's tracing (Euler, ``d_L``), without obstacles.
    spacing : float, mm
        ``w + G_p``.
    gap_diameter : float, mm
        Smallest circumcircle diameter worth a seed (Eq. 4.6: ``2 (w + G_p)``).
    max_iterations : int

    Returns
    -------
    pieces : list of (n_i, 2) arrays
        Discontinuous filaments.
    stats : dict
        ``iterations``, ``seeded`` (streamlines that kept at least one piece), ``stopped`` (why:
        ``"no gap"`` = 0, ``"iteration bound"`` = 1).
    """
    bpts = _boundary_points(region, settings.step)
    fil = filaments.points
    pts = np.concatenate([fil, bpts]) if len(bpts) else fil.copy()
    is_bnd = np.concatenate([np.zeros(len(fil), dtype=bool), np.ones(len(bpts), dtype=bool)])
    owner = np.concatenate([filaments.vertex_line, np.full(len(bpts), -1)])
    pieces: list[Points2] = []
    stats = {"iterations": 0, "seeded": 0, "stopped": 0}
    if len(pts) < 3:
        return pieces, stats
    tri = Delaunay(pts, incremental=True)
    tried: list[np.ndarray] = []
    next_owner = int(owner.max()) + 1 if len(owner) else 0
    for it in range(max_iterations):
        stats["iterations"] = it + 1
        s = tri.simplices
        allp = tri.points
        centre, r = circumcircles(allp[s[:, 0]], allp[s[:, 1]], allp[s[:, 2]])
        ci = np.flatnonzero(np.isfinite(r) & (2.0 * r >= gap_diameter))
        ci = ci[np.argsort(-r[ci], kind="stable")]
        tried_tree = cKDTree(np.asarray(tried)) if tried else None
        best = -1
        for k in range(0, len(ci), 64):  # largest circles first, until one is a valid seed
            chunk = ci[k : k + 64]
            ok = grid.inside(centre[chunk])
            if tried_tree is not None:
                dt, _ = tried_tree.query(centre[chunk], k=1)
                ok &= dt > settings.step
            if np.any(ok):
                best = int(chunk[np.argmax(ok)])
                break
        if best < 0:
            stats["stopped"] = 0
            break
        seed = centre[best]
        tried.append(seed)
        new = trace(seed[None, :], grid, settings).lines
        if len(new) == 0:
            continue
        npts = new.line(0)
        keep = _survivors(npts, allp[~is_bnd], spacing)
        runs = _runs_of(keep)
        survivors = []
        for a, b in runs:
            if b - a >= 2:
                pieces.append(npts[a:b])
                survivors.append(npts[a:b])
        if survivors:
            stats["seeded"] += 1
            add = np.concatenate(survivors)
            tri.add_points(add)
            is_bnd = np.concatenate([is_bnd, np.zeros(len(add), dtype=bool)])
            owner = np.concatenate([owner, np.full(len(add), next_owner)])
            next_owner += 1
    else:
        stats["stopped"] = 1
    tri.close()
    return pieces, stats


def _survivors(new: Points2, old: Points2, spacing: float) -> Bools:
    """Which vertices of a new streamline satisfy the spacing against the old filament points.

    Triangulates the new vertices with the old filament vertices within ``2 spacing`` (a triangle
    with circumradius ``r`` only involves points within ``2 r`` of its vertices; the boundary
    points are not filament points, as in App. C's ``XYT``); the new streamline's vertices of
    triangles touching it with ``D < spacing``, other than triangles made only of new vertices,
    violate.
    """
    if len(old) == 0:
        return np.ones(len(new), dtype=bool)
    tree = cKDTree(old)
    near = tree.query_ball_point(new, 2.0 * spacing, return_sorted=False)
    idx = np.unique(np.concatenate([np.asarray(x, dtype=np.int64) for x in near] + [np.zeros(0, np.int64)]))
    if len(idx) == 0:
        return np.ones(len(new), dtype=bool)
    pts = np.concatenate([new, old[idx]])
    is_new = np.concatenate([np.ones(len(new), dtype=bool), np.zeros(len(idx), dtype=bool)])
    try:
        s = Delaunay(pts).simplices
    except QhullError:  # degenerate input (all points on a line): no triangle, nothing violates
        return np.ones(len(new), dtype=bool)
    nw = is_new[s]
    s = s[np.any(nw, axis=1) & ~np.all(nw, axis=1)]
    _, r = circumcircles(pts[s[:, 0]], pts[s[:, 1]], pts[s[:, 2]])
    bad = s[2.0 * r < spacing]
    keep = np.ones(len(new), dtype=bool)
    v = bad[is_new[bad]]
    keep[v[v < len(new)]] = False
    return keep


def _runs_of(mask: Bools) -> list[tuple[int, int]]:
    padded = np.concatenate([[False], mask, [False]])
    edges = np.flatnonzero(np.diff(padded.astype(np.int8)))
    return list(zip(edges[0::2].tolist(), edges[1::2].tolist(), strict=True))
