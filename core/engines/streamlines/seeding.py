"""Where streamlines start.

Faithful mode (thesis Sec. 4.2, Table 4.3)
    Seeds at the finite-element centroids when the caller passes them, otherwise a hexagonal lattice
    with the thesis's seed density (0.2 per mm² by default; the thesis placed seeds "throughout the
    infill domain" without any informed choice, Sec. 4.2.4).

Default mode, first round (beyond the thesis)
    Every principal-stress trajectory ends on the boundary, so it can be started there.  Seeds lie
    on the region's boundary offset inwards by half a pitch, spaced so that the streamlines they
    start are one pitch apart *across the field*: along the offset curve, a seed every
    ``pitch / |sin(phi)|`` where ``phi`` is the angle between the field and the curve, and at least
    every ``boundary_seed_gap`` where the field runs along the boundary (the trajectory that hugs
    that boundary at half a pitch).  Where the field meets the boundary square on, this is the
    slicer's own rectilinear spacing.

Default mode, gap rounds
    :func:`gap_seeds`: raster cells at least ``fill_spacing`` from every path (the empty circles of
    Mebarki et al. 2005 / thesis Eq. 4.6, found with a distance transform instead of a Delaunay
    triangulation), largest first, each suppressing the others along its future streamline so
    that one round does not seed the same corridor many times.
"""

from __future__ import annotations

import numpy as np
import shapely
from loadpath._typing import Bools, Floats, Points2, Region
from loadpath.engines.streamlines._lines import cross2
from loadpath.engines.streamlines.directions import DirectionGrid
from scipy.spatial import cKDTree

__all__ = ["lattice", "boundary_seeds", "gap_seeds", "rings", "sample_ring"]


def lattice(region: Region, spacing: float) -> Points2:
    """Hexagonal lattice points inside the region.

    Parameters
    ----------
    region : Polygon or MultiPolygon, mm
    spacing : float, mm
        Distance between neighbouring points (density ``2 / (sqrt(3) spacing²)``).

    Returns
    -------
    (n, 2) float, mm
    """
    x0, y0, x1, y1 = region.bounds
    dy = spacing * np.sqrt(3.0) / 2.0
    ys = np.arange(y0 + 0.5 * dy, y1, dy)
    xs = np.arange(x0 + 0.25 * spacing, x1, spacing)
    gx, gy = np.meshgrid(xs, ys)
    gx = gx + 0.5 * spacing * (np.arange(len(ys)) % 2)[:, None]
    fx, fy = gx.ravel(), gy.ravel()
    inside = shapely.contains_xy(region, fx, fy)
    return np.stack([fx[inside], fy[inside]], axis=1)


def rings(region: Region) -> list[Points2]:
    """All boundary loops (exteriors and holes) of a polygon or multipolygon, as closed arrays."""
    out = []
    for poly in shapely.get_parts(region):
        if poly.is_empty or poly.geom_type != "Polygon":
            continue
        out.append(np.asarray(poly.exterior.coords))
        out.extend(np.asarray(r.coords) for r in poly.interiors)
    return out


def sample_ring(ring: Points2, ds: float) -> tuple[Points2, Points2, Floats]:
    """Points every ``ds`` mm along a closed ring, with unit tangents and arc positions.

    Returns
    -------
    points : (n, 2) float, mm
    tangents : (n, 2) float
    s : (n,) float, mm
    """
    seg = np.diff(ring, axis=0)
    ln = np.linalg.norm(seg, axis=1)
    keep = ln > 0
    seg, ln, start = seg[keep], ln[keep], ring[:-1][keep]
    if len(ln) == 0:
        return np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0)
    cum = np.concatenate([[0.0], np.cumsum(ln)])
    s = np.arange(0.0, cum[-1], ds)
    k = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(ln) - 1)
    t = (s - cum[k]) / ln[k]
    return start[k] + t[:, None] * seg[k], seg[k] / ln[k][:, None], s


def boundary_seeds(
    region: Region, grid: DirectionGrid, pitch: float, max_gap: float, phase: float = 0.0
) -> tuple[Points2, Bools]:
    """Seeds on the boundary offset inwards by half a pitch, one pitch apart across the field.

    With ``phase`` every seed moves on along the curve by that many pitches (counted across the
    field, as the spacing is): phase 0.5 starts each streamline between two of phase 0, which is
    how a staggered copy of a layer is laid.  The seed phase 0 puts on each corner of the curve
    moves on with the others.

    Most trajectories cross the boundary twice, so they get two seeds.  To trace each once, the
    seeds are split by an orientation of the field: with ``u`` the field's dominant direction and
    ``v = sign(d . u) d`` at each seed, a seed where ``v`` points into the region is an *entry*,
    where it points out an *exit*.  Following a trajectory along ``v`` it enters once and leaves
    once, as long as it stays within 60 degrees of ``u``; seeds whose direction is further from
    ``u`` are ambiguous and go with the entries.

    Parameters
    ----------
    region : Polygon or MultiPolygon, mm
    grid : DirectionGrid
    pitch : float, mm
    max_gap : float, mm
        Largest distance between consecutive seeds along the offset curve.
    phase : float, pitches
        Shift of the seeds along the curve (only its fractional part counts).

    Returns
    -------
    seeds : (n, 2) float, mm
        In ring order (outer boundaries first, then holes, island after island).
    entry : (n,) bool
        Entry (or ambiguous) seeds, to be traced first.
    """
    inner = region.buffer(-0.5 * pitch, join_style="mitre", mitre_limit=2.0)
    out, flags = [], []
    ds = 0.25 * pitch
    shift = float(phase) % 1.0
    u = grid.dominant()
    for ring in rings(inner):
        pts, tan, _ = sample_ring(ring, ds)
        if len(pts) == 0:
            continue
        d, ok = grid(pts)
        sin_phi = np.abs(cross2(tan, d))
        density = np.where(ok, np.maximum(sin_phi / pitch, 1.0 / max_gap), 1.0 / max_gap)
        # count the streamlines crossing the curve; the count restarts at every corner of the
        # curve, where a seed sits (a rectangle's first line is then half a pitch from the side)
        turn = np.abs(cross2(np.roll(tan, 1, axis=0), tan)) > np.sin(np.radians(30.0))
        turn |= np.sum(np.roll(tan, 1, axis=0) * tan, axis=1) < 0
        run = np.cumsum(turn)
        count = np.cumsum(density * ds)
        base = np.zeros(run.max() + 1)
        starts = np.flatnonzero(np.concatenate([[True], run[1:] != run[:-1]]))
        base[run[starts]] = count[starts] - density[starts] * ds
        local = count - base[run] - density * ds  # 0 at the first sample of each run
        marks = np.floor(local - shift + 1e-9)
        first = np.concatenate([[True], (np.diff(marks) > 0) | (run[1:] != run[:-1])])
        if shift:
            # a run's first sample (local 0) lies before the run's first shifted seed at local = shift
            first &= marks >= 0
        sel = first & ok
        p, t, dd = pts[sel], tan[sel], d[sel]
        nrm = np.stack([-t[:, 1], t[:, 0]], axis=1)
        probe = p + 0.25 * pitch * nrm
        inward = shapely.contains_xy(inner, probe[:, 0], probe[:, 1])
        nrm = np.where(inward[:, None], nrm, -nrm)
        du = dd @ u
        v = dd * np.where(du < 0, -1.0, 1.0)[:, None]
        entry = (np.sum(v * nrm, axis=1) >= 0) | (np.abs(du) < 0.5)
        out.append(p)
        flags.append(entry)
    if not out:
        return np.zeros((0, 2)), np.zeros(0, dtype=bool)
    seeds = np.concatenate(out)
    entry = np.concatenate(flags)
    keep = grid.inside(seeds)
    return seeds[keep], entry[keep]


def gap_seeds(
    points: Points2, clearance: Floats, directions: Points2, along: float, across: float
) -> np.ndarray:
    """Pick the lattice points that start this round's gap-filling streamlines.

    Greedy, largest empty circle first (Mebarki et al. 2005, thesis Eq. 4.6): each chosen seed
    suppresses the candidates its streamline will pass, those within ``along`` of it along the
    field and ``across`` across it, so a long corridor between two paths gets one seed instead of
    one per lattice point.

    Parameters
    ----------
    points : (n, 2) float, mm
        Candidate points (each already at least the fill spacing from every path).
    clearance : (n,) float, mm
        Distance of each candidate to the nearest path or boundary (its empty circle's radius).
    directions : (n, 2) float
        Unit field direction at each candidate.
    along, across : float, mm

    Returns
    -------
    (k,) int
        Indices into ``points``, largest clearance first.
    """
    n = len(points)
    if n == 0:
        return np.zeros(0, dtype=np.int64)
    order = np.lexsort((np.arange(n), -clearance))
    alive = np.ones(n, dtype=bool)
    tree = cKDTree(points)
    chosen = []
    for i in order:
        if not alive[i]:
            continue
        chosen.append(i)
        nb = np.asarray(tree.query_ball_point(points[i], along), dtype=np.int64)
        rel = points[nb] - points[i]
        off = np.abs(cross2(rel, directions[i][None, :]))
        alive[nb[off < across]] = False
    return np.asarray(chosen, dtype=np.int64)
