"""Gap fill: a short straight bead in each void left where path ends meet.

Where two fronts meet (a seam behind a hole, the neutral axis of a bent bracket where the followed
stress turns by 90 degrees, a swarm killed between converging neighbours) the paths end, and the
beads' square ends leave voids a pitch or so across that no swarm can enter and that
:mod:`loadpath.engines.finish.ends` cannot reach without covering a neighbour.  A void costs
stiffness in proportion to its area, and volume matching cannot refill it (it thins or thickens
every bead alike).

:func:`gap_fill` finds the voids next to path ends (beads square at their ends, of each point's
flow width) and lays one straight bead in each void of at least ``min_area`` pitch²: through the
void's deepest point, along the followed stress there or along the void's long axis, whichever
covers more of the void and less outside it; its width is the void's area over the line's length
(within ``[min_width, cap]`` pitches).  A gap bead keeps the engines' rule: its centre line stays
``min_gap`` pitches from every other path (it is trimmed to the longest piece that does, and
dropped if that is shorter than ``min_length`` pitches).

Only the neighbourhood of path ends is searched (``window`` pitches around each end), and only
the beads that can reach into it are drawn (:func:`.voids.ribbons`; the voids themselves are one
Clipper difference, :func:`.voids.find_voids`), so the cost grows with the number of ends, not
with the layer's size.  The spacing rule measures exact point-to-segment distances
(:func:`_near_distance`) to the segments near each candidate bead, all candidates at once.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import shapely
from loadpath._typing import Floats, Points2, Region
from loadpath.engines.swarm.voids import find_voids, ribbons
from scipy.spatial import cKDTree

__all__ = ["gap_fill", "segment_distance", "near_points"]

_MARGIN = 0.01
"""Added to ``min_gap``, in pitches: a gap bead is checked every tenth of a pitch, and between two
samples ``h = 0.05`` pitch away its distance to a path can dip by ``h² / (2 min_gap)`` = 0.0025."""


def segment_distance(p: Points2, a: Points2, b: Points2) -> Floats:
    """Exact distance from each point ``p[i]`` to its segment ``a[i] -> b[i]``.

    Parameters
    ----------
    p, a, b : (n, 2) float, mm
        Points and segment ends (a segment may have zero length).

    Returns
    -------
    (n,) float, mm
    """
    ab = b - a
    ll = np.einsum("ij,ij->i", ab, ab)
    ap = p - a
    t = np.clip(np.einsum("ij,ij->i", ap, ab) / np.where(ll > 0, ll, 1.0), 0.0, 1.0)
    return np.hypot(*(ap - t[:, None] * ab).T)


def _near_distance(p: Points2, a: Points2, b: Points2, reach: float) -> Floats:
    """Exact distance from each point to the nearest segment whose midpoint is within ``reach``.

    With ``reach`` at least ``d`` plus the longest half segment, every distance below ``d`` is
    the exact distance to the nearest of all the segments.

    Parameters
    ----------
    p : (m, 2) float, mm
    a, b : (k, 2) float, mm
        Segment ends.
    reach : float, mm

    Returns
    -------
    (m,) float, mm
        ``inf`` where no segment's midpoint is within ``reach``.
    """
    d = np.full(len(p), np.inf)
    if not len(p) or not len(a):
        return d
    pairs = cKDTree(p).sparse_distance_matrix(cKDTree(0.5 * (a + b)), reach, output_type="ndarray")
    ip, js = pairs["i"].astype(np.int64), pairs["j"].astype(np.int64)
    np.minimum.at(d, ip, segment_distance(p[ip], a[js], b[js]))
    return d


def near_points(q: Points2, centres: Points2, reach: float, split: int = 3) -> np.ndarray:
    """Return the indices of the points ``q`` in the grid cells around ``centres`` (ascending).

    Cells are ``reach / split`` wide and the ``2 split + 1`` cells square around a centre's cell
    are taken, so every point within ``reach`` of a centre is returned (and some up to
    ``(1 + 1 / split) sqrt(2) reach`` away): a cheap superset, without a tree of the layer's points.

    Parameters
    ----------
    q : (n, 2) float, mm
    centres : (e, 2) float, mm
    reach : float, mm
    split : int
        Cells per ``reach``.

    Returns
    -------
    (k,) int
    """
    size = reach / split
    o = centres.min(axis=0) - reach - size
    ce = np.floor((centres - o) / size).astype(np.int64)
    shape = ce.max(axis=0) + split + 1
    grid = np.zeros(shape, dtype=bool)
    for dx in range(-split, split + 1):
        for dy in range(-split, split + 1):
            grid[ce[:, 0] + dx, ce[:, 1] + dy] = True
    # points off the grid land in its border cells, which no centre marks (or in marked ones: a
    # superset is fine)
    cq = np.clip(((q - o) / size).astype(np.int64), 0, shape - 1)
    return np.flatnonzero(grid[cq[:, 0], cq[:, 1]])


def _lines_in(pieces: np.ndarray, c: Points2, d: Points2, reach: Floats) -> np.ndarray:
    """For each void, the piece of the line through ``c`` along ``d`` inside it nearest ``c``.

    Parameters
    ----------
    pieces : (n,) Polygon, mm
    c : (n, 2) float, mm
        A point in each void.
    d : (n, 2) float
        Unit directions.
    reach : (n,) float, mm
        Half length of the line, enough to cross the void.

    Returns
    -------
    (n,) LineString or None, mm
        None where the line meets the void in points only.
    """
    out = np.full(len(pieces), None, dtype=object)
    full = shapely.linestrings(np.stack([c - reach[:, None] * d, c + reach[:, None] * d], axis=1))
    parts, idx = shapely.get_parts(shapely.intersection(full, pieces), return_index=True)
    ok = (shapely.get_type_id(parts) == 1) & (shapely.length(parts) > 0)
    parts, idx = parts[ok], idx[ok]
    dist = shapely.distance(parts, shapely.points(c[idx]))
    o = np.lexsort((np.arange(len(idx)), dist, idx))  # the nearest, the first of equals
    first = o[np.r_[True, idx[o][1:] != idx[o][:-1]]] if len(o) else o
    out[idx[first]] = parts[first]
    return out


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

    (Over 120 lines: the voids near the ends, their candidate beads and the acceptance tests all
    work on the same flattened point, width and end arrays, built once here.)
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
    need = (min_gap + _MARGIN) * pitch
    radius = window * pitch
    end_pts = np.concatenate([pts[first], pts[last]])
    # the segments that can matter: a ribbon point lies within half its width of its segment, a
    # gap bead within the windows (``radius`` of an end) and tested ``need`` around it
    seg_len = np.hypot(*np.diff(pts, axis=0).T)
    seg_len[last[:-1]] = 0.0  # from one path's last point to the next path's first
    half_max = 0.5 * float(np.max(seg_len, initial=0.0))
    reach = radius + half_max + max(0.5 * float(np.max(w)), need)
    cand = near_points(pts, end_pts, reach + half_max)  # the segments' first points
    cand = cand[~is_last[cand]]
    a, b = pts[cand], pts[cand + 1]
    mid = 0.5 * (a + b)
    half_len = 0.5 * seg_len[cand]
    half_w = 0.5 * np.maximum(w[cand], w[cand + 1])
    d_end, _ = cKDTree(end_pts).query(mid)
    near = d_end <= reach
    drawn = cand[d_end <= radius + half_len + half_w]
    pieces = find_voids(end_pts, radius, region, ribbons(pts, w, first, drawn), min_area * pitch**2)
    if not pieces:
        return [], [], stats
    circles = shapely.maximum_inscribed_circle(np.array(pieces, dtype=object), 0.02 * pitch)
    wide = shapely.length(circles) >= 0.5 * min_width * pitch  # not a sliver between two long paths
    pieces = [g for g, k in zip(pieces, wide, strict=True) if k]
    centres = shapely.get_coordinates(shapely.get_point(circles[wide], 0))
    stats["gap_voids"] = len(pieces)
    if not pieces:
        return [], [], stats
    step = 0.1 * pitch
    n = len(pieces)
    arr = np.array(pieces, dtype=object)
    area = shapely.area(arr)
    bounds = shapely.bounds(arr)
    span = np.hypot(bounds[:, 2] - bounds[:, 0], bounds[:, 3] - bounds[:, 1]) + pitch
    # two candidate directions per void: the followed stress (where valid) and the long axis
    dirs = np.full((2, n, 2), np.nan)
    if field is not None:
        smp = field.sample(centres)  # type: ignore[attr-defined]
        dirs[0, smp.valid] = np.asarray(smp.direction, dtype=float)[smp.valid]
    rect = shapely.get_coordinates(shapely.oriented_envelope(arr), return_index=True)
    for i in range(n):  # a rectangle has 5 coordinates; a degenerate envelope (line, point) fewer
        r = rect[0][rect[1] == i]
        if len(r) >= 3:
            e1, e2 = r[1] - r[0], r[2] - r[1]
            axis = e1 if np.hypot(*e1) >= np.hypot(*e2) else e2
            if np.hypot(*axis) > 0:
                dirs[1, i] = axis / np.hypot(*axis)
    # each candidate's line, width and score (void covered less neighbour covered)
    lines = np.full((2, n), None, dtype=object)
    score = np.full((2, n), -np.inf)
    bw = np.zeros((2, n))
    for k in range(2):
        has = np.flatnonzero(np.all(np.isfinite(dirs[k]), axis=1))
        ln = _lines_in(arr[has], centres[has], dirs[k, has], span[has])
        length = shapely.length(ln)
        ok = np.flatnonzero(np.nan_to_num(length, nan=0.0) >= min_length * pitch)
        has, ln, length = has[ok], ln[ok], length[ok]
        if not len(has):
            continue
        w_k = np.clip(area[has] / length, min_width * pitch, cap * pitch)
        # the bead: the line's rectangle (a straight line buffered with flat caps)
        xy, li = shapely.get_coordinates(ln, return_index=True)
        at = np.searchsorted(li, np.arange(len(ln)))
        p0, p1 = xy[at], xy[np.r_[at[1:], len(xy)] - 1]
        side = (0.5 * w_k / length)[:, None] * np.stack([p0[:, 1] - p1[:, 1], p1[:, 0] - p0[:, 0]], axis=1)
        bead = shapely.polygons(np.stack([p0 + side, p0 - side, p1 - side, p1 + side], axis=1))
        inside = shapely.area(shapely.intersection(bead, arr[has]))
        lines[k, has], bw[k, has], score[k, has] = ln, w_k, inside - (w_k * length - inside)
    pick = (score[1] > score[0]).astype(np.int64)  # the stress direction unless the axis is better
    best_line, best_w = lines[pick, np.arange(n)], bw[pick, np.arange(n)]
    good = score[pick, np.arange(n)] > 0
    if not good.any():
        return [], [], stats
    # samples every ``step`` along each best line, and their exact distance to the other paths
    xy, li = shapely.get_coordinates(best_line[good], return_index=True)
    ends_of = np.searchsorted(li, np.arange(int(good.sum())))
    q = np.stack([xy[ends_of], xy[np.r_[ends_of[1:], len(xy)] - 1]], axis=1)  # (g, 2, 2) first, last
    ns = np.maximum(2, np.ceil(shapely.length(best_line[good]) / step).astype(np.int64) + 1)
    frac = (np.arange(ns.sum()) - np.repeat(np.cumsum(ns) - ns, ns)) / np.repeat(ns - 1, ns)
    which = np.repeat(np.arange(len(ns)), ns)
    samp_all = q[which, 0] + frac[:, None] * (q[which, 1] - q[which, 0])
    pad = need + float(np.max(half_len[near], initial=0.0))  # every segment within need is found
    d_all = _near_distance(samp_all, a[near], b[near], pad)
    first_sample = np.full(n, -1)
    first_sample[np.flatnonzero(good)] = np.cumsum(ns) - ns
    n_samples = np.zeros(n, dtype=np.int64)
    n_samples[np.flatnonzero(good)] = ns
    out_p: list[Points2] = []
    out_w: list[Floats] = []
    order = sorted(range(n), key=lambda i: (-round(area[i], 9), *np.round(centres[i], 9)))
    for i in order:
        if not good[i]:
            continue
        # the longest run of samples ``need`` from every other path and every gap bead laid
        sl = slice(first_sample[i], first_sample[i] + n_samples[i])
        samp, dmin = samp_all[sl], d_all[sl]
        if out_p:
            laid = np.array(out_p)  # (l, 2, 2)
            m, nl = len(samp), len(laid)
            d_laid = segment_distance(
                np.repeat(samp, nl, axis=0), np.tile(laid[:, 0], (m, 1)), np.tile(laid[:, 1], (m, 1))
            )
            dmin = np.minimum(dmin, d_laid.reshape(m, nl).min(axis=1))
        edges = np.diff(np.concatenate([[0], (dmin >= need).astype(np.int8), [0]]))
        run_s, run_e = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
        if not len(run_s):
            continue
        k = int(np.argmax(run_e - run_s))
        p0, p1 = samp[run_s[k]], samp[run_e[k]]
        if np.hypot(*(p1 - p0)) < min_length * pitch:
            continue
        out_p.append(np.stack([p0, p1]))
        out_w.append(np.full(2, best_w[i]))
        stats["gap_beads"] += 1
        stats["gap_mm2"] += float(best_w[i] * np.hypot(*(p1 - p0)))
    return out_p, out_w, stats
