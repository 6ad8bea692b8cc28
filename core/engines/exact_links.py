"""The links of a layer chosen all at once: an integer program over every candidate link.

The linking's greedy passes (:mod:`loadpath.engines.linking`) lay one link at a time and never take
one back, and their repairs (:mod:`loadpath.engines.insertion`) exchange one link at a time.  Where
a level set grazes the edge, or a family of level sets converges on a re-entrant corner, the
zig-zag along the edge has to change step over a whole stretch to take those ends in, and no single
exchange does it: a longer alternating exchange closes a loop (a path linked to its neighbour at
both ends), so the search for one finds none (on the bench's bar, the dog-bone and the T of the
2026-12-07 sweep, none within four links).

Here every candidate link that passes the geometric tests on its own
(:meth:`loadpath.engines.linking._Layer.geometry`) is a binary unknown, and the program asks for the
most links (each one a run fewer), then the shortest, subject to

* each end linked at most once;
* no two links closer than the clearance (the test each link laid meets against those before it);
* no loop: two links between the same two paths exclude each other from the start, and a longer
  loop of the solution found is excluded and the program solved again (lazy constraints), until
  none is left, for at most :data:`ROUNDS` solves of at most ``nodes`` branch-and-bound nodes each
  (counts, not times, so that the links are the same on every machine); each loop left then loses
  its longest link.

Solved by HiGHS through :func:`scipy.optimize.milp` (scipy, a base dependency): in integers up to
:data:`MIP_CANDIDATES` candidates, beyond that the linear relaxation, whose links above one half are
laid first.  The links found are laid first by the linking (its ``prefer``), which then continues
as usual (the greedy pass, the long links, the insertions), and the result is kept where it leaves
fewer runs than the greedy ways.

Measured on captured layers (PrusaSlicer 2.5, 100 %; the greedy ways' runs -> with the program, and
the linking's time added): the bench's bar 5 -> 4 and 3 -> 2; the sweep's dog-bone 11 -> 9 and
13 -> 9, its T 33 -> 25 and 30 -> 22 (level sets) and 86 -> 78 (swarm); the tests' specimen 5 -> 3
and 7 -> 5, L-bracket 24 -> 22 and 25 -> 22, shelf bracket 220 -> 196 (swarm, 851 paths); 0.1-0.7 s
more per layer.
"""

from __future__ import annotations

import time

import numpy as np

__all__ = ["exact_links", "MIP_CANDIDATES", "ROUNDS", "GUARD_S"]

MIP_CANDIDATES = 300
"""Layers with at most this many candidate links are solved in integers; larger ones by the linear
relaxation, its links above one half laid first, the surest first, and the greedy passes going on
from them.  HiGHS's root node alone took 0.7 s per solve on a layer of 1781 candidates (a swarm layer
of a shelf bracket); the relaxation takes a few hundredths, and on the T of the sweep it gave fewer
runs (33 -> 25 and 30 -> 22, the integer program 25 and 24)."""

ROUNDS = 8
"""Solves at most: each excludes the loops the one before it closed."""

GUARD_S = 5.0
"""Seconds all the solves of a layer may take, a guard only: the node count bounds the work, so the
links are the same on any machine unless this is reached (then they depend on the machine's speed)."""


def exact_links(  # type: ignore[no-untyped-def]
    layer, nodes: int, integers: int = MIP_CANDIDATES
) -> list[tuple[tuple, tuple, bool]]:
    """The links of the program (module docstring) as the linking's ``prefer`` takes them.

    Parameters
    ----------
    layer : loadpath.engines.linking._Layer
        The prepared layer: its ends, candidate links (``a``, ``b``, ``straight``, ``near_edge``) and
        the geometric test.
    nodes : int
        Branch-and-bound nodes each solve may take (a count, not a time: the same links on any
        machine).
    integers : int
        Most candidates solved in integers; more are solved by the linear relaxation.

    Returns
    -------
    list of (end point, end point, boundary)
        End points as :func:`loadpath.engines.linking._rounded` names them; empty when there is no
        candidate, or the solver found no solution within its nodes.
    """
    from loadpath.engines.linking import _clear_reach, _length, _rounded
    from scipy import sparse
    from scipy.optimize import Bounds, LinearConstraint, milp
    from scipy.spatial import cKDTree

    n = len(layer.ps)
    ends, pts, samples, boundary = [], [], [], []
    for k in range(len(layer.a)):
        ea, eb = int(layer.a[k]), int(layer.b[k])
        if ea // 2 == eb // 2:
            continue
        found = layer.geometry(ea, eb, bool(layer.straight[k]), bool(layer.near_edge[k]))
        if found is not None:
            ends.append((ea, eb))
            pts.append(found[0])
            samples.append(found[1])
            boundary.append(bool(found[2]))
    m = len(ends)
    if m == 0:
        return []
    e = np.array(ends, dtype=np.int64)
    col = np.arange(m)
    degree = sparse.csr_matrix((np.ones(2 * m), (e.T.ravel(), np.tile(col, 2))), shape=(2 * n, m))
    rows = [LinearConstraint(degree, 0, 1)]
    # links closer than the clearance, not sharing an end (those the degree rows exclude)
    owner = np.repeat(col, [len(s) for s in samples])
    reach = _clear_reach(layer.options, layer.pitch)
    near = cKDTree(np.concatenate(samples)).query_pairs(reach, output_type="ndarray")
    pairs = np.unique(np.sort(owner[near], axis=1), axis=0) if len(near) else np.zeros((0, 2), np.int64)
    pairs = pairs[pairs[:, 0] != pairs[:, 1]]
    shared = (e[pairs[:, 0], None, :] == e[pairs[:, 1], :, None]).any(axis=(1, 2))
    pairs = pairs[~shared]
    if len(pairs):
        rows.append(_all_but_one(list(pairs), m))
    # two links between the same two paths close a loop
    p = np.sort(e // 2, axis=1)
    _, group, counts = np.unique(p, axis=0, return_inverse=True, return_counts=True)
    loops = [np.flatnonzero(group.ravel() == g) for g in np.flatnonzero(counts > 1)]
    length = np.array([_length(q) for q in pts])
    # most links first; among as many, the shortest (the lengths' sum is below 1)
    cost = -1.0 + 0.5 * length / max(float(length.sum()), 1e-9)
    kinds = np.full(m, float(m <= integers))  # in integers, or the relaxation
    start = time.perf_counter()
    x = None
    for _ in range(ROUNDS):
        left = GUARD_S - (time.perf_counter() - start)
        if left <= 0:
            break
        cons = rows + ([_all_but_one(loops, m)] if loops else [])
        opts = {"node_limit": int(nodes), "time_limit": left}
        res = milp(cost, constraints=cons, integrality=kinds, bounds=Bounds(0, 1), options=opts)
        if res.x is None:  # no solution within the nodes (HiGHS status 1 without an incumbent)
            break
        value = res.x
        x = value > 0.5
        found = _loops_of(e[x], col[x], n)
        if not found:
            break
        loops.extend(found)
        if res.status != 0:  # at the node limit: another round would not prove more
            break
    if x is None:
        return []
    for loop in _loops_of(e[x], col[x], n):  # loops left: each loses its longest link
        x[loop[np.argmax(length[loop])]] = False
    chosen = np.flatnonzero(x)
    chosen = chosen[np.lexsort((length[chosen], -value[chosen]))]  # the surest first (the relaxation)
    return [(_rounded(layer.e_pt[e[j, 0]]), _rounded(layer.e_pt[e[j, 1]]), boundary[j]) for j in chosen]


def _all_but_one(groups: list[np.ndarray], m: int):  # type: ignore[no-untyped-def]
    """At most ``len(group) - 1`` of each group's links (``m`` columns): a loop's links, or a pair
    of links too close to lie together (``x_j + x_k <= 1``)."""
    from scipy import sparse
    from scipy.optimize import LinearConstraint

    r = np.repeat(np.arange(len(groups)), [len(q) for q in groups])
    a = sparse.csr_matrix((np.ones(r.size), (r, np.concatenate(groups))), shape=(len(groups), m))
    return LinearConstraint(a, 0, np.array([len(q) - 1 for q in groups], dtype=float))


def _loops_of(links: np.ndarray, cols: np.ndarray, n: int) -> list[np.ndarray]:
    """The loops that links ``(k, 2)`` (ends; their columns ``cols``) close among ``n`` paths: per
    connected set of paths with as many links as paths, its links' columns."""
    from loadpath.engines.linking import _root

    parent = list(range(n))
    for a, b in links // 2:
        ra, rb = _root(parent, int(a)), _root(parent, int(b))
        if ra != rb:
            parent[ra] = rb
    comp = np.array([_root(parent, int(a)) for a in links[:, 0] // 2], dtype=np.int64)
    out = []
    for c in np.unique(comp):
        mine = comp == c
        paths = np.unique(links[mine] // 2)
        if int(mine.sum()) >= len(paths):
            out.append(cols[mine])
    return out
