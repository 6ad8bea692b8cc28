"""Path ends pulled back until their round bead end balances the void it leaves.

A path end placed so its *square* bead end meets the bead ahead
(:mod:`loadpath.engines.finish.ends`, the flow-width rectangle of interface.md) puts its whole
rounded end, half a disc of the bead's width, on top of that bead; a swarm end killed closer than
that puts more.  Printed, that plastic piles up on the other bead; in the coverage metric it is
overlap, and on a layer with hundreds of ends along the seams where fronts meet (a bearing-loaded
bracket: 374 ends on 330 mm², their caps 17 of its 22 mm² of overlap) it is most of it.  Pulling an
end straight back by ``t`` takes its cap off the bead ahead but leaves uncovered the corners beside
the cap; for a cap of radius ``r`` against a straight bead side, the overlap falls from ``pi r^2 /
2`` at ``t = 0`` to ``0.45 r^2`` at ``t = 0.6 r`` while the void only grows to ``0.08 r^2``.

:func:`settle_ends` finds, for every end, the pull-back ``t`` (in steps up to ``max_back`` of its
width) that removes the most overlap less ``balance`` times the void it adds, measured on a grid
of samples around the end: a sample is *other* if another path's bead (the metric's: each segment
buffered by the mean half width of its ends) covers it, *own* if the end's bead (straight, round
ended) covers it at ``t``.  Samples outside the region count as neither.  Any shape of meeting is
handled the same way (head-on, oblique, against the rim of a hole), with no case analysis.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import shapely
from loadpath._typing import Floats, Points2, Region
from loadpath.engines.swarm.gaps import near_points, segment_distance
from scipy.spatial import cKDTree

__all__ = ["settle_ends"]

_NEAR = 16
"""Pieces of path (at most half a pitch long) looked at around each sample: the nearest ones."""


def settle_ends(
    paths: Sequence[Points2],
    widths: Sequence[Floats],
    region: Region,
    pitch: float,
    balance: float = 1.0,
    max_back: float = 1.0,
    steps: int = 10,
    grid: int = 4,
    fixed: Sequence[bool] | None = None,
) -> tuple[list[Points2], list[Floats], dict]:
    """Pull every path end back by the amount that best trades its cap's overlap for void.

    Parameters
    ----------
    paths : sequence of (n_i, 2) float, mm
    widths : sequence of (n_i,) float, mm
        Flow width at every point.
    region : Polygon or MultiPolygon, mm
    pitch : float, mm
    balance : float
        Weight of the void added against the overlap removed (1: area for area).
    max_back : float
        Longest pull-back, in the end's own widths (an end never moves past 0.4 of its path).
    steps : int
        Pull-backs tried, evenly up to ``max_back``.
    grid : int
        Samples per half width of the grid around each end.
    fixed : sequence of bool, optional
        Paths whose ends stay (they still count as the others' beads).

    Returns
    -------
    paths, widths : lists as given, the pulled-back ends moved along their paths
    stats : dict
        ``ends_settled`` (count) and ``settled_mm`` (total pull-back).

    (Over 120 lines: the trial pull-backs of all ends are scored together, on sample grids around
    each end; the candidates, scores and the update share those arrays.)
    """
    paths = [np.asarray(p, dtype=float) for p in paths]
    widths = [np.asarray(w, dtype=float) for w in widths]
    stats = {"ends_settled": 0, "settled_mm": 0.0}
    counts = np.array([len(p) for p in paths])
    if not len(paths) or np.all(counts < 2):
        return paths, widths, stats
    pts = np.concatenate(paths)
    wid = np.concatenate(widths)
    pid = np.repeat(np.arange(len(paths)), counts)
    last = np.cumsum(counts) - 1
    first = last - counts + 1
    seg_ok = np.ones(len(pts) - 1, dtype=bool)
    seg_ok[last[:-1]] = False
    si = np.flatnonzero(seg_ok)
    sa, sb, srad, spid = pts[si], pts[si + 1], 0.25 * (wid[si] + wid[si + 1]), pid[si]
    is_first = np.zeros(len(pts), dtype=bool)
    is_first[first] = True
    s_head = is_first[si]  # the segment starts a path
    is_last = np.zeros(len(pts), dtype=bool)
    is_last[last] = True
    s_tail = is_last[si + 1]  # the segment ends a path
    seg_len = np.hypot(*(sb - sa).T)
    arc = np.zeros(len(pts))
    arc[si + 1] = seg_len
    arc = np.cumsum(arc)
    arc -= np.repeat(arc[first], counts)
    length = arc[last]

    # ends (paths of at least two distinct points): point, inward direction, width, room to move
    movable = np.ones(len(paths), dtype=bool) if fixed is None else ~np.asarray(fixed, dtype=bool)
    live = np.flatnonzero((counts >= 2) & (length > 0) & movable)
    e_path = np.concatenate([live, live])
    e_tail = np.repeat([False, True], len(live))
    e_idx = np.where(e_tail, last[e_path], first[e_path])
    nxt = np.where(e_tail, e_idx - 1, e_idx + 1)
    e_pt = pts[e_idx]
    back = pts[nxt] - e_pt
    back /= np.maximum(np.hypot(*back.T), 1e-12)[:, None]
    r = 0.5 * wid[e_idx]
    room = 0.4 * length[e_path]

    # only the segments that can reach the samples around an end are looked at
    far = float(2.0 * max_back * r.max() + r.max() + 0.5 * wid.max()) + 0.25 * pitch
    near = near_points(0.5 * (sa + sb), e_pt, far + 0.5 * float(seg_len.max()))
    sa, sb, srad, spid, s_head, s_tail, seg_len = (
        x[near] for x in (sa, sb, srad, spid, s_head, s_tail, seg_len)
    )
    # long segments cut into pieces of at most half a pitch, so the search radius stays small
    # (a piece keeps the segment's radius; only the path's first and last pieces are cap ends)
    n_cut = np.maximum(1, np.ceil(seg_len / (0.5 * pitch)).astype(np.int64))
    rep = np.repeat(np.arange(len(sa)), n_cut)
    k_in = np.arange(len(rep)) - np.repeat(np.cumsum(n_cut) - n_cut, n_cut)
    f0, f1 = k_in / n_cut[rep], (k_in + 1) / n_cut[rep]
    da = sb - sa
    ca, cb = sa[rep] + f0[:, None] * da[rep], sa[rep] + f1[:, None] * da[rep]
    c_rad, c_pid = srad[rep], spid[rep]
    c_head = s_head[rep] & (k_in == 0)
    c_tail = s_tail[rep] & (k_in == n_cut[rep] - 1)
    # only the ends whose round end reaches into another path's bead get samples
    ctree = cKDTree(0.5 * (ca + cb))
    _, jn = ctree.query(e_pt, k=_NEAR, distance_upper_bound=float(r.max() + c_rad.max()) + 0.25 * pitch)
    je = np.repeat(np.arange(len(e_pt)), _NEAR)
    jc = jn.ravel()
    ok = jc < len(ca)
    je, jc = je[ok], jc[ok]
    foreign = c_pid[jc] != e_path[je]
    je, jc = je[foreign], jc[foreign]
    # (one of three points of the cap, 0.6 of its radius out, straight ahead and 60 degrees to
    # either side, inside another bead: a neighbour beside the end, touching its bead, is not
    # enough)
    side = np.stack([-back[je, 1], back[je, 0]], axis=1)
    hit = np.zeros(len(je), dtype=bool)
    for c, s in ((1.0, 0.0), (0.5, 0.866), (0.5, -0.866)):
        probe = e_pt[je] + 0.6 * r[je, None] * (-c * back[je] + s * side)
        hit |= segment_distance(probe, ca[jc], cb[jc]) < c_rad[jc]
    busy = np.unique(je[hit])
    e_path, e_tail, e_pt, back, r, room = (x[busy] for x in (e_path, e_tail, e_pt, back, r, room))
    # samples around each end in its frame: u along the path (back is negative), v across
    k = np.arange(-2 * grid * max_back, grid + 1) + 0.5
    kv = np.arange(-grid, grid) + 0.5
    uu, vv = (g.ravel() / grid for g in np.meshgrid(k, kv, indexing="ij"))  # in radii
    n_e = len(e_pt)
    u = r[:, None] * uu[None, :]
    v = r[:, None] * vv[None, :]
    normal = np.stack([-back[:, 1], back[:, 0]], axis=1)
    q = e_pt[:, None, :] - u[..., None] * back[:, None, :] + v[..., None] * normal[:, None, :]
    # own bead at pull-back t: the straight body up to -t and the disc of radius r at -t
    t = (max_back * 2.0 * r)[:, None] * np.linspace(0.0, 1.0, steps + 1)[None, :]  # (e, k)
    t = np.minimum(t, room[:, None])
    own0 = ((u <= 0) & (np.abs(v) <= r[:, None])) | (u * u + v * v <= (r * r)[:, None])
    cell = (r / grid) ** 2
    # only the samples the pull-backs can uncover are looked at
    look = own0 & (u >= -t[:, -1:])
    ei, sj = np.nonzero(look)
    qs = q[ei, sj]
    inside = shapely.contains_xy(region, qs[:, 0], qs[:, 1])
    # covered by another path's bead: exact distance to the segments near each sample; a sample
    # only another end's cap covers counts half (that end may pull back as well)
    body = np.zeros(len(qs), dtype=bool)
    capped = np.zeros(len(qs), dtype=bool)
    if len(ca) and len(qs):
        reach = float(c_rad.max()) + 0.25 * pitch
        dist, js = ctree.query(qs, k=_NEAR, distance_upper_bound=reach)
        ip = np.repeat(np.arange(len(qs)), _NEAR)
        js = js.ravel()
        ok = js < len(ca)
        ip, js = ip[ok], js[ok]
        mine = c_pid[js] == e_path[ei[ip]]
        ip, js = ip[~mine], js[~mine]
        ab = cb[js] - ca[js]
        ap = qs[ip] - ca[js]
        ll = np.einsum("ij,ij->i", ab, ab)
        tt = np.einsum("ij,ij->i", ap, ab) / np.where(ll > 0, ll, 1.0)
        d = np.hypot(*(ap - np.clip(tt, 0.0, 1.0)[:, None] * ab).T)
        hit = d <= c_rad[js]
        at_cap = ((tt < 0) & c_head[js]) | ((tt > 1) & c_tail[js])
        body[ip[hit & ~at_cap]] = True
        capped[ip[hit & at_cap]] = True
    worth = np.where(body, 1.0, np.where(capped, 0.5, -balance))
    # overlap removed and void added by each pull-back, (e, k)
    gain = np.zeros((n_e, steps + 1))
    us, vs = u[ei, sj], v[ei, sj]
    for j in range(1, steps + 1):
        tj = t[ei, j]
        lost = ~(((us <= -tj) & (np.abs(vs) <= r[ei])) | ((us + tj) ** 2 + vs * vs <= r[ei] ** 2)) & inside
        gain[:, j] = np.bincount(ei[lost], weights=worth[lost], minlength=n_e)
    gain *= cell[:, None]
    best = np.argmax(gain, axis=1)  # the first of equals: no move unless it gains
    move = t[np.arange(n_e), best]
    move = np.where(gain[np.arange(n_e), best] > 0, move, 0.0)

    out_p, out_w = list(paths), list(widths)
    head = np.zeros(len(paths))
    tail = np.zeros(len(paths))
    head[e_path[~e_tail]] = move[~e_tail]
    tail[e_path[e_tail]] = move[e_tail]
    for i in np.flatnonzero((head > 0) | (tail > 0)):
        a = arc[first[i] : last[i] + 1]
        s0, s1 = head[i], length[i] - tail[i]
        keep = (a > s0) & (a < s1)
        ends = np.array([s0, s1])
        xy = np.stack([np.interp(ends, a, paths[i][:, 0]), np.interp(ends, a, paths[i][:, 1])], axis=1)
        wd = np.interp(ends, a, widths[i])
        out_p[i] = np.vstack([xy[:1], paths[i][keep], xy[1:]])
        out_w[i] = np.concatenate([wd[:1], widths[i][keep], wd[1:]])
    stats["ends_settled"] = int(np.count_nonzero(move > 0))
    stats["settled_mm"] = float(move.sum())
    return out_p, out_w, stats
