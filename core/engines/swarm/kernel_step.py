"""The compiled swarm: one iteration of Algorithm 1 and the loop of iterations (see :mod:`.step`).

:mod:`.step` documents the method stage by stage; this module is its compiled form (numba,
``cache=True``).  Every stage is the loop form of the numpy expressions the engine used before
(same formulas, same order of the operations that decide a result), so the paths are the same up
to rounding.  It is longer than the house limit because the stages share the agent table and
splitting them would only pass it around.

The agents of a step are one float table, one row per agent of the extended chain (moving agents,
boundary agents, agents spawned this step), columns:

=========  =================================================================================
``T``      ideal location t (boundary agents: reference point on the boundary), mm
``E``      along-direction of the agent's frame (stress direction, or boundary tangent)
``MASS``   virtual mass
``H``      last displacement direction (zero for boundary agents)
``P``      location x(k) (spawned and boundary agents: t)
``KIND``   0 moving agent, 1 spawned this step, -1 boundary agent
``CHAIN``  chain number
``WIN``    kill/spawn window
``PID``    path id (-1 boundary agent, -3 spawned by the kill/spawn choice, id assigned later)
``SEG``    boundary segment of a boundary agent (-1 otherwise)
=========  =================================================================================

Statistics are counted in an int array (:data:`COUNTERS` names its entries).  A QP the exact
solver does not finish goes to OSQP through :func:`loadpath.engines.swarm.qp.osqp_fallback`
(numba's object mode), which raises :class:`~loadpath.errors.SolverError` if OSQP fails too.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from loadpath.engines.finish import kernel_geom as kg
from loadpath.engines.swarm import qp as _qp
from loadpath.engines.swarm._jit import announce_compile, njit, njit_inline, objmode
from loadpath.engines.swarm.chain import BOUNDARY_SLIDE, BOX_ACROSS, BOX_ALONG, MASS_FLOOR, WEIGHT_FLOOR
from loadpath.engines.swarm.kernel_qp import chain_positions, chain_potentials, chain_qp, solve_box_qp

__all__ = ["StepParams", "COUNTERS", "run_swarm", "step"]

StepParams = namedtuple(
    "StepParams",
    "K window kill_below spawn_above min_gap ray_reach merge_reach grow_free_ends edge_gap qp_max_iter "
    "qp_tol cos_turn",
)
"""The :class:`~.step.SwarmParams` the kernels use, as plain numbers (see there)."""

COUNTERS = (
    "steps",
    "step_limit_hit",
    "no_direction",
    "blocked",
    "spawn_free_end",
    "qp_solves",
    "qp_unknowns",
    "qp_exact",
    "qp_osqp_solved",
    "kills",
    "spawns",
    "killed_same_step",
    "killed_too_close",
    "merged",
)
"""Names of the entries of the statistics array, in order."""

(
    _C_STEPS,
    _C_LIMIT,
    _C_NODIR,
    _C_BLOCKED,
    _C_FREE_END,
    _C_SOLVES,
    _C_UNKNOWNS,
    _C_EXACT,
    _C_OSQP,
    _C_KILLS,
    _C_SPAWNS,
    _C_SAME_STEP,
    _C_TOO_CLOSE,
    _C_MERGED,
) = range(len(COUNTERS))

_TX, _TY, _EX, _EY, _MASS, _HX, _HY, _PX, _PY, _KIND, _CHAIN, _WIN, _PID, _SEG = range(14)
_NCOL = 14


# ----------------------------------------------------------------------------------------------
# small helpers
# ----------------------------------------------------------------------------------------------


@njit_inline
def _unit2(x: float, y: float) -> tuple[float, float]:
    n = np.sqrt(x * x + y * y)
    if n == 0.0:
        n = 1.0
    return x / n, y / n


@njit
def _take(a: np.ndarray, keep: np.ndarray) -> np.ndarray:
    """Rows of ``a`` where ``keep`` (1-D or 2-D ``a``)."""
    return a[np.flatnonzero(keep)]


@njit_inline
def _point_segment(px: float, py: float, ax: float, ay: float, bx: float, by: float) -> float:
    """Distance from a point to the segment ``a -> b``."""
    ex = bx - ax
    ey = by - ay
    den = ex * ex + ey * ey
    u = ((px - ax) * ex + (py - ay) * ey) / (den if den > 0 else 1.0)
    u = min(max(u, 0.0), 1.0)
    qx = ax + u * ex - px
    qy = ay + u * ey - py
    return np.sqrt(qx * qx + qy * qy)


@njit_inline
def _row(
    out: np.ndarray,
    i: int,
    tx: float,
    ty: float,
    ex: float,
    ey: float,
    mass: float,
    hx: float,
    hy: float,
    px: float,
    py: float,
    kind: float,
    chain: float,
    pid: float,
    seg: float,
) -> None:
    out[i, _TX] = tx
    out[i, _TY] = ty
    out[i, _EX] = ex
    out[i, _EY] = ey
    out[i, _MASS] = mass
    out[i, _HX] = hx
    out[i, _HY] = hy
    out[i, _PX] = px
    out[i, _PY] = py
    out[i, _KIND] = kind
    out[i, _CHAIN] = chain
    out[i, _WIN] = 0.0
    out[i, _PID] = pid
    out[i, _SEG] = seg


# ----------------------------------------------------------------------------------------------
# stage 1: step direction (Eq. 2 with momentum), ideal locations, virtual masses
# ----------------------------------------------------------------------------------------------


@njit
def _ideal(
    r: kg.RasterData, pos: np.ndarray, head: np.ndarray, start: np.ndarray, pitch: float, counts: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    n = pos.shape[0]
    s, mass, valid = kg.raster_sample(r, pos)
    nvalid = int(np.sum(valid))
    if nvalid < n:
        # no direction: the mean heading of the agent and its chain neighbours (or its own)
        mean = head.copy()
        for i in range(n - 1):
            if not start[i + 1]:
                mean[i, 0] += head[i + 1, 0]
                mean[i, 1] += head[i + 1, 1]
        for i in range(1, n):
            if not start[i]:
                mean[i, 0] += head[i - 1, 0]
                mean[i, 1] += head[i - 1, 1]
        for i in range(n):
            if valid[i]:
                continue
            mx, my = _unit2(mean[i, 0], mean[i, 1])
            if not mx * mx + my * my > 0.25:
                mx, my = head[i, 0], head[i, 1]
            s[i, 0] = mx
            s[i, 1] = my
            mass[i] = 0.0
        counts[_C_NODIR] += n - nvalid
    sdir = np.zeros((n, 2))
    t = np.zeros((n, 2))
    for i in range(n):
        sg = 1.0 if s[i, 0] * head[i, 0] + s[i, 1] * head[i, 1] >= 0 else -1.0
        sdir[i, 0] = sg * s[i, 0]
        sdir[i, 1] = sg * s[i, 1]
        t[i, 0] = pos[i, 0] + pitch * sdir[i, 0]
        t[i, 1] = pos[i, 1] + pitch * sdir[i, 1]
    return t, sdir, mass


# ----------------------------------------------------------------------------------------------
# stage 2: blocked agents end their path (last partial step to the edge); chains split
# ----------------------------------------------------------------------------------------------


@njit
def _remove_blocked(
    dom: kg.DomainData,
    grid: kg.GridData,
    prm: StepParams,
    pitch: float,
    pos: np.ndarray,
    head: np.ndarray,
    pid: np.ndarray,
    start: np.ndarray,
    t: np.ndarray,
    sdir: np.ndarray,
    mass: np.ndarray,
    counts: np.ndarray,
):
    n = pos.shape[0]
    in_dom = kg.inside(dom, t)
    ok = in_dom & kg.grid_free_path(grid, pos, t, pid)
    # where the followed stress jumps (the max-|sigma| direction turning by ~90 degrees where the
    # principal stresses cross, e.g. a bent bar's neutral axis) the path ends instead of kinking
    for i in range(n):
        if mass[i] > 0.0 and sdir[i, 0] * head[i, 0] + sdir[i, 1] * head[i, 1] < prm.cos_turn:
            ok[i] = False
    last = np.zeros((0, 2))
    last_pid = np.zeros(0, dtype=np.int64)
    if np.all(ok):
        return pos, head, pid, start, t, sdir, mass, last, last_pid
    counts[_C_BLOCKED] += n - int(np.sum(ok))
    ends = np.flatnonzero(~in_dom)
    if len(ends):
        dist, _, tangent, seg = kg.ray(dom, pos[ends], sdir[ends], 2.0 * pitch)
        ne = len(ends)
        reach = np.zeros(ne)
        for k in range(ne):
            if seg[k] >= 0:
                # the end point keeps `edge_gap` pitches from the layer's edge and half a pitch from
                # beads laid before, measured across the boundary
                gap = (prm.edge_gap if dom.edge[seg[k]] else 0.5) * pitch
                e = ends[k]
                cos = abs(sdir[e, 0] * tangent[k, 1] - sdir[e, 1] * tangent[k, 0])
                reach[k] = dist[k] - gap / max(cos, 0.5)
        go = (reach > 0.1 * pitch) & (reach <= pitch)
        eg = ends[go]
        ng = len(eg)
        if ng:
            rg = reach[go]
            p0 = pos[eg]
            gp = pid[eg]
            q = np.zeros((ng, 2))
            both = np.zeros((2 * ng, 2))
            for k in range(ng):
                q[k, 0] = p0[k, 0] + rg[k] * sdir[eg[k], 0]
                q[k, 1] = p0[k, 1] + rg[k] * sdir[eg[k], 1]
                both[k] = q[k]
                both[ng + k, 0] = 0.5 * (q[k, 0] + p0[k, 0])
                both[ng + k, 1] = 0.5 * (q[k, 1] + p0[k, 1])
            gp2 = np.concatenate((gp, gp))
            clear = kg.grid_clear_of(grid, both, gp2, (prm.min_gap + 1.0 / 12.0) * pitch)
            fine = kg.grid_free_path(grid, p0, q, gp) & clear[:ng] & clear[ng:]
            # two ends converging on one boundary must not finish closer than the gap: keep the first
            fi = np.flatnonzero(fine)
            if len(fi) > 1:
                lim = (prm.min_gap * pitch) ** 2
                drop = np.zeros(len(fi), dtype=np.bool_)
                for jj in range(len(fi)):
                    for ii in range(jj):
                        dx = q[fi[ii], 0] - q[fi[jj], 0]
                        dy = q[fi[ii], 1] - q[fi[jj], 1]
                        if dx * dx + dy * dy < lim:
                            drop[jj] = True
                            break
                for jj in range(len(fi)):
                    if drop[jj]:
                        fine[fi[jj]] = False
            last = _take(q, fine)
            last_pid = _take(gp, fine)
            kg.grid_mark(grid, _take(p0, fine), last, last_pid)
    new_start = np.zeros(n, dtype=np.bool_)
    for i in range(n):
        new_start[i] = start[i] or (i > 0 and not ok[i - 1])
    keep = np.flatnonzero(ok)
    start2 = new_start[keep]
    if len(start2):
        start2[0] = True
    return pos[keep], head[keep], pid[keep], start2, t[keep], sdir[keep], mass[keep], last, last_pid


# ----------------------------------------------------------------------------------------------
# stage 3: the extended chain (boundary agents at chain ends, new agents at free ends)
# ----------------------------------------------------------------------------------------------


@njit
def _windows(tab: np.ndarray, window: int) -> None:
    """Window of each agent: rank of moving agents within their chain // window, numbered from 0."""
    m = tab.shape[0]
    w = max(1, window)
    win = -1
    rank = -1
    key_c = -1.0
    key_r = -1
    for i in range(m):
        if i == 0 or tab[i, _CHAIN] != tab[i - 1, _CHAIN]:
            rank = -1
        if tab[i, _KIND] >= 0:
            rank += 1
        r = max(rank, 0) // w
        if i == 0 or tab[i, _CHAIN] != key_c or r != key_r:
            win += 1
            key_c = tab[i, _CHAIN]
            key_r = r
        tab[i, _WIN] = win


@njit
def _extend(
    dom: kg.DomainData,
    grid: kg.GridData,
    prm: StepParams,
    pitch: float,
    pos: np.ndarray,
    head: np.ndarray,
    pid: np.ndarray,
    start: np.ndarray,
    t: np.ndarray,
    sdir: np.ndarray,
    mass: np.ndarray,
    next_pid: int,
    counts: np.ndarray,
) -> tuple[np.ndarray, int]:
    n = pos.shape[0]
    starts = np.flatnonzero(start)
    nc = len(starts)
    ends = np.zeros(nc, dtype=np.int64)
    for c in range(nc - 1):
        ends[c] = starts[c + 1] - 1
    ends[nc - 1] = n - 1
    chain = np.zeros(n)
    c = -1
    for i in range(n):
        if start[i]:
            c += 1
        chain[i] = c
    src = np.concatenate((starts, ends))
    dirs = np.zeros((2 * nc, 2))
    for k in range(nc):  # radial directions out of the chain ends (Eq. 5: right of travel)
        dirs[k, 0] = -head[starts[k], 1]
        dirs[k, 1] = head[starts[k], 0]
        dirs[nc + k, 0] = head[ends[k], 1]
        dirs[nc + k, 1] = -head[ends[k], 0]
    ts = t[src]
    dist, point, tangent, seg = kg.ray(dom, ts, dirs, prm.ray_reach * pitch)
    hit = np.isfinite(dist)
    spawn = np.zeros(2 * nc, dtype=np.bool_)
    cand = np.zeros((2 * nc, 2))
    if prm.grow_free_ends:
        for k in range(2 * nc):
            cand[k, 0] = ts[k, 0] + pitch * dirs[k, 0]
            cand[k, 1] = ts[k, 1] + pitch * dirs[k, 1]
        spawn = (
            ~hit & kg.inside(dom, cand) & kg.grid_free_for(grid, cand, np.full(2 * nc, -2, dtype=np.int64))
        )
        for k in range(2 * nc):
            if not spawn[k]:
                continue
            cc = k % nc
            nb = min(starts[cc] + 1, ends[cc]) if k < nc else max(ends[cc] - 1, starts[cc])
            s = src[k]
            ax, ay = _unit2(t[s, 0] - t[nb, 0], t[s, 1] - t[nb, 1])
            square = abs(head[s, 0] * ax + head[s, 1] * ay) < 0.5
            spawn[k] = nb != s and square and ax * dirs[k, 0] + ay * dirs[k, 1] > 0.8
            if spawn[k]:
                dmin = np.inf
                for j in range(n):
                    dmin = min(dmin, np.sqrt((cand[k, 0] - t[j, 0]) ** 2 + (cand[k, 1] - t[j, 1]) ** 2))
                if dmin < 0.75 * pitch:
                    spawn[k] = False
        if nc == 1 and n == 1 and spawn[0] and spawn[1]:
            spawn[1] = False  # a lone agent grows on one side per step
        counts[_C_FREE_END] += int(np.sum(spawn))
    new_pid = np.full(2 * nc, -1.0)
    for k in range(2 * nc):
        if spawn[k]:
            new_pid[k] = next_pid
            next_pid += 1
    m = n + int(np.sum(hit)) + int(np.sum(spawn))
    tab = np.zeros((m, _NCOL))
    r = 0
    for cc in range(nc):
        for k in (cc, nc + cc):
            if k == nc + cc:
                for i in range(starts[cc], ends[cc] + 1):
                    _row(
                        tab, r, t[i, 0], t[i, 1], sdir[i, 0], sdir[i, 1], mass[i], head[i, 0], head[i, 1],
                        pos[i, 0], pos[i, 1], 0.0, chain[i], float(pid[i]), -1.0,
                    )  # fmt: skip
                    r += 1
            s = src[k]
            # order along the chain: left boundary, left spawn, agents, right spawn, right boundary
            order = (0, 1) if k < nc else (1, 0)
            for o in order:
                if o == 0 and hit[k]:
                    _row(
                        tab, r, point[k, 0], point[k, 1], tangent[k, 0], tangent[k, 1], 0.0, 0.0, 0.0,
                        point[k, 0], point[k, 1], -1.0, chain[s], -1.0, float(seg[k]),
                    )  # fmt: skip
                    r += 1
                elif o == 1 and spawn[k]:
                    _row(
                        tab, r, cand[k, 0], cand[k, 1], sdir[s, 0], sdir[s, 1], mass[s],
                        head[s, 0], head[s, 1], cand[k, 0], cand[k, 1], 1.0, chain[s], new_pid[k], -1.0,
                    )  # fmt: skip
                    r += 1
    _windows(tab, prm.window)
    return tab, next_pid


# ----------------------------------------------------------------------------------------------
# stage 4: kill / spawn (three swarms, Eq. 12-13 per window)
# ----------------------------------------------------------------------------------------------


@njit
def _links(tab: np.ndarray, lo: int, hi: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Links, radial unit vectors (Eq. 5-6) and target distances (pitches) of rows ``lo:hi``."""
    m = hi - lo
    k = max(m - 1, 0)
    link = np.zeros(k, dtype=np.bool_)
    radial = np.zeros((k, 2))
    target = np.zeros(k)
    for j in range(k):
        a = lo + j
        link[j] = tab[a + 1, _CHAIN] == tab[a, _CHAIN]
        hx = tab[a + 1, _HX] + tab[a, _HX]
        hy = tab[a + 1, _HY] + tab[a, _HY]
        radial[j, 0], radial[j, 1] = _unit2(hy, -hx)
        target[j] = 0.5 if (tab[a + 1, _KIND] < 0 or tab[a, _KIND] < 0) else 1.0
    return link, radial, target


@njit_inline
def _pair_window(tab: np.ndarray, j: int) -> int:
    """Window of the pair ``(j, j + 1)``: its left agent's, or the right one's if the left is a boundary."""
    return int(tab[j, _WIN]) if tab[j, _KIND] >= 0 else int(tab[j + 1, _WIN])


@njit
def _propose(
    tab: np.ndarray, prm: StepParams, pitch: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Propose per window the agent to kill and the pair to split.

    Returns kill windows and agents, spawn windows and pairs.
    """
    m = tab.shape[0]
    link, radial, target = _links(tab, 0, m)
    gap = np.full(max(m - 1, 0), np.nan)
    for j in range(m - 1):
        if link[j]:
            dx = tab[j + 1, _TX] - tab[j, _TX]
            dy = tab[j + 1, _TY] - tab[j, _TY]
            gap[j] = (dx * radial[j, 0] + dy * radial[j, 1]) / (pitch * target[j])
    n_win = int(tab[m - 1, _WIN]) + 1
    kbest = np.full(n_win, np.inf)
    kidx = np.full(n_win, -1, dtype=np.int64)
    sbest = np.full(n_win, np.inf)
    sidx = np.full(n_win, -1, dtype=np.int64)
    for j in range(m - 1):
        w = _pair_window(tab, j)
        g = gap[j]
        if g < prm.kill_below and g < kbest[w]:
            kbest[w] = g
            kidx[w] = j
        if g > prm.spawn_above and -g < sbest[w]:
            sbest[w] = -g
            sidx[w] = j
    kw = np.flatnonzero(kidx >= 0)
    sw = np.flatnonzero(sidx >= 0)
    spairs = sidx[sw]
    kpair = kidx[kw]
    # the victim: the moving agent of the pair whose other neighbour is closer too
    keep = np.zeros(len(kpair), dtype=np.bool_)
    victim = np.zeros(len(kpair), dtype=np.int64)
    for k in range(len(kpair)):
        j = kpair[k]
        left_other = gap[j - 1] if j - 1 >= 0 else np.inf
        right_other = gap[j + 1] if j + 1 < m - 1 else np.inf
        left_other = np.inf if np.isnan(left_other) else left_other
        right_other = np.inf if np.isnan(right_other) else right_other
        v = j if left_other <= right_other else j + 1
        if tab[j, _KIND] < 0:
            v = j + 1
        elif tab[j + 1, _KIND] < 0:
            v = j
        victim[k] = v
        keep[k] = tab[v, _KIND] >= 0
    return kw[keep], victim[keep], sw, spairs


@njit
def _variant(tab: np.ndarray, kill: np.ndarray, spawn_pairs: np.ndarray) -> np.ndarray:
    """Return the swarm with the given agents killed and new agents in the given gaps ``(j, j + 1)``.

    A new agent splits the gap by the target distances; it takes the mean frame, heading and mass
    of the moving agents beside it.
    """
    m = tab.shape[0]
    keep = np.ones(m, dtype=np.bool_)
    for k in kill:
        keep[k] = False
    after = np.full(m, -1, dtype=np.int64)
    for k in range(len(spawn_pairs)):
        after[spawn_pairs[k]] = k
    out = np.zeros((int(np.sum(keep)) + len(spawn_pairs), _NCOL))
    r = 0
    for j in range(m):
        if keep[j]:
            out[r] = tab[j]
            r += 1
        if after[j] < 0:
            continue
        a = tab[j]
        b = tab[j + 1]
        mov_a = a[_KIND] >= 0
        mov_b = b[_KIND] >= 0
        la = 1.0 if mov_a else 0.5
        lb = 1.0 if mov_b else 0.5
        f = la / (la + lb)
        tx = a[_TX] + f * (b[_TX] - a[_TX])
        ty = a[_TY] + f * (b[_TY] - a[_TY])
        wa = 1.0 if mov_a else 0.0
        wb = 1.0 if mov_b else 0.0
        ex, ey = _unit2(wa * a[_EX] + wb * b[_EX], wa * a[_EY] + wb * b[_EY])
        hx, hy = _unit2(wa * a[_HX] + wb * b[_HX], wa * a[_HY] + wb * b[_HY])
        mass = (wa * a[_MASS] + wb * b[_MASS]) / max(wa + wb, 1.0)
        _row(out, r, tx, ty, ex, ey, mass, hx, hy, tx, ty, 1.0, a[_CHAIN], -3.0, -1.0)
        out[r, _WIN] = a[_WIN] if mov_a else b[_WIN]
        r += 1
    return out


@njit
def _solve(tab: np.ndarray, blocks: np.ndarray, prm: StepParams, pitch: float, counts: np.ndarray):
    """Solve the QPs (Eq. 12) of the swarms stacked in ``tab`` (rows ``blocks[i]:blocks[i+1]``) as one.

    Swarms do not interact: no pair links two of them.  Returns the problem's arrays (scaled
    ideal locations, frames, weights, links, radial vectors, targets) and the solution ``u``.
    """
    m = tab.shape[0]
    link, radial, target = _links(tab, 0, m)
    for b in range(1, len(blocks) - 1):
        link[blocks[b] - 1] = False
    t = np.zeros((m, 2))
    e1 = np.zeros((m, 2))
    weight = np.zeros(m)
    lo = np.zeros(2 * m)
    hi = np.zeros(2 * m)
    for j in range(m):
        t[j, 0] = tab[j, _TX] / pitch
        t[j, 1] = tab[j, _TY] / pitch
        e1[j, 0] = tab[j, _EX]
        e1[j, 1] = tab[j, _EY]
        if tab[j, _KIND] >= 0:
            weight[j] = max(prm.K * max(tab[j, _MASS], MASS_FLOOR), WEIGHT_FLOOR)
            lo[2 * j], hi[2 * j] = -BOX_ALONG, BOX_ALONG
            lo[2 * j + 1], hi[2 * j + 1] = -BOX_ACROSS, BOX_ACROSS
        else:  # a boundary agent slides along the boundary tangent only
            lo[2 * j], hi[2 * j] = -BOUNDARY_SLIDE, BOUNDARY_SLIDE
    ab, q, _ = chain_qp(t, e1, weight, link, radial, target)
    finite = np.all(np.isfinite(ab)) and np.all(np.isfinite(q))
    ok = False
    u = np.zeros(2 * m)
    if finite:
        u, _, _, _, ok = solve_box_qp(ab, q, lo, hi, np.zeros(2 * m), prm.qp_tol, prm.qp_max_iter)
    if ok:
        counts[_C_EXACT] += 1
    else:
        with objmode(u="float64[::1]"):
            u = _qp.osqp_fallback(ab, q, lo, hi)
        counts[_C_OSQP] += 1
    counts[_C_SOLVES] += 1
    counts[_C_UNKNOWNS] += 2 * m
    return t, e1, weight, link, radial, target, u


@njit
def _choose(
    tab: np.ndarray, kills: np.ndarray, kw: np.ndarray, spairs: np.ndarray, sw: np.ndarray, prm, pitch, counts
):
    """Solve X0, X-1, X+1 (Eq. 12) and keep per window the lowest potential per agent (Eq. 13).

    Returns the chosen table and the scaled positions of its agents, (m, 2).
    """
    m0 = tab.shape[0]
    n_win = int(tab[m0 - 1, _WIN]) + 1
    none = np.zeros(0, dtype=np.int64)
    has_k = len(kills) > 0
    has_s = len(spairs) > 0
    if not (has_k or has_s):
        t, e1, _, _, _, _, u = _solve(tab, np.array([0, m0]), prm, pitch, counts)
        return tab, chain_positions(t, e1, u)
    vk = _variant(tab, kills, none) if has_k else np.zeros((0, _NCOL))
    vs = _variant(tab, none, spairs) if has_s else np.zeros((0, _NCOL))
    glued = np.concatenate((tab, vk, vs))
    blocks = np.array([0, m0, m0 + vk.shape[0], m0 + vk.shape[0] + vs.shape[0]])
    t, e1, weight, link, radial, target, u = _solve(glued, blocks, prm, pitch, counts)
    # potential per moving agent of each (variant, window) (Eq. 13 restricted to the window)
    pair, agent = chain_potentials(t, e1, weight, link, radial, target, u)
    size = 3 * n_win
    tot_a = np.zeros(size)
    tot_p = np.zeros(size)
    cnt = np.zeros(size)
    mg = glued.shape[0]
    for v in range(3):
        for j in range(blocks[v], blocks[v + 1]):
            w = int(glued[j, _WIN]) + v * n_win
            tot_a[w] += agent[j]
            if glued[j, _KIND] >= 0:
                cnt[w] += 1.0
            if j < mg - 1:
                lw = int(glued[j, _WIN]) if glued[j, _KIND] >= 0 else int(glued[j + 1, _WIN])
                # the pair linking two variants is never linked: its potential is 0
                tot_p[lw + v * n_win] += pair[j]
    pot = np.full((3, n_win), np.inf)
    for w in range(n_win):
        pot[0, w] = (tot_a[w] + tot_p[w]) / max(cnt[w], 1.0) if cnt[w] > 0 else np.inf
    for w in kw:
        wi = w + n_win
        pot[1, w] = (tot_a[wi] + tot_p[wi]) / max(cnt[wi], 1.0) if cnt[wi] > 0 else np.inf
    for w in sw:
        wi = w + 2 * n_win
        pot[2, w] = (tot_a[wi] + tot_p[wi]) / max(cnt[wi], 1.0) if cnt[wi] > 0 else np.inf
    take_kill = np.zeros(len(kw), dtype=np.bool_)
    take_spawn = np.zeros(len(sw), dtype=np.bool_)
    for k in range(len(kw)):
        w = kw[k]
        take_kill[k] = pot[1, w] < pot[0, w] and not pot[2, w] < pot[1, w]  # ties keep X0
    for k in range(len(sw)):
        w = sw[k]
        take_spawn[k] = pot[2, w] < pot[0, w] and pot[2, w] < pot[1, w]
    nk = int(np.sum(take_kill))
    ns = int(np.sum(take_spawn))
    counts[_C_KILLS] += nk
    counts[_C_SPAWNS] += ns
    if nk == 0 and ns == 0:
        v = 0
    elif has_k and nk == len(kw) and ns == 0:
        v = 1
    elif has_s and ns == len(sw) and nk == 0:
        v = 2
    else:
        final = _variant(tab, kills[take_kill], spairs[take_spawn])
        t2, e2, _, _, _, _, u2 = _solve(final, np.array([0, final.shape[0]]), prm, pitch, counts)
        return final, chain_positions(t2, e2, u2)
    lo, hi = blocks[v], blocks[v + 1]
    x = chain_positions(t[lo:hi], e1[lo:hi], u[2 * lo : 2 * hi])
    return glued[lo:hi].copy(), x


# ----------------------------------------------------------------------------------------------
# stage 5: safety (inside, free cells, half a pitch from other paths and from this step's moves)
# ----------------------------------------------------------------------------------------------


@njit
def _stable_argsort(v: np.ndarray) -> np.ndarray:
    """``np.argsort(v, kind="stable")`` as a bottom-up merge sort, (n,) int.

    numba's own ``np.argsort(kind="mergesort")`` is generic library code that costs seconds of
    the cold compile; a stable sort's order is unique, so the result is the same.
    """
    n = v.shape[0]
    a = np.arange(n)
    b = np.zeros(n, dtype=np.int64)
    width = 1
    while width < n:
        for lo in range(0, n, 2 * width):
            mid = min(lo + width, n)
            hi = min(lo + 2 * width, n)
            i, j = lo, mid
            for k in range(lo, hi):
                # take from the left run on ties: stable
                if i < mid and (j >= hi or v[a[j]] >= v[a[i]]):
                    b[k] = a[i]
                    i += 1
                else:
                    b[k] = a[j]
                    j += 1
        a, b = b, a
        width *= 2
    return a


@njit
def _near_pairs(x: np.ndarray, idx: np.ndarray, r: float) -> np.ndarray:
    """Pairs ``(i, j)``, ``i < j``, of positions in ``idx`` (indices into it) within ``r``, (p, 2)."""
    n = len(idx)
    xs = np.zeros(n)
    for a in range(n):
        xs[a] = x[idx[a], 0]
    order = _stable_argsort(xs)
    out = np.zeros((16, 2), dtype=np.int64)
    k = 0
    r2 = r * r
    for a in range(n):
        i = order[a]
        for b in range(a + 1, n):
            j = order[b]
            dx = x[idx[j], 0] - x[idx[i], 0]
            if dx > r:
                break
            dy = x[idx[j], 1] - x[idx[i], 1]
            if dx * dx + dy * dy <= r2:
                if k == out.shape[0]:
                    grown = np.zeros((2 * k, 2), dtype=np.int64)
                    grown[:k] = out
                    out = grown
                out[k, 0] = min(i, j)
                out[k, 1] = max(i, j)
                k += 1
    return out[:k]


@njit
def _safety(tab: np.ndarray, x: np.ndarray, dom, grid, prm: StepParams, pitch: float, counts: np.ndarray):
    """Which agents survive; returns alive (m,) and the grid cells and samples along each move."""
    m = tab.shape[0]
    moving = np.zeros(m, dtype=np.bool_)
    pid = np.zeros(m, dtype=np.int64)
    start = x.copy()
    for j in range(m):
        moving[j] = tab[j, _KIND] >= 0
        pid[j] = int(tab[j, _PID])
        if tab[j, _KIND] == 0:
            start[j, 0] = tab[j, _PX]
            start[j, 1] = tab[j, _PY]
    min_gap = prm.min_gap * pitch
    # the new point and the middle of the move, so no part of the new trail comes within half a
    # pitch of another path
    both = np.zeros((2 * m, 2))
    for j in range(m):
        both[j] = x[j]
        both[m + j, 0] = 0.5 * (start[j, 0] + x[j, 0])
        both[m + j, 1] = 0.5 * (start[j, 1] + x[j, 1])
    clear = kg.grid_clear_of(grid, both, np.concatenate((pid, pid)), min_gap + pitch / 12.0)
    cells, samples = kg.grid_cells(grid, start, x)
    inside = kg.inside(dom, x)
    free = kg.grid_free_cells(grid, cells, pid)
    alive = np.zeros(m, dtype=np.bool_)
    for j in range(m):
        alive[j] = not moving[j] or (inside[j] and free[j] and clear[j] and clear[m + j])
    # two agents of one step may not come within half a pitch of each other's new point or the
    # middle of each other's move; the later one gives way
    idx = np.flatnonzero(alive & moving)
    ni = len(idx)
    if ni > 1:
        n1 = max(ni - 1, 0)
        n2 = max(ni - 2, 0)
        pairs = np.zeros((n1 + n2, 2), dtype=np.int64)
        for k in range(n1):
            pairs[k, 0], pairs[k, 1] = k, k + 1
        for k in range(n2):
            pairs[n1 + k, 0], pairs[n1 + k, 1] = k, k + 2
        if tab[idx[ni - 1], _CHAIN] != tab[idx[0], _CHAIN]:
            pairs = np.concatenate((pairs, _near_pairs(x, idx, min_gap + 1.5 * pitch)))
        kill = np.zeros(m, dtype=np.bool_)
        for k in range(pairs.shape[0]):
            a = idx[pairs[k, 0]]
            b = idx[pairs[k, 1]]
            d = min(
                _point_segment(x[a, 0], x[a, 1], start[b, 0], start[b, 1], x[b, 0], x[b, 1]),
                _point_segment(x[b, 0], x[b, 1], start[a, 0], start[a, 1], x[a, 0], x[a, 1]),
                _point_segment(start[a, 0], start[a, 1], start[b, 0], start[b, 1], x[b, 0], x[b, 1]),
                _point_segment(start[b, 0], start[b, 1], start[a, 0], start[a, 1], x[a, 0], x[a, 1]),
            )
            if d < min_gap:
                kill[max(a, b)] = True
        nk = int(np.sum(kill))
        if nk:
            alive &= ~kill
            counts[_C_SAME_STEP] += nk
    # neighbours along the front closer than min_gap: the more compressed one goes
    for _ in range(8):
        idx = np.flatnonzero(alive & moving)
        ni = len(idx)
        if ni < 2:
            break
        link = np.zeros(ni - 1, dtype=np.bool_)
        gap = np.zeros(ni - 1)
        bad = np.zeros(ni - 1, dtype=np.bool_)
        for k in range(ni - 1):
            a, b = idx[k], idx[k + 1]
            link[k] = tab[b, _CHAIN] == tab[a, _CHAIN]
            rx, ry = _unit2(tab[b, _HY] + tab[a, _HY], -(tab[b, _HX] + tab[a, _HX]))
            dx = x[b, 0] - x[a, 0]
            dy = x[b, 1] - x[a, 1]
            gap[k] = dx * rx + dy * ry
            bad[k] = link[k] and (gap[k] < min_gap or dx * dx + dy * dy < min_gap * min_gap)
        if not np.any(bad):
            break
        kill = np.zeros(ni, dtype=np.bool_)
        for k in range(ni - 1):
            if not bad[k]:
                continue
            gl = gap[k - 1] if k >= 1 and link[k - 1] else np.inf
            gr = gap[k + 1] if k + 1 < ni - 1 and link[k + 1] else np.inf
            kill[k if gl <= gr else k + 1] = True
        for k in range(ni):
            if kill[k]:
                alive[idx[k]] = False
        counts[_C_TOO_CLOSE] += int(np.sum(kill))
    return alive, cells, samples


@njit
def _local_pitch(tab: np.ndarray, x: np.ndarray, pitch: float) -> np.ndarray:
    """Local pitch of each agent: half the gap to each moving neighbour, the full gap to a boundary.

    Negative where the estimate is uncertain (no moving neighbour on both sides); the engine
    measures those points on the finished layer (:mod:`.widths`).
    """
    m = tab.shape[0]
    link = np.zeros(m + 1, dtype=np.bool_)
    gap = np.full(m + 1, np.nan)
    for i in range(1, m):
        link[i] = tab[i, _CHAIN] == tab[i - 1, _CHAIN]
        # the radial distance (Eq. 8: across the mean travel of the pair), not the straight one
        rx, ry = _unit2(tab[i, _HY] + tab[i - 1, _HY], -(tab[i, _HX] + tab[i - 1, _HX]))
        gap[i] = abs((x[i, 0] - x[i - 1, 0]) * rx + (x[i, 1] - x[i - 1, 1]) * ry)
    out = np.zeros(m)
    for i in range(m):
        left_b = i > 0 and tab[i - 1, _KIND] < 0
        right_b = i < m - 1 and tab[i + 1, _KIND] < 0
        lp = ((1.0 if left_b else 0.5) * gap[i]) if link[i] else np.nan
        rp = ((1.0 if right_b else 0.5) * gap[i + 1]) if link[i + 1] else np.nan
        if np.isnan(lp):
            lp = rp
        if np.isnan(rp):
            rp = lp
        sure = link[i] and link[i + 1] and not left_b and not right_b
        v = pitch if np.isnan(lp) else lp + rp
        v = min(max(v, 0.25 * pitch), 3.0 * pitch)
        out[i] = v if sure else -v
    return out


# ----------------------------------------------------------------------------------------------
# stage 6: merge chains whose facing ends met (internal boundary agents removed)
# ----------------------------------------------------------------------------------------------


@njit
def _merge(dom, prm: StepParams, pitch: float, pos: np.ndarray, head: np.ndarray, start: np.ndarray, counts):
    starts = np.flatnonzero(start)
    if len(starts) < 2:
        return
    lim = (prm.merge_reach * pitch) ** 2
    cand = np.zeros(len(starts) - 1, dtype=np.bool_)
    for c in range(1, len(starts)):
        s = starts[c]
        dx = pos[s, 0] - pos[s - 1, 0]
        dy = pos[s, 1] - pos[s - 1, 1]
        # close, and facing each other: b lies to the right of a's travel
        hx = head[s - 1, 0] + head[s, 0]
        hy = head[s - 1, 1] + head[s, 1]
        cand[c - 1] = dx * dx + dy * dy <= lim and dx * hy + dy * -hx > 0
    if not np.any(cand):
        return
    sel = starts[1:][cand]
    cr = kg.crosses(dom, pos[sel - 1], pos[sel])
    for k in range(len(sel)):
        if not cr[k]:
            start[sel[k]] = False
            counts[_C_MERGED] += 1


# ----------------------------------------------------------------------------------------------
# one step, and the loop
# ----------------------------------------------------------------------------------------------


@njit_inline
def _step(
    r: kg.RasterData,
    dom: kg.DomainData,
    grid: kg.GridData,
    prm: StepParams,
    pitch: float,
    pos: np.ndarray,
    head: np.ndarray,
    pid: np.ndarray,
    start: np.ndarray,
    next_pid: int,
    counts: np.ndarray,
):
    """Advance the swarm by one step (Algorithm 1, lines 2-9).

    Inlined (numba IR) into :func:`run_swarm` and :func:`step`: numba optimises a compiled
    function together with every compiled function it calls, so a separately compiled step would
    have the whole step optimised twice (once for itself, once inside the loop): ~12 s of the cold
    compile.

    Returns
    -------
    pos, head, pid, start
        The next state (possibly empty).
    points : (k, 2) float, mm
        New locations of the surviving agents, then the last points of paths ended this step.
    point_pid : (k,) int
    point_pitch : (k,) float, mm
        Local pitch, negative where uncertain.
    next_pid : int
    """
    t, sdir, mass = _ideal(r, pos, head, start, pitch, counts)
    pos, head, pid, start, t, sdir, mass, last, last_pid = _remove_blocked(
        dom, grid, prm, pitch, pos, head, pid, start, t, sdir, mass, counts
    )
    if pos.shape[0] == 0:
        return pos, head, pid, start, last, last_pid, np.full(len(last), -pitch), next_pid
    tab, next_pid = _extend(dom, grid, prm, pitch, pos, head, pid, start, t, sdir, mass, next_pid, counts)
    kw, kills, sw, spairs = _propose(tab, prm, pitch)
    final, xs = _choose(tab, kills, kw, spairs, sw, prm, pitch, counts)
    x = xs * pitch
    # boundary agents: tangent step done in the QP, now back onto the boundary
    bnd = np.flatnonzero(final[:, _KIND] < 0)
    if len(bnd):
        seg = np.zeros(len(bnd), dtype=np.int64)
        for k in range(len(bnd)):
            seg[k] = int(final[bnd[k], _SEG])
        pr = kg.project_local(dom, x[bnd], seg, 6)
        for k in range(len(bnd)):
            x[bnd[k]] = pr[k]
    alive, cells, samples = _safety(final, x, dom, grid, prm, pitch, counts)
    if not np.all(alive):
        keep = np.flatnonzero(alive)
        final = final[keep]
        x = x[keep]
        cells = cells[keep]
        samples = samples[keep]
    lp = _local_pitch(final, x, pitch)
    mv = np.flatnonzero(final[:, _KIND] >= 0)
    nm = len(mv)
    new_pos = np.zeros((nm, 2))
    new_head = np.zeros((nm, 2))
    new_pid = np.zeros(nm, dtype=np.int64)
    new_start = np.zeros(nm, dtype=np.bool_)
    lim = (0.1 * pitch) ** 2
    for k in range(nm):
        j = mv[k]
        p = int(final[j, _PID])
        if p == -3:
            p = next_pid
            next_pid += 1
        new_pid[k] = p
        new_pos[k] = x[j]
        if final[j, _KIND] == 1:
            px, py = x[j, 0], x[j, 1]
        else:
            px, py = final[j, _PX], final[j, _PY]
        dx = x[j, 0] - px
        dy = x[j, 1] - py
        if dx * dx + dy * dy > lim:
            new_head[k, 0], new_head[k, 1] = _unit2(dx, dy)
        else:
            new_head[k, 0], new_head[k, 1] = final[j, _HX], final[j, _HY]
        new_start[k] = k == 0 or final[j, _CHAIN] != final[mv[k - 1], _CHAIN]
    kg.grid_mark_cells(grid, cells[mv], samples[mv], new_pid)  # the trails prev -> x
    _merge(dom, prm, pitch, new_pos, new_head, new_start, counts)
    points = np.concatenate((new_pos, last))
    ppid = np.concatenate((new_pid, last_pid))
    ppitch = np.concatenate((lp[mv], np.full(len(last), -pitch)))
    return new_pos, new_head, new_pid, new_start, points, ppid, ppitch, next_pid


@njit
def step(
    r: kg.RasterData,
    dom: kg.DomainData,
    grid: kg.GridData,
    prm: StepParams,
    pitch: float,
    pos: np.ndarray,
    head: np.ndarray,
    pid: np.ndarray,
    start: np.ndarray,
    next_pid: int,
    counts: np.ndarray,
):
    """One step on its own (:func:`_step`; for :func:`.step.step` and tests, compiled on first use)."""
    return _step(r, dom, grid, prm, pitch, pos, head, pid, start, next_pid, counts)


@njit
def run_swarm(
    r: kg.RasterData,
    dom: kg.DomainData,
    grid: kg.GridData,
    prm: StepParams,
    pitch: float,
    pos: np.ndarray,
    head: np.ndarray,
    pid: np.ndarray,
    start: np.ndarray,
    next_pid: int,
    max_steps: int,
    direction: int,
    counts: np.ndarray,
):
    """Advance a swarm until it dies (or ``max_steps``); returns the points it laid.

    Returns
    -------
    points : (k, 2) float, mm
    point_pid : (k,) int
    point_pitch : (k,) float, mm
        Negative where uncertain (measured on the finished layer).
    point_step : (k,) int
        ``direction`` times the step that laid each point.
    next_pid : int
    """
    cap = 4096
    pts = np.zeros((cap, 2))
    ppid = np.zeros(cap, dtype=np.int64)
    ppitch = np.zeros(cap)
    pstep = np.zeros(cap, dtype=np.int64)
    k = 0
    n_steps = 0
    while pos.shape[0] > 0 and n_steps < max_steps:
        n_steps += 1
        pos, head, pid, start, p, i, w, next_pid = _step(
            r, dom, grid, prm, pitch, pos, head, pid, start, next_pid, counts
        )
        need = k + p.shape[0]
        if need > cap:
            cap = max(2 * cap, need)
            pts2 = np.zeros((cap, 2))
            pts2[:k] = pts[:k]
            pts = pts2
            ppid2 = np.zeros(cap, dtype=np.int64)
            ppid2[:k] = ppid[:k]
            ppid = ppid2
            ppitch2 = np.zeros(cap)
            ppitch2[:k] = ppitch[:k]
            ppitch = ppitch2
            pstep2 = np.zeros(cap, dtype=np.int64)
            pstep2[:k] = pstep[:k]
            pstep = pstep2
        pts[k:need] = p
        ppid[k:need] = i
        ppitch[k:need] = w
        pstep[k:need] = direction * n_steps
        k = need
    counts[_C_STEPS] += n_steps
    if pos.shape[0] > 0:
        counts[_C_LIMIT] += 1
    return pts[:k].copy(), ppid[:k].copy(), ppitch[:k].copy(), pstep[:k].copy(), next_pid


# one log line now if the kernels are not in numba's cache: the first layer compiles them
announce_compile(run_swarm)
