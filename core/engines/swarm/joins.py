"""Facing path ends joined into one path.

Where two fronts meet head-on (fill swarms started from both sides of a piece, a fan around a pin
hole meeting a fill swarm) their paths end facing each other across a small gap: after
:mod:`loadpath.engines.finish.ends` they stop about half a pitch apart, so each end's round bead end
lies on the other's, and two retractions and two bead ends are printed where one continuous bead
would do.  On the bench bracket 144 such pairs lie within two pitches of each other (288 of 754
ends).

:func:`join_ends` joins every pair of ends that

* are at most ``max_gap`` pitches apart,
* face each other: each end's outward direction is within ``max_turn`` degrees of the line to the
  other end (so the joined path turns by at most that much at either side of the bridge),
* and whose bridge (the straight segment between them) stays inside the region and keeps
  ``clearance`` from every other path and every other bridge (more than the engines' half-pitch
  rule; it cannot then cross anything),

nearest pairs first, each end at most once, never closing a loop.  The joined path is the first
path, the bridge and the second path reversed as needed; every point keeps its own width (the
bridge's ends carry the widths of the ends they join).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import shapely
from loadpath._typing import Floats, Points2, Region
from loadpath.engines.swarm.gaps import segment_distance
from scipy.spatial import cKDTree

__all__ = ["join_ends"]

_MARGIN = 0.02
"""Added to the clearance, in pitches: the bridges are checked at samples, not everywhere."""


def _near(q: Points2, centres: Points2, reach: float) -> np.ndarray:
    """Return the indices of the points ``q`` in the cells around ``centres``' cells, ascending.

    Cells are ``reach`` wide, so every point within ``reach`` of a centre is among them (a cheap
    superset, without a tree).
    """
    lo = np.minimum(q.min(axis=0), centres.min(axis=0))
    cq = np.floor((q - lo) / reach).astype(np.int64)
    cc = np.floor((centres - lo) / reach).astype(np.int64)
    shape = np.maximum(cq.max(axis=0), cc.max(axis=0)) + 3
    mark = np.zeros(shape, dtype=bool)
    for dx in (0, 1, 2):
        for dy in (0, 1, 2):
            mark[cc[:, 0] + dx, cc[:, 1] + dy] = True
    return np.flatnonzero(mark[cq[:, 0] + 1, cq[:, 1] + 1])


def _root(parent: list[int], i: int) -> int:
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


def join_ends(
    paths: Sequence[Points2],
    widths: Sequence[Floats],
    region: Region,
    pitch: float,
    max_gap: float = 2.0,
    max_turn: float = 50.0,
    clearance: float = 0.65,
    step: float = 0.1,
    hairpin: float | None = None,
) -> tuple[list[Points2], list[Floats], list[int], dict]:
    """Join the facing ends of different paths (module docstring).

    Parameters
    ----------
    paths : sequence of (n_i, 2) float, mm
    widths : sequence of (n_i,) float, mm
    region : Polygon or MultiPolygon, mm
    pitch : float, mm
    max_gap : float
        Longest bridge, in pitches.
    max_turn : float, degrees
        Largest angle between an end's direction and its bridge.
    clearance : float
        Smallest distance of a bridge to other paths and bridges, in pitches: more than the
        engines' half pitch, so a bridge's bead does not lie on its neighbours' (0.5 joins more
        ends but raises the overlap: on the bench bracket 3.74 % against 3.68 % with 0.65, on the
        small test bracket 6.61 against 6.43 %).
    step : float
        Spacing of the samples along a bridge that are checked, in pitches.
    hairpin : float, optional
        Also join neighbours that end side by side heading the same way (directions within 30
        degrees, bridge within 30 degrees of square to them, at most 1.5 of their mean width
        apart) by a hairpin whose bridge keeps this many pitches from other paths (the engines'
        0.5 suits it: the bridge runs along the bead the two ends stop at).  ``None``: no
        hairpins.

    Returns
    -------
    paths, widths : lists
        The joined paths (and those not joined, in their order of first appearance).
    origin : list of int
        For each output path, the input path it starts with.
    stats : dict
        ``joins`` (bridges laid) and ``join_mm`` (their length).

    (Over 120 lines: pairing the ends, testing the bridge and rebuilding the joined paths work on
    the same end tables; the hairpin variant reuses them.)
    """
    paths = [np.asarray(p, dtype=float) for p in paths]
    widths = [np.asarray(w, dtype=float) for w in widths]
    stats = {"joins": 0, "join_mm": 0.0}
    n = len(paths)
    counts = np.array([len(p) for p in paths])
    if n < 2:
        return paths, widths, list(range(n)), stats
    pts = np.concatenate(paths)
    pid = np.repeat(np.arange(n), counts)
    last = np.cumsum(counts) - 1
    first = last - counts + 1
    two = counts >= 2
    fi, la = first[two], last[two]
    idx = np.flatnonzero(two)
    e_pt = np.vstack([pts[fi], pts[la]])
    e_dir = e_pt - np.vstack([pts[fi + 1], pts[la - 1]])
    e_len = np.hypot(*e_dir.T)
    e_pid = np.concatenate([idx, idx])
    e_tail = np.repeat([False, True], len(idx))
    live = e_len > 0
    wid = np.concatenate(widths)
    e_w = np.concatenate([wid[fi], wid[la]])[live]
    e_pt, e_dir, e_pid, e_tail = e_pt[live], e_dir[live] / e_len[live, None], e_pid[live], e_tail[live]
    pairs = cKDTree(e_pt).query_pairs(max_gap * pitch, output_type="ndarray")
    if not len(pairs):
        return paths, widths, list(range(n)), stats
    a, b = pairs[:, 0], pairs[:, 1]
    v = e_pt[b] - e_pt[a]
    gap = np.hypot(*v.T)
    u = v / np.maximum(gap, 1e-12)[:, None]
    cos_t = np.cos(np.radians(max_turn))
    facing = (np.sum(e_dir[a] * u, axis=1) >= cos_t) & (np.sum(-e_dir[b] * u, axis=1) >= cos_t)
    c_need = np.full(len(a), clearance)
    if hairpin is not None:
        # neighbours ending side by side, heading the same way: a hairpin across their ends
        pin = (
            (np.sum(e_dir[a] * e_dir[b], axis=1) >= np.cos(np.radians(30.0)))
            & (np.abs(np.sum(e_dir[a] * u, axis=1)) <= np.sin(np.radians(30.0)))
            & (gap <= 1.5 * 0.5 * (e_w[a] + e_w[b]))
            & ~facing
        )
        c_need = np.where(pin, hairpin, c_need)
        facing = facing | pin
    ok = (e_pid[a] != e_pid[b]) & (gap > 0) & facing
    a, b, gap, c_need = a[ok], b[ok], gap[ok], c_need[ok]
    if not len(a):
        return paths, widths, list(range(n)), stats
    q0, q1 = e_pt[a], e_pt[b]
    # the bridges inside the region
    bridges = shapely.linestrings(np.stack([q0, q1], axis=1))
    shapely.prepare(region)
    ok = shapely.covers(region, bridges)
    a, b, gap, c_need, q0, q1 = a[ok], b[ok], gap[ok], c_need[ok], q0[ok], q1[ok]
    if not len(a):
        return paths, widths, list(range(n)), stats
    # samples along each bridge (ends excluded) and their distance to the other paths' segments
    need_k = (c_need + _MARGIN) * pitch
    need = float(need_k.max()) if len(need_k) else 0.0
    ns = np.maximum(2, np.ceil(gap / (step * pitch)).astype(np.int64))
    inner = ns - 1
    which = np.repeat(np.arange(len(a)), inner)
    frac = (np.arange(len(which)) - np.repeat(np.cumsum(inner) - inner, inner) + 1) / np.repeat(ns, inner)
    samp = q0[which] + frac[:, None] * (q1 - q0)[which]
    seg_ok = np.ones(len(pts) - 1, dtype=bool)
    seg_ok[last[:-1]] = False
    si = np.flatnonzero(seg_ok)
    sa, sb, spid = pts[si], pts[si + 1], pid[si]
    # only the segments near a bridge, cut into pieces of at most half a pitch (a small search
    # radius whatever the longest segment)
    seg_len = np.hypot(*(sb - sa).T)
    mid_b = 0.5 * (q0 + q1)
    near = _near(0.5 * (sa + sb), mid_b, need + 0.5 * float(gap.max()) + 0.5 * float(seg_len.max()))
    sa, sb, spid, seg_len = sa[near], sb[near], spid[near], seg_len[near]
    n_cut = np.maximum(1, np.ceil(seg_len / (0.5 * pitch)).astype(np.int64))
    rep = np.repeat(np.arange(len(sa)), n_cut)
    k_in = np.arange(len(rep)) - np.repeat(np.cumsum(n_cut) - n_cut, n_cut)
    da = (sb - sa)[rep] / n_cut[rep, None]
    sa, spid = sa[rep] + k_in[:, None] * da, spid[rep]
    sb = sa + da
    near = cKDTree(samp).sparse_distance_matrix(
        cKDTree(0.5 * (sa + sb)), need + 0.25 * pitch, output_type="ndarray"
    )
    ip, js = near["i"].astype(np.int64), near["j"].astype(np.int64)
    mine = (spid[js] == e_pid[a][which[ip]]) | (spid[js] == e_pid[b][which[ip]])
    ip, js = ip[~mine], js[~mine]
    close = segment_distance(samp[ip], sa[js], sb[js]) < need_k[which[ip]]
    blocked = np.zeros(len(a), dtype=bool)
    blocked[which[ip[close]]] = True
    a, b, gap, need_k, q0, q1 = (x[~blocked] for x in (a, b, gap, need_k, q0, q1))

    # nearest pairs first, each end once, no loops, bridges clear of each other
    order = np.lexsort((b, a, gap))
    used = np.zeros(len(e_pt), dtype=bool)
    parent = list(range(n))
    link: dict[tuple[int, bool], tuple[int, bool]] = {}
    laid: list[tuple[Points2, Points2]] = []
    for k in order:
        ea, eb = int(a[k]), int(b[k])
        if used[ea] or used[eb]:
            continue
        pa, pb = int(e_pid[ea]), int(e_pid[eb])
        ra, rb = _root(parent, pa), _root(parent, pb)
        if ra == rb:
            continue
        p0, p1 = q0[k], q1[k]
        if laid:
            s = p0 + np.linspace(0.0, 1.0, 11)[:, None] * (p1 - p0)
            la = np.array([x[0] for x in laid])
            lb = np.array([x[1] for x in laid])
            m = len(laid)
            d = segment_distance(np.repeat(s, m, axis=0), np.tile(la, (len(s), 1)), np.tile(lb, (len(s), 1)))
            if np.min(d) < need_k[k]:
                continue
        used[ea] = used[eb] = True
        parent[ra] = rb
        link[(pa, bool(e_tail[ea]))] = (pb, bool(e_tail[eb]))
        link[(pb, bool(e_tail[eb]))] = (pa, bool(e_tail[ea]))
        laid.append((p0, p1))
        stats["joins"] += 1
        stats["join_mm"] += float(gap[k])
    if not laid:
        return paths, widths, list(range(n)), stats

    # walk each chain from a free end
    out_p: list[Points2] = []
    out_w: list[Floats] = []
    origin: list[int] = []
    done = np.zeros(n, dtype=bool)
    for i in range(n):
        if done[i]:
            continue
        # go to one free end of i's chain (no loops: one exists)
        cur, at_tail = i, False  # walking off i's head
        while (cur, at_tail) in link:
            nxt, nxt_end = link[(cur, at_tail)]
            cur, at_tail = nxt, not nxt_end
        # cur's end ``at_tail`` is free: start there
        pts_c: list[Points2] = []
        w_c: list[Floats] = []
        start = cur
        enter_tail = at_tail
        while True:
            done[cur] = True
            p, w = paths[cur], widths[cur]
            if enter_tail:
                p, w = p[::-1], w[::-1]
            pts_c.append(p)
            w_c.append(w)
            leave = (cur, not enter_tail)
            if leave not in link:
                break
            cur, end = link[leave]
            enter_tail = end
        out_p.append(np.concatenate(pts_c))
        out_w.append(np.concatenate(w_c))
        origin.append(start)
    return out_p, out_w, origin, stats
