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
  none is left or the time ``budget`` runs out; then each loop left loses its longest link.

Solved by HiGHS through :func:`scipy.optimize.milp` (scipy, a base dependency).  The links found are
laid first by the linking (its ``prefer``), which then continues as usual (the greedy pass, the long
links, the insertions), and the result is kept where it leaves fewer runs than the greedy ways.

Measured on the captured layers of the sweep's PrusaSlicer 100 % files (candidate links that pass
alone; the greedy's runs -> the program's): the bench's bar 5 -> 4 and 3 -> 2, the dog-bone 11 -> 9
and 13 -> 9, the T 33 -> 20 and 30 -> 21 (0.03-0.2 s; the T's 4-27 s to prove its optimum).
"""

from __future__ import annotations

import time

import numpy as np

__all__ = ["exact_links"]


def exact_links(layer, budget: float) -> list[tuple[tuple, tuple, bool]]:  # type: ignore[no-untyped-def]
    """The links of the program (module docstring) as the linking's ``prefer`` takes them.

    Parameters
    ----------
    layer : loadpath.engines.linking._Layer
        The prepared layer: its ends, candidate links (``a``, ``b``, ``straight``, ``near_edge``) and
        the geometric test.
    budget : float, s
        Time for the solves (the test of the candidates comes first and is not counted).

    Returns
    -------
    list of (end point, end point, boundary)
        End points as :func:`loadpath.engines.linking._rounded` names them; empty when there is no
        candidate, or the solver found no solution in the budget.
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
    rows.append(_pair_rows(pairs[~shared], m))
    # two links between the same two paths close a loop
    p = np.sort(e // 2, axis=1)
    _, group, counts = np.unique(p, axis=0, return_inverse=True, return_counts=True)
    loops = [np.flatnonzero(group.ravel() == g) for g in np.flatnonzero(counts > 1)]
    length = np.array([_length(q) for q in pts])
    # most links first; among as many, the shortest (the lengths' sum is below 1)
    cost = -1.0 + 0.5 * length / max(float(length.sum()), 1e-9)
    start = time.perf_counter()
    x = None
    while True:
        left = budget - (time.perf_counter() - start)
        if left <= 0:
            break
        cons = [r for r in rows if r is not None]
        if loops:
            cons.append(_loop_rows(loops, m))
        res = milp(
            cost, constraints=cons, integrality=np.ones(m), bounds=Bounds(0, 1), options={"time_limit": left}
        )
        if res.x is None:  # no solution within the time (HiGHS status 1 without an incumbent)
            break
        x = np.round(res.x).astype(bool)
        found = _loops_of(e[x], col[x], n)
        if not found:
            break
        loops.extend(found)
        if res.status != 0:  # out of time: what is left of the budget cannot prove another
            break
    if x is None:
        return []
    for loop in _loops_of(e[x], col[x], n):  # out of time with loops left: each loses its longest link
        x[loop[np.argmax(length[loop])]] = False
    chosen = np.flatnonzero(x)
    return [(_rounded(layer.e_pt[e[j, 0]]), _rounded(layer.e_pt[e[j, 1]]), boundary[j]) for j in chosen]


def _pair_rows(pairs: np.ndarray, m: int):  # type: ignore[no-untyped-def]
    """``x_j + x_k <= 1`` for each pair ``(j, k)``; None when there is none."""
    from scipy import sparse
    from scipy.optimize import LinearConstraint

    if not len(pairs):
        return None
    r = np.repeat(np.arange(len(pairs)), 2)
    a = sparse.csr_matrix((np.ones(r.size), (r, pairs.ravel())), shape=(len(pairs), m))
    return LinearConstraint(a, 0, 1)


def _loop_rows(loops: list[np.ndarray], m: int):  # type: ignore[no-untyped-def]
    """At most ``len(loop) - 1`` of each loop's links."""
    from scipy import sparse
    from scipy.optimize import LinearConstraint

    r = np.repeat(np.arange(len(loops)), [len(q) for q in loops])
    a = sparse.csr_matrix((np.ones(r.size), (r, np.concatenate(loops))), shape=(len(loops), m))
    return LinearConstraint(a, 0, np.array([len(q) - 1 for q in loops], dtype=float))


def _loops_of(links: np.ndarray, cols: np.ndarray, n: int) -> list[np.ndarray]:
    """The loops that links ``(k, 2)`` (ends; their columns ``cols``) close among ``n`` paths: per
    connected set of paths with as many links as paths, its links' columns."""
    parent = np.arange(n)

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for a, b in links // 2:
        ra, rb = root(int(a)), root(int(b))
        if ra != rb:
            parent[ra] = rb
    comp = np.array([root(int(a)) for a in links[:, 0] // 2], dtype=np.int64)
    out = []
    for c in np.unique(comp):
        mine = comp == c
        paths = np.unique(links[mine] // 2)
        if int(mine.sum()) >= len(paths):
            out.append(cols[mine])
    return out
