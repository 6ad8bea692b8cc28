"""Gap fill: a short straight bead in each void left where path ends meet.

Where two fronts meet (a seam behind a hole, the neutral axis of a bent bracket where the followed
stress turns by 90 degrees, a swarm killed between converging neighbours) the paths end, and the
beads' square ends leave voids a pitch or so across that no swarm can enter and that
:mod:`.ends` cannot reach without covering a neighbour.  A void costs stiffness in proportion to
its area, and volume matching cannot refill it (it thins or thickens every bead alike).

:func:`gap_fill` finds the voids next to path ends (beads square at their ends, of each point's
flow width) and lays one straight bead in each void of at least ``min_area`` pitch²: through the
void's deepest point, along the followed stress there or along the void's long axis, whichever
covers more of the void and less outside it; its width is the void's area over the line's length
(within ``[min_width, cap]`` pitches).  A gap bead keeps the engines' rule: its centre line stays
``min_gap`` pitches from every other path (it is trimmed to the longest piece that does, and
dropped if that is shorter than ``min_length`` pitches).

Only the neighbourhood of path ends is searched (``window`` pitches around each end), and the
beads there are drawn as ribbons of a few segments each (:func:`_ribbons`), so the cost grows with
the number of ends, not with the layer's size.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import shapely
from loadpath._typing import Floats, Points2, Region
from loadpath.engines.swarm.widths import _tangents
from scipy.spatial import cKDTree

__all__ = ["gap_fill"]

_CHUNK = 4
"""Segments per ribbon piece (:func:`_ribbons`)."""

_MARGIN = 0.01
"""Added to ``min_gap``, in pitches: the other paths are sampled every tenth of a pitch."""


def _densify(pts: Points2, seg: np.ndarray, step: float) -> Points2:
    """Points at most ``step`` apart along the segments ``pts[seg] -> pts[seg + 1]`` (ends included)."""
    ln = np.hypot(*(pts[seg + 1] - pts[seg]).T)
    n = np.maximum(1, np.ceil(ln / step).astype(np.int64))
    rep = np.repeat(seg, n)
    frac = (np.arange(len(rep)) - np.repeat(np.cumsum(n) - n, n)) / np.repeat(n, n)
    return np.vstack([pts[rep] + frac[:, None] * (pts[rep + 1] - pts[rep]), pts[seg + 1]])


def _ribbons(pts: Points2, w: Floats, counts: np.ndarray, near: Points2, reach: float) -> Region:
    """Union of the beads near the points ``near``, as ribbons: centre line offset by half the width.

    Each path is cut into chunks of :data:`_CHUNK` segments (neighbouring chunks share a vertex,
    so their ribbons meet edge to edge); a chunk is kept when one of its vertices is within
    ``reach`` of a point of ``near``.  One polygon per chunk instead of a buffer per segment is 8x
    faster on a bracket layer and within 0.5 % of the layer's area of the exact union (mitred
    instead of round joints).
    """
    starts = np.cumsum(counts) - counts
    tan = _tangents(pts, starts)
    off = 0.5 * w[:, None] * np.stack([-tan[:, 1], tan[:, 0]], axis=1)
    pid = np.repeat(np.arange(len(counts)), counts)
    k = np.arange(len(pts)) - starts[pid]  # vertex index along its path
    nseg = counts - 1
    nchunk = np.maximum(1, -(-nseg // _CHUNK))
    first_chunk = np.cumsum(nchunk) - nchunk
    # chunk c of a path holds vertices c * _CHUNK ... (c + 1) * _CHUNK: a vertex on a cut is in two
    c_lo = np.minimum(k // _CHUNK, nchunk[pid] - 1)
    on_cut = (k % _CHUNK == 0) & (k > 0) & (k < counts[pid] - 1)
    vert = np.concatenate([np.arange(len(pts)), np.flatnonzero(on_cut)])
    chunk = np.concatenate([first_chunk[pid] + c_lo, first_chunk[pid[on_cut]] + c_lo[on_cut] - 1])
    order = np.lexsort((vert, chunk))
    vert, chunk = vert[order], chunk[order]
    d, _ = cKDTree(near).query(pts[vert], distance_upper_bound=reach)
    keep_chunk = np.zeros(int(nchunk.sum()), dtype=bool)
    keep_chunk[chunk[np.isfinite(d)]] = True
    sel = keep_chunk[chunk]
    vert, chunk = vert[sel], chunk[sel]
    if not len(vert):
        return shapely.Polygon()
    # ring per chunk: left side forward, right side back
    cut = np.flatnonzero(np.diff(chunk)) + 1
    back = np.concatenate([v[::-1] for v in np.split(vert, cut)])
    coords = np.concatenate([(pts + off)[vert], (pts - off)[back]])
    _, rid = np.unique(np.concatenate([chunk, chunk]), return_inverse=True)
    o = np.argsort(rid, kind="stable")
    polys = shapely.polygons(shapely.linearrings(coords[o], indices=rid[o]))
    bad = ~shapely.is_valid(polys)
    polys[bad] = shapely.make_valid(polys[bad])
    return shapely.union_all(polys)


def _line_in(piece: Region, c: np.ndarray, d: np.ndarray, reach: float) -> shapely.LineString | None:
    """Return the piece of the line through ``c`` along ``d`` in ``piece`` nearest ``c``."""
    line = shapely.LineString([c - reach * d, c + reach * d]).intersection(piece)
    parts = [g for g in shapely.get_parts(line) if g.geom_type == "LineString" and g.length > 0]
    if not parts:
        return None
    return min(parts, key=lambda g: g.distance(shapely.Point(c)))


def gap_fill(
    paths: Sequence[Points2],
    widths: Sequence[Floats],
    region: Region,
    pitch: float,
    field: object | None = None,
    min_area: float = 0.5,
    min_width: float = 0.3,
    cap: float = 1.5,
    min_gap: float = 0.5,
    min_length: float = 0.5,
    window: float = 2.0,
) -> tuple[list[Points2], list[Floats], dict]:
    """Straight gap beads in the voids next to path ends (module docstring).

    Parameters
    ----------
    paths : sequence of (n_i, 2) float, mm
    widths : sequence of (n_i,) float, mm
        Flow width at every point.
    region : Polygon or MultiPolygon, mm
    pitch : float, mm
    field : StressField, optional
        The followed stress (one candidate direction of a gap bead).
    min_area : float
        Smallest void that gets a bead, in pitch².
    min_width, cap : float
        Narrowest and widest gap bead, in pitches.
    min_gap : float
        Smallest centre-line distance of a gap bead to other paths, in pitches.
    min_length : float
        Shortest gap bead, in pitches.
    window : float
        Radius around each path end that is searched for voids, in pitches.

    Returns
    -------
    paths : list of (2, 2) float, mm
    widths : list of (2,) float, mm
    stats : dict
        ``gap_voids`` (voids examined), ``gap_beads`` (laid), ``gap_mm2`` (their nominal area).
    """
    stats: dict = {"gap_voids": 0, "gap_beads": 0, "gap_mm2": 0.0}
    keep = [i for i, p in enumerate(paths) if len(p) >= 2]
    if not keep:
        return [], [], stats
    counts = np.array([len(paths[i]) for i in keep])
    pts = np.concatenate([np.asarray(paths[i], dtype=float) for i in keep])
    w = np.concatenate([np.asarray(widths[i], dtype=float) for i in keep])
    last = np.cumsum(counts) - 1
    first = last - counts + 1
    is_last = np.zeros(len(pts), dtype=bool)
    is_last[last] = True
    seg = np.flatnonzero(~is_last)
    # the voids next to path ends: the window around the ends less the beads that reach into it
    end_pts = np.concatenate([pts[first], pts[last]])
    win = shapely.intersection(
        shapely.union_all(shapely.buffer(shapely.points(end_pts), window * pitch, quad_segs=8)), region
    )
    voids = shapely.difference(win, _ribbons(pts, w, counts, end_pts, (window + cap) * pitch))
    pieces = [
        g for g in shapely.get_parts(voids) if g.geom_type == "Polygon" and g.area >= min_area * pitch**2
    ]
    circles = shapely.maximum_inscribed_circle(np.array(pieces, dtype=object), 0.02 * pitch)
    wide = shapely.length(circles) >= 0.5 * min_width * pitch  # not a sliver between two long paths
    pieces = [g for g, k in zip(pieces, wide, strict=True) if k]
    centres = shapely.get_coordinates(shapely.get_point(circles[wide], 0))
    stats["gap_voids"] = len(pieces)
    if not pieces:
        return [], [], stats
    step = 0.1 * pitch
    # the spacing rule needs only the segments that can come within min_gap of a void (a void lies
    # within its bounds' diagonal of its deepest point)
    bounds = shapely.bounds(np.array(pieces, dtype=object))
    diag = np.hypot(bounds[:, 2] - bounds[:, 0], bounds[:, 3] - bounds[:, 1])
    a, b = pts[seg], pts[seg + 1]
    pad = (min_gap + 0.1) * pitch + 0.5 * float(np.max(np.hypot(*(b - a).T), initial=0.0))
    near = cKDTree(0.5 * (a + b)).query_ball_point(centres, diag + pad, return_sorted=False)
    near = np.unique(np.concatenate([np.asarray(x, dtype=np.int64) for x in near]))
    tree = cKDTree(_densify(pts, seg[near], step))
    need = (min_gap + _MARGIN) * pitch
    out_p: list[Points2] = []
    out_w: list[Floats] = []
    laid: list[Points2] = []
    order = sorted(range(len(pieces)), key=lambda i: (-round(pieces[i].area, 9), *np.round(centres[i], 9)))
    for i in order:
        piece, c = pieces[i], centres[i]
        reach = float(np.hypot(*np.subtract(*np.reshape(piece.bounds, (2, 2))))) + pitch
        dirs = []
        if field is not None:
            smp = field.sample(c[None, :])  # type: ignore[attr-defined]
            if smp.valid[0]:
                dirs.append(np.asarray(smp.direction[0], dtype=float))
        rect = np.asarray(piece.minimum_rotated_rectangle.exterior.coords)
        if len(rect) >= 3:
            e1, e2 = rect[1] - rect[0], rect[2] - rect[1]
            axis = e1 if np.hypot(*e1) >= np.hypot(*e2) else e2
            if np.hypot(*axis) > 0:
                dirs.append(axis / np.hypot(*axis))
        best = None
        for d in dirs:
            line = _line_in(piece, c, d, reach)
            if line is None or line.length < min_length * pitch:
                continue
            bw = float(np.clip(piece.area / line.length, min_width * pitch, cap * pitch))
            bead = line.buffer(0.5 * bw, cap_style="flat")
            inside = bead.intersection(piece).area
            score = inside - (bead.area - inside)  # void covered less neighbour covered
            if best is None or score > best[0]:
                best = (score, line, bw)
        if best is None or best[0] <= 0:
            continue
        _, line, bw = best
        # the spacing rule: the longest run of samples ``need`` from every other path
        q = shapely.get_coordinates(line)
        samp = q[0] + np.linspace(0.0, 1.0, max(2, int(np.ceil(line.length / step)) + 1))[:, None] * (
            q[-1] - q[0]
        )
        dmin, _ = tree.query(samp)
        if laid:
            dmin = np.minimum(dmin, cKDTree(np.concatenate(laid)).query(samp)[0])
        edges = np.diff(np.concatenate([[0], (dmin >= need).astype(np.int8), [0]]))
        run_s, run_e = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
        if not len(run_s):
            continue
        k = int(np.argmax(run_e - run_s))
        p0, p1 = samp[run_s[k]], samp[run_e[k]]
        if np.hypot(*(p1 - p0)) < min_length * pitch:
            continue
        out_p.append(np.stack([p0, p1]))
        out_w.append(np.full(2, bw))
        laid.append(samp[run_s[k] : run_e[k] + 1])
        stats["gap_beads"] += 1
        stats["gap_mm2"] += float(bw * np.hypot(*(p1 - p0)))
    return out_p, out_w, stats
