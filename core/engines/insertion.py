"""Runs inserted into a link: the last step of linking a layer (:mod:`loadpath.engines.linking`).

The linking lays links greedily (shortest first, or chain by chain), and a link once laid is never
taken back.  So a run whose two ends lie beside a link laid earlier stays a run of its own, although
the link could make way for it: the link from end ``p`` to end ``q`` is replaced by two, ``p`` to one
end of the run and its other end to ``q``, and the layer prints one run fewer (one retracted travel
fewer on PrusaSlicer).  Typical places (issue 19):

* a half-way level set in the wedge between two level sets that meet the jump cut
  (:attr:`loadpath.toolpath.Toolpaths.band`), those two already joined across the cut;
* a short piece beside the links of a zig-zag along the edge.

A run is inserted only where it saves a retraction: a run with an end less than ``free_hop`` from
another run's end is left as it is.

Swaps (:func:`_swaps`): the same exchange with the two new ends on two different runs.  Along an
edge the shortest-first pass can pair the ends out of step (``a-b``, ``c`` alone, ``d-e``, ``f`` alone:
a fan of level sets and their half-way pieces along a clamped face); ``d-e`` gives way to ``c-d``
and ``e-f``, its chain parts in two and each half joins one of the runs: one run fewer.

The pipeline does neither on sparse infill (:attr:`loadpath.engines.linking.LinkOptions.insert`).

Each new link passes the tests every link passes (:meth:`loadpath.engines.linking._Layer.geometry`:
inside the region, clear of every path but near its own ends), keeps the clearance from every other
link (the replaced one excepted) and from its partner, and at most ``max_long_link`` pitches long
when straight (the second pass's bound), ``max_edge_link`` along the edge, and crosses no path
(tested exactly, :func:`_crosses`).  Candidates are taken cheapest first (the new links' length less
the old one's), a few per run (:data:`TRIES`), round after round while one is accepted.

Measured (``benchmarks/bench_printability.py``, PrusaSlicer 100 %, retractions in the replaced
blocks, the level sets' band linking on in both): bar 50 -> 45, cantilever 85 -> 65, L-bracket
142 -> 120; the swarm's and the streamlines' cantilever 555 -> 525 and 575 -> 560
(``benchmarks/printability_results.md``, seventeenth round).
"""

from __future__ import annotations

import numpy as np
from loadpath._typing import Points2
from loadpath.engines.linking import _clear_reach, _Laid, _length, _root, _rounded

__all__ = ["insert_runs"]

TRIES = 8
"""Candidate links tried per run and round, the cheapest first.  Bench's solid and sparse layers
(``benchmarks/bench_printability.py`` slices, every engine's linking): 4 left 384 groups of runs
apart, 8 and more 380; unbounded the insertions took a third of the linking's time."""


def _free_chains(n: int, link: dict) -> list[tuple[int, int]]:
    """The chains' free ends ``(head, tail)`` (end indices, ``2 i`` / ``2 i + 1`` of path ``i``)."""
    seen = np.zeros(n, dtype=bool)
    out = []
    for i in range(n):
        if seen[i]:
            continue
        start = 2 * i
        while start in link:  # walk to a free end of i's chain
            start = link[start][0] ^ 1
        end = start
        while True:
            seen[end // 2] = True
            far = end ^ 1
            if far not in link:
                break
            end = link[far][0]
        out.append((start, end ^ 1))
    return out


def _hopped(chains: list[tuple[int, int]], e_pt: np.ndarray, hop: float) -> np.ndarray:
    """Which free ends lie less than ``hop`` mm from another chain's free end: (2 c,) bool, chain
    ``i``'s two ends at ``2 i`` and ``2 i + 1`` (the travel between them goes without a retraction)."""
    from scipy.spatial import cKDTree

    out = np.zeros(2 * len(chains), dtype=bool)
    if hop > 0 and chains:
        free = np.array(chains, dtype=np.int64).ravel()
        pairs = cKDTree(e_pt[free]).query_pairs(hop, output_type="ndarray")
        out[pairs[pairs[:, 0] // 2 != pairs[:, 1] // 2].ravel()] = True
    return out


def insert_runs(  # type: ignore[no-untyped-def]
    layer, link: dict, used: np.ndarray, parent: list[int], samples: dict, stats: dict
) -> int:
    """Insert free runs into links laid before (module docstring); returns how many were.

    Parameters
    ----------
    layer : loadpath.engines.linking._Layer
        The prepared layer (ends, their directions and the geometric tests).
    link : dict
        End -> (other end, link points from this end); changed in place.
    used : (2 n,) bool
        Ends that carry a link; changed in place.
    parent : list of int
        Union-find of the paths (a chain is one set); changed in place.
    samples : dict
        ``(min end, max end)`` -> the link's samples (m, 2) mm; changed in place.
    stats : dict
        ``links``, ``boundary_links``, ``link_mm`` and ``link_ends`` are kept up to date;
        ``inserted`` counts the runs inserted, ``swapped`` the swaps.
    """
    from scipy.spatial import cKDTree

    o, pitch, e_pt = layer.options, layer.pitch, layer.e_pt
    reach = _clear_reach(o, pitch)
    long_mm = max(o.max_long_link, o.max_link) * pitch
    edge_mm = o.max_edge_link * pitch
    near_mm = max(long_mm, edge_mm)
    edge_d = layer.edge_d
    done = 0
    for _ in range(8):  # rounds: a run inserted brings new links that can take others
        chains = _free_chains(len(layer.ps), link)
        linked = np.array(sorted(e for e in link if e < link[e][0]), dtype=np.int64)  # each link once
        if len(chains) < 2 or not len(linked):
            break
        keys = [(int(e), int(link[e][0])) for e in linked]
        all_s = [samples[k] for k in keys]
        owner = np.repeat(np.arange(len(keys)), [len(s) for s in all_s])
        tree = cKDTree(np.concatenate(all_s))
        hopped = _hopped(chains, e_pt, o.free_hop)
        cands = _candidates(chains, keys, link, parent, e_pt, near_mm, hopped)
        swaps = _swaps(chains, keys, link, parent, e_pt, near_mm, hopped)
        if not cands and not swaps:
            break
        changed = False
        gone: set[int] = set()
        fresh = _Laid(reach)  # the links laid this round (not in the tree)
        for _cost, p, x, y, q, k in cands + swaps:  # the insertions first: each leaves no half-chain
            if k in gone or used[x] or used[y] or link.get(p, (None,))[0] != q:
                continue
            swap = x // 2 != y // 2 and _root(parent, x // 2) != _root(parent, y // 2)
            roots = {_root(parent, e // 2) for e in (p, x, y)}
            if len(roots) != (3 if swap else 2):  # a loop (or x and y no longer one run's ends)
                continue
            first = _try(layer, p, x, long_mm, edge_mm, edge_d)
            second = _try(layer, y, q, long_mm, edge_mm, edge_d) if first is not None else None
            if second is None:
                continue
            (pts1, s1, b1), (pts2, s2, b2) = first, second
            if _too_near(s1, s2, reach) or _near_links(tree, owner, k, gone, s1, reach):
                continue
            if _near_links(tree, owner, k, gone, s2, reach):
                continue
            if fresh.near(s1) or fresh.near(s2):
                continue
            fresh.add(s1)
            fresh.add(s2)
            # replace p - q by p - x and y - q
            old_pts = link[p][1]
            del link[p], link[q]
            samples.pop((min(p, q), max(p, q)), None)
            link[p], link[x] = (x, pts1), (p, pts1[::-1])
            link[y], link[q] = (q, pts2), (y, pts2[::-1])
            samples[(min(p, x), max(p, x))] = s1
            samples[(min(y, q), max(y, q))] = s2
            used[x] = used[y] = True
            if swap:  # the chain of p - q parted and both halves joined to other chains
                parent[:] = _chains_of(len(parent), link)
            else:
                parent[_root(parent, x // 2)] = _root(parent, p // 2)
            gone.add(k)
            stats["links"] += 1
            was_edge = _relist(stats, e_pt, p, q, [(p, x, b1), (y, q, b2)])
            stats["boundary_links"] += int(b1) + int(b2) - int(was_edge)
            stats["link_mm"] += _length(pts1) + _length(pts2) - _length(old_pts)
            key = "swapped" if swap else "inserted"
            stats[key] = stats.get(key, 0) + 1
            done += 1
            changed = True
        if not changed:
            break
    return done


def _candidates(  # type: ignore[no-untyped-def]
    chains: list[tuple[int, int]], keys: list[tuple[int, int]], link: dict, parent: list[int],
    e_pt: np.ndarray, near_mm: float, hopped: np.ndarray,
) -> list[tuple[float, int, int, int, int, int]]:
    """Where each free chain might go: ``(cost, p, x, y, q, k)``, link ``k`` from end ``p`` to ``q``
    replaced by ``p - x`` and ``y - q`` (``x``, ``y`` the chain's free ends, each within ``near_mm`` of
    its partner), cost the new links' straight length less the old link's; each chain's
    :data:`TRIES` cheapest, cheapest first.

    A chain with a free end less than a free hop from another chain's (``hopped``, :func:`_hopped`)
    is left as it is: the travel
    between them goes without a retraction already, and inserted elsewhere it could leave the other
    chain apart (the bench's swarm layers: 43 -> 44 groups of runs).
    """
    from scipy.spatial import cKDTree

    chains = [c for i, c in enumerate(chains) if not (hopped[2 * i] or hopped[2 * i + 1])]
    if not chains:
        return []
    nl = len(keys)
    kp = np.array(keys, dtype=np.int64)
    sides = np.concatenate([kp, kp[:, ::-1]])  # row j: (p, q) of link j % nl, either way
    old = np.array([_length(link[int(p)][1]) for p, _ in keys])
    ends = np.array([(a, b) for a, b in chains] + [(b, a) for a, b in chains], dtype=np.int64)
    hits = cKDTree(e_pt[sides[:, 0]]).query_ball_point(e_pt[ends[:, 0]], near_mm)
    ci = np.repeat(np.arange(len(ends)), [len(h) for h in hits])
    if not len(ci):
        return []
    j = np.concatenate([np.asarray(h, dtype=np.int64) for h in hits])
    x, y = ends[ci, 0], ends[ci, 1]
    p, q = sides[j, 0], sides[j, 1]
    ok = np.hypot(*(e_pt[y] - e_pt[q]).T) <= near_mm
    x, y, p, q, j, ci = x[ok], y[ok], p[ok], q[ok], j[ok], ci[ok]
    cost = np.hypot(*(e_pt[x] - e_pt[p]).T) + np.hypot(*(e_pt[y] - e_pt[q]).T) - old[j % nl]
    chain = ci % len(chains)
    order = np.lexsort((cost, chain))
    out = []
    taken: dict[int, int] = {}
    for i in order.tolist():
        c = int(chain[i])
        if taken.get(c, 0) >= TRIES or _root(parent, int(p[i]) // 2) == _root(parent, int(x[i]) // 2):
            continue
        taken[c] = taken.get(c, 0) + 1
        out.append((float(cost[i]), int(p[i]), int(x[i]), int(y[i]), int(q[i]), int(j[i] % nl)))
    out.sort()
    return out


SWAP_NEAR = 3
"""Free ends tried beside each end of a link for a swap (:func:`_swaps`), the nearest first."""

SWAP_TRIES = 3
"""Swaps tried per free end and round, the cheapest first (:func:`_swaps`)."""


def _swaps(  # type: ignore[no-untyped-def]
    chains: list[tuple[int, int]], keys: list[tuple[int, int]], link: dict, parent: list[int],
    e_pt: np.ndarray, near_mm: float, hopped: np.ndarray,
) -> list[tuple[float, int, int, int, int, int]]:
    """Links that two free chains could share: ``(cost, p, x, y, q, k)``, link ``k`` from ``p`` to ``q``
    replaced by ``p - x`` and ``y - q``, ``x`` a free end of one chain within ``near_mm`` of ``p``, ``y``
    one of another within ``near_mm`` of ``q``; cost as :func:`_candidates`', cheapest first.

    Where the greedy linking pairs the ends along an edge out of step (``a-b``, ``c`` alone,
    ``d-e``, ``f`` alone, the links along the edge), ``c`` and ``f`` each stay a run's end; the swap
    ``c-d``, ``e-f`` joins both runs through the link's chain: the chain of ``d-e`` parts in two and
    each half joins one run, one run fewer (typical: a fan of level sets and their half-way pieces
    along a face).  Free ends less than a free hop from another chain's free end (``hopped``,
    :func:`_hopped`) are left (the travel between them is not retracted already).
    """
    from scipy.spatial import cKDTree

    if len(chains) < 2 or not keys:
        return []
    free = np.array(chains, dtype=np.int64).ravel()[~hopped]
    owner = np.repeat(np.arange(len(chains)), 2)[~hopped]
    if len(free) < 2:
        return []
    kp = np.array(keys, dtype=np.int64)
    old = np.array([_length(link[int(p)][1]) for p, _ in keys])
    k = min(SWAP_NEAR, len(free))
    tree = cKDTree(e_pt[free])
    dp, ip = tree.query(e_pt[kp[:, 0]], k=k, distance_upper_bound=near_mm)
    dq, iq = tree.query(e_pt[kp[:, 1]], k=k, distance_upper_bound=near_mm)
    dp, ip, dq, iq = (np.reshape(a, (len(kp), k)) for a in (dp, ip, dq, iq))
    out = []
    for a in range(k):
        for b in range(k):
            ok = np.isfinite(dp[:, a]) & np.isfinite(dq[:, b])
            j = np.flatnonzero(ok)
            j = j[owner[ip[j, a]] != owner[iq[j, b]]]
            for jj in j.tolist():
                x, y = int(free[ip[jj, a]]), int(free[iq[jj, b]])
                p, q = int(kp[jj, 0]), int(kp[jj, 1])
                if len({_root(parent, e // 2) for e in (p, x, y)}) == 3:
                    out.append((float(dp[jj, a] + dq[jj, b] - old[jj]), p, x, y, q, jj))
    out.sort()
    tried: dict[int, int] = {}
    kept = []
    for c in out:  # each free end in its SWAP_TRIES cheapest only: the links' tests are the cost
        x, y = c[2], c[3]
        if tried.get(x, 0) < SWAP_TRIES and tried.get(y, 0) < SWAP_TRIES:
            tried[x], tried[y] = tried.get(x, 0) + 1, tried.get(y, 0) + 1
            kept.append(c)
    return kept


def _chains_of(n: int, link: dict) -> list[int]:
    """Union-find parents of ``n`` paths joined by the links ``link`` (each set one chain)."""
    parent = list(range(n))
    for e, (f, _pts) in link.items():
        ra, rb = _root(parent, e // 2), _root(parent, f // 2)
        if ra != rb:
            parent[ra] = rb
    return parent


def _try(  # type: ignore[no-untyped-def]
    layer, ea: int, eb: int, long_mm: float, edge_mm: float, edge_d: np.ndarray
):
    """The link from ``ea`` to ``eb`` (points, samples, boundary) that the layer's tests accept:
    straight when at most ``long_mm`` long and inside the region, else along the edge when both
    ends are near it; or None."""
    import shapely

    o, pitch = layer.options, layer.pitch
    gap = float(np.hypot(*(layer.e_pt[eb] - layer.e_pt[ea])))
    straight_ok = gap <= long_mm and bool(
        layer.grown.covers(shapely.LineString([layer.e_pt[ea], layer.e_pt[eb]]))
    )
    near = o.edge_reach * pitch
    edge_ok = bool(edge_d[ea] <= near and edge_d[eb] <= near) and gap <= edge_mm
    if not (straight_ok or edge_ok):
        return None
    found = layer.geometry(ea, eb, straight_ok, edge_ok)
    if found is None or _crosses(layer, found[0], ea, eb):
        return None
    return found


def _crosses(layer, pts: Points2, ea: int, eb: int) -> bool:  # type: ignore[no-untyped-def]
    """Whether a link crosses or touches a path anywhere but at the two ends it joins.

    The sampled clearance test (a quarter pitch apart, within the clearance less half a step) can
    miss a crossing where the clearance is a small share of the pitch (sparse infill: a fifth), and
    an inserted link may be several pitches long.
    """
    import shapely

    lines = getattr(layer, "_lines", None)
    if lines is None:
        lines = np.array([shapely.LineString(p.points) for p in layer.ps], dtype=object)
        layer._lines = lines
        layer._lines_tree = shapely.STRtree(lines)
    link = shapely.LineString(pts)
    own = {ea // 2: layer.e_pt[ea], eb // 2: layer.e_pt[eb]}
    for h in layer._lines_tree.query(link, predicate="intersects"):
        h = int(h)
        if h not in own:
            return True
        meet = shapely.intersection(link, lines[h])
        if shapely.hausdorff_distance(meet, shapely.Point(own[h])) > 1e-6:
            return True
    return False


def _too_near(s1: Points2, s2: Points2, reach: float) -> bool:
    from scipy.spatial import cKDTree

    return bool(cKDTree(s1).query_ball_point(s2, reach, return_length=True).any())


def _near_links(  # type: ignore[no-untyped-def]
    tree, owner: np.ndarray, k: int, gone: set[int], s: Points2, reach: float
) -> bool:
    """Whether samples ``s`` come within ``reach`` of a link other than link ``k`` (being replaced)
    and those replaced this round."""
    hits = tree.query_ball_point(s, reach)
    for h in hits:
        for i in h:
            j = int(owner[i])
            if j != k and j not in gone:
                return True
    return False


def _relist(stats: dict, e_pt: np.ndarray, p: int, q: int, new: list[tuple[int, int, bool]]) -> bool:
    """Keep ``stats["link_ends"]`` (the links by their end points, whether along the edge) as the
    links now are: the link ``p - q`` out, ``new`` in.  Returns whether ``p - q`` ran along the edge."""
    ends = stats.setdefault("link_ends", [])
    a, b = _rounded(e_pt[p]), _rounded(e_pt[q])
    was = [t for t in ends if {t[0], t[1]} == {a, b}]
    ends[:] = [t for t in ends if {t[0], t[1]} != {a, b}]
    for x, y, boundary in new:
        ends.append((_rounded(e_pt[x]), _rounded(e_pt[y]), bool(boundary)))
    return bool(was and was[0][2])
