"""Density control: which traced streamlines become filaments (thesis Sec. 4.1.2, App. C).

Two procedures:

:func:`thesis_density_control` (faithful mode) - the thesis's, as App. C writes it
    Delaunay-triangulate the integration points of the untreated streamlines; for the current
    streamline ``i``, take the triangles touching it; if any has a circumcircle diameter
    ``D < w + G_p`` (Eq. 4.5) remove *every whole* streamline owning a vertex of such a triangle
    and check ``i`` again; otherwise accept ``i`` as a filament and move to the streamline through
    the smallest circumcircle touching ``i``.  Settled on purpose:

    * ``i`` itself is never in the removed set (a triangle with all three vertices on ``i`` can be
      small on a tight curve; such triangles are not spacing tests at all).
    * "Collinear" duplicates (App. C's first branch) are not tested separately: a duplicate of ``i``
      traced from another seed forms tiny triangles with ``i`` and is removed by the spacing branch,
      which does the same thing (removes the neighbour, keeps ``i``).
    * Triangles whose circumcentre is outside the region (across a hole or a concave notch) are
      ignored: they are not gaps between filaments.
    * When ``i`` has no untreated neighbour left, the next streamline is the lowest-numbered
      untreated one (App. C does not say).
    * The thesis re-triangulates all untreated points at every iteration.  Only the triangles
      touching ``i`` are used, and a triangle with circumradius ``r`` depends only on points within
      ``2 r`` of ``i``, so each iteration triangulates the untreated points within
      ``2 (w + G_p)`` of ``i``: the same test triangles, at a fraction of the cost.

:func:`select` (default mode) - greedy, exact, and keeps what the thesis throws away
    Candidates are visited longest first.  Pass 1 keeps every candidate whose *whole* length
    stays at least ``min_spacing`` (segment to segment) from everything kept so far: these are the
    thesis's continuous filaments.  Pass 2 revisits the rest and keeps their runs that stay clear,
    if at least ``min_length`` long: discontinuous pieces (the thesis's gap fill, Sec. 4.1.2,
    "remove only the violating points").  Conflicts between candidates are found once with a
    ``cKDTree`` over segment midpoints; the greedy pass is a loop over candidates with numpy
    work per candidate.  Nothing is quadratic: the work is proportional to the number of
    segment pairs closer than ``min_spacing + step``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from loadpath._typing import Bools, Floats, Ints, Points2, Region
from loadpath.engines.streamlines._lines import Lines, point_segment_distance, segment_distance
from loadpath.engines.streamlines.integrate import END_SPACING, Traced
from scipy.spatial import Delaunay, QhullError, cKDTree

__all__ = ["Selected", "select", "conflicts", "drop_crossings", "thesis_density_control", "circumcircles"]


@dataclass(frozen=True)
class Selected:
    """Accepted pieces of traced streamlines.

    Attributes
    ----------
    lines : Lines
    whole : (m,) bool
        The piece is an entire traced streamline (not trimmed).
    end_start, end_finish : (m,) int
        Why each end stopped (``END_SPACING`` where trimmed).
    source : (m,) int
        Index of the traced line each piece comes from.
    """

    lines: Lines
    whole: Bools
    end_start: Ints
    end_finish: Ints
    source: Ints


def conflicts(lines: Lines, min_spacing: float) -> tuple[Ints, Ints]:
    """Pairs of segments of different lines closer than ``min_spacing``, both orders, sorted.

    Two segments (lengths at most ``h``) closer than ``r`` have an end within ``r`` of the other
    segment, and crossing segments have an end within ``h / 2`` of the other one; so the test runs
    on (vertex, segment) pairs - one point-segment distance each, from a single sparse distance
    query between the vertices and the segment midpoints within ``r + h / 2`` - and a close pair
    (vertex ``v``, segment ``s``) makes both segments at ``v`` conflict with ``s``.
    """
    start, owner = lines.segments()
    z = np.zeros(0, dtype=np.int64)
    if len(start) < 2:
        return z, z
    pts = lines.points
    a = pts[start]
    b = pts[start + 1]
    seg_len = np.linalg.norm(b - a, axis=1)
    hmax = float(np.max(seg_len))
    vl = lines.vertex_line
    # segments ending / starting at each vertex (-1 if none)
    n = len(pts)
    seg_before = np.full(n, -1)
    seg_after = np.full(n, -1)
    seg_after[start] = np.arange(len(start))
    seg_before[start + 1] = np.arange(len(start))
    if 0.5 * hmax >= min_spacing:  # long segments: crossings could hide from the end test
        return _segment_conflicts(a, b, owner, min_spacing)
    sd = cKDTree(pts).sparse_distance_matrix(
        cKDTree(0.5 * (a + b)), min_spacing + 0.5 * hmax, output_type="ndarray"
    )
    v = sd["i"].astype(np.int64)
    sg = sd["j"].astype(np.int64)
    other = vl[v] != owner[sg]
    v, sg = v[other], sg[other]
    d = point_segment_distance(pts[v], a[sg], b[sg])
    close = d < min_spacing
    v, sg = v[close], sg[close]
    own1 = seg_before[v]
    own2 = seg_after[v]
    ca = np.concatenate([own1, own2])
    cb = np.concatenate([sg, sg])
    keep = ca >= 0
    return _symmetric_sorted(ca[keep], cb[keep], len(start))


def _symmetric_sorted(ca: Ints, cb: Ints, n: int) -> tuple[Ints, Ints]:
    """Both orders of each pair, sorted by the first, duplicates removed."""
    if len(ca) == 0:
        return ca, cb
    ca, cb = np.concatenate([ca, cb]), np.concatenate([cb, ca])
    key = np.sort(ca * n + cb)  # (np.unique hashes in numpy 2.x, much slower here)
    key = key[np.concatenate([[True], key[1:] != key[:-1]])]
    return key // n, key % n


def _segment_conflicts(a: Points2, b: Points2, owner: Ints, min_spacing: float) -> tuple[Ints, Ints]:
    """Exact segment-segment conflicts (for segments longer than twice the spacing)."""
    mid = 0.5 * (a + b)
    hmax = float(np.max(np.linalg.norm(b - a, axis=1)))
    pairs = cKDTree(mid).query_pairs(min_spacing + hmax, output_type="ndarray")
    if len(pairs) == 0:
        z = np.zeros(0, dtype=np.int64)
        return z, z
    i, j = pairs[:, 0], pairs[:, 1]
    diff = owner[i] != owner[j]
    i, j = i[diff], j[diff]
    close = segment_distance(a[i], b[i], a[j], b[j]) < min_spacing
    return _symmetric_sorted(i[close], j[close], len(a))


def _runs(free: np.ndarray) -> list[tuple[int, int]]:
    """Maximal runs of True as (first, last + 1) index pairs."""
    padded = np.concatenate([[False], free, [False]])
    edges = np.flatnonzero(np.diff(padded.astype(np.int8)))
    return list(zip(edges[0::2].tolist(), edges[1::2].tolist(), strict=True))


def select(
    traced: Traced,
    min_spacing: float,
    min_length: float,
    order: Ints | None = None,
    runs: str = "seed",
) -> Selected:
    """Greedy selection of whole streamlines, then of their clear runs (module docstring).

    Parameters
    ----------
    traced : Traced
        Candidates (already clear of paths accepted in earlier rounds).
    min_spacing : float, mm
    min_length : float, mm
    order : (m,) int, optional
        Visiting order; default longest first.
    runs : {"seed", "all", "none"}
        Which clear runs of a trimmed candidate pass 2 keeps: the one through its seed (the
        Jobard-Lefer streamline of that seed: the seed was placed in a gap, the other runs lie in
        gaps nobody checked), all of them (the thesis's "remove only the violating points"), or
        none (whole streamlines only, the thesis's continuous filaments).

    Returns
    -------
    Selected
    """
    lines = traced.lines
    m = len(lines)
    if m == 0:
        z = np.zeros(0, dtype=np.int64)
        return Selected(Lines.from_list([]), np.zeros(0, dtype=bool), z, z, z)
    start, _ = lines.segments()
    seg_len = np.linalg.norm(lines.points[start + 1] - lines.points[start], axis=1)
    seg_off = np.concatenate([[0], np.cumsum(lines.counts - 1)])
    length = np.add.reduceat(seg_len, seg_off[:-1]) if len(seg_len) else np.zeros(m)
    length = np.where(lines.counts > 1, length, 0.0)
    if order is None:
        order = np.lexsort((np.arange(m), -length))
    ca, cb = conflicts(lines, min_spacing)
    lo_all = np.searchsorted(ca, seg_off[:-1])
    hi_all = np.searchsorted(ca, seg_off[1:])
    taken = np.zeros(len(seg_len), dtype=bool)
    whole = np.zeros(m, dtype=bool)
    for c in order:
        if length[c] < min_length or length[c] <= 0:
            continue
        lo, hi = lo_all[c], hi_all[c]
        if not np.any(taken[cb[lo:hi]]):
            taken[seg_off[c] : seg_off[c + 1]] = True
            whole[c] = True
    out, out_whole, out_s, out_f, out_src = [], [], [], [], []
    pieces: dict[int, list[tuple[int, int]]] = {}
    for c in order if runs != "none" else ():
        if whole[c] or length[c] < min_length:
            continue
        s0, s1 = seg_off[c], seg_off[c + 1]
        lo, hi = lo_all[c], hi_all[c]
        blocked = np.zeros(s1 - s0, dtype=bool)
        hit = taken[cb[lo:hi]]
        blocked[ca[lo:hi][hit] - s0] = True
        seed_seg = min(int(traced.seed_vertex[c]), s1 - s0 - 1)
        for r0, r1 in _runs(~blocked):
            if runs == "seed" and not (r0 <= seed_seg < r1 or r0 <= seed_seg - 1 < r1):
                continue
            if np.sum(seg_len[s0 + r0 : s0 + r1]) >= min_length:
                taken[s0 + r0 : s0 + r1] = True
                pieces.setdefault(int(c), []).append((r0, r1))
    for c in range(m):
        pts = lines.line(c)
        if whole[c]:
            out.append(pts)
            out_whole.append(True)
            out_s.append(traced.end_start[c])
            out_f.append(traced.end_finish[c])
            out_src.append(c)
        for r0, r1 in pieces.get(c, []):
            nseg = len(pts) - 1
            out.append(pts[r0 : r1 + 1])
            out_whole.append(False)
            out_s.append(traced.end_start[c] if r0 == 0 else END_SPACING)
            out_f.append(traced.end_finish[c] if r1 == nseg else END_SPACING)
            out_src.append(c)
    return Selected(
        lines=Lines.from_list(out),
        whole=np.asarray(out_whole, dtype=bool),
        end_start=np.asarray(out_s, dtype=np.int64),
        end_finish=np.asarray(out_f, dtype=np.int64),
        source=np.asarray(out_src, dtype=np.int64),
    )


def circumcircles(a: Points2, b: Points2, c: Points2) -> tuple[Points2, Floats]:
    """Circumcentres and circumradii of triangles (inf radius for degenerate ones).

    Parameters
    ----------
    a, b, c : (n, 2) float, mm

    Returns
    -------
    centre : (n, 2) float, mm
    radius : (n,) float, mm
    """
    ab = b - a
    ac = c - a
    den = 2.0 * (ab[:, 0] * ac[:, 1] - ab[:, 1] * ac[:, 0])
    ab2 = np.sum(ab * ab, axis=1)
    ac2 = np.sum(ac * ac, axis=1)
    ok = np.abs(den) > 1e-15 * np.maximum(ab2 + ac2, 1e-300)
    safe = np.where(ok, den, 1.0)
    ux = (ac[:, 1] * ab2 - ab[:, 1] * ac2) / safe
    uy = (ab[:, 0] * ac2 - ac[:, 0] * ab2) / safe
    centre = a + np.stack([ux, uy], axis=1)
    radius = np.where(ok, np.hypot(ux, uy), np.inf)
    return centre, radius


def thesis_density_control(
    lines: Lines, region: Region, spacing: float, inside: Callable[[Points2], Bools]
) -> tuple[Bools, dict[str, int]]:
    """Run the thesis's whole-streamline density control (App. C), with the guards of the module doc.

    Parameters
    ----------
    lines : Lines
        All traced streamlines, in seed order (streamline 1 is the first).
    region : Polygon or MultiPolygon, mm
    spacing : float, mm
        ``w + G_p``.
    inside : callable
        ``inside(points (n, 2)) -> (n,) bool``, the region test.

    Returns
    -------
    chosen : (m,) bool
        Streamlines kept as continuous filaments.
    stats : dict
        ``iterations``, ``removed``, ``chosen``.
    """
    m = len(lines)
    status = np.zeros(m, dtype=np.int8)  # 0 untreated, 1 removed, -1 chosen (App. C, column 4)
    if m == 0:
        return np.zeros(0, dtype=bool), {"iterations": 0, "removed": 0, "chosen": 0}
    pts = lines.points
    owner = lines.vertex_line
    tree = cKDTree(pts)
    reach = 2.0 * spacing
    i = 0
    iterations = 0
    max_iter = 4 * m + 10  # every iteration removes or chooses at least one streamline
    while iterations < max_iter:
        if status[i] != 0:
            left = np.flatnonzero(status == 0)
            if len(left) == 0:
                break
            i = int(left[0])
        iterations += 1
        near = tree.query_ball_point(lines.line(i), reach, return_sorted=False)
        idx = np.unique(np.concatenate([np.asarray(x, dtype=np.int64) for x in near]))
        idx = idx[status[owner[idx]] == 0]
        own = owner[idx] == i
        if np.all(own) or len(idx) < 3:
            status[i] = -1
            continue
        try:
            tri = Delaunay(pts[idx]).simplices
        except QhullError:
            status[i] = -1
            continue
        tow = owner[idx[tri]]  # (t, 3) owner of each vertex
        touch = np.any(tow == i, axis=1) & ~np.all(tow == i, axis=1)
        tri, tow = tri[touch], tow[touch]
        centre, r = circumcircles(pts[idx[tri[:, 0]]], pts[idx[tri[:, 1]]], pts[idx[tri[:, 2]]])
        real = np.isfinite(r)
        if np.any(real):
            real[real] = inside(centre[real])
        tri, tow, r = tri[real], tow[real], r[real]
        bad = 2.0 * r < spacing  # Eq. 4.5 violated
        if np.any(bad):
            n1 = np.unique(tow[bad])
            n1 = n1[n1 != i]
            status[n1] = 1
            continue
        status[i] = -1
        if len(r) == 0:
            continue
        nxt = tow[int(np.argmin(r))]
        nxt = nxt[(nxt != i) & (status[nxt] == 0)]
        if len(nxt):
            i = int(nxt[0])
    chosen = status == -1
    return chosen, {
        "iterations": int(iterations),
        "removed": int(np.sum(status == 1)),
        "chosen": int(np.sum(chosen)),
    }


def drop_crossings(
    lines: list[Points2], rank: Ints, min_distance: float = 1e-9
) -> tuple[list[Points2], Ints]:
    """Cut paths where they cross or touch a path of higher priority (the faithful mode's guard).

    The thesis's circumcircle test (Eq. 4.5) does not exclude crossings between a gap-filling piece
    and a filament in every configuration; paths that cross cannot be printed in one layer.  Of two
    segments closer than ``min_distance`` the one of the path with the larger ``rank`` is removed,
    splitting its path.

    Parameters
    ----------
    lines : list of (n_i, 2) arrays
    rank : (m,) int
        Priority of each path (lower keeps its segments).
    min_distance : float, mm
        Segments closer than this (0: crossing) conflict.

    Returns
    -------
    pieces : list of (k_j, 2) arrays
    source : (p,) int
        Index of the path each piece comes from.
    """
    src = np.arange(len(lines))
    rank = np.asarray(rank)
    for _ in range(10):
        packed = Lines.from_list(lines)
        ca, cb = conflicts(packed, min_distance)
        if len(ca) == 0:
            break
        start, owner = packed.segments()
        r = rank[src]
        drop_a = (r[owner[ca]] > r[owner[cb]]) | ((r[owner[ca]] == r[owner[cb]]) & (owner[ca] > owner[cb]))
        dead = np.zeros(len(start), dtype=bool)
        dead[ca[drop_a]] = True
        seg_off = np.concatenate([[0], np.cumsum(packed.counts - 1)])
        new_lines, new_src = [], []
        for k in range(len(lines)):
            segs = dead[seg_off[k] : seg_off[k + 1]]
            if not np.any(segs):
                new_lines.append(lines[k])
                new_src.append(src[k])
                continue
            for r0, r1 in _runs(~segs):
                new_lines.append(lines[k][r0 : r1 + 1])
                new_src.append(src[k])
        lines, src = new_lines, np.asarray(new_src, dtype=np.int64)
    return lines, src
