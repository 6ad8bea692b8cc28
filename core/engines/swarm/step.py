"""One iteration of the swarm (paper Algorithm 1, lines 2-9), vectorized over the agents.

This module is longer than the house limit because one iteration is one algorithm whose stages
share many arrays; splitting it would only pass them around.  The stages:

1. **Step** (Eq. 2): every agent moves ``h`` along the local principal direction, oriented by its
   momentum (``mu = sign(s . last displacement)``).  Where the field has no direction (validity
   mask false) it follows the mean heading of itself and its chain neighbours, so it neither stalls
   nor zig-zags.
2. **Blocked agents**: an agent whose ideal location leaves the domain (closer than the margin to
   the boundary: the far end, a hole, a concave corner, or beads laid by an earlier swarm) or
   enters a cell of another path is removed; its path ends.  If it was inside a chain, the chain
   splits there: the two new chain ends get *internal boundary agents* on that boundary
   (paper Fig. 3).
3. **Boundary agents** (Sec. III-B4): each chain end casts a ray along the radial direction; the
   first boundary point within ``ray_reach`` pitches is its boundary agent, which slides along the
   boundary tangent in the QP and is projected back onto the boundary.  A chain end with no
   boundary in reach is free; a new agent is spawned one pitch beyond it (if there is room), so
   the front widens where the region does.
4. **Kill / spawn** (Sec. III-B6): the chains are cut into windows of ``window`` agents.  In each
   window the pair with the smallest normalised radial gap (below ``kill_below``) proposes a
   kill of its more compressed agent and the pair with the largest gap (above ``spawn_above``)
   proposes a spawn in between.  The QP (Eq. 12) is solved for three swarms — X0, X-1 (every
   proposed kill) and X+1 (every proposed spawn) — as one banded system, and each window keeps
   the variant with the lowest potential per agent over its own pairs and agents (Eq. 13 applied
   window by window).  This allows one kill or spawn per window per step, i.e. several where the
   front is wide.  If windows chose differently the combined swarm is solved once more.
5. **Safety**: after the QP, agents that left the domain or came closer than ``min_gap`` pitches
   to their neighbour are removed, so paths never cross and never come closer than half a pitch.
6. **Merge**: two chains whose facing ends are within ``merge_reach`` pitches with no boundary
   between them are joined: their internal boundary agents met (Fig. 3) and are removed.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from loadpath._typing import Bools, Floats, Ints, Points2
from loadpath.engines.swarm.boundary import Domain
from loadpath.engines.swarm.chain import (
    BOUNDARY_SLIDE,
    BOX_ACROSS,
    BOX_ALONG,
    MASS_FLOOR,
    ChainProblem,
    build_qp,
    positions,
    potentials,
)
from loadpath.engines.swarm.grid import Occupancy
from loadpath.engines.swarm.qp import solve
from loadpath.engines.swarm.raster import FieldRaster
from scipy.spatial import cKDTree

__all__ = ["SwarmParams", "SwarmState", "Context", "step"]


@dataclass(frozen=True)
class SwarmParams:
    """Tuning of the swarm (defaults reproduce the paper's method; see the module docstring).

    Attributes
    ----------
    K : float
        Weight of the environment potential (Eq. 12: ``P = P_a + K P_e``).
    window : int
        Agents per kill/spawn window.
    kill_below, spawn_above : float
        Normalised radial gaps that propose a kill / a spawn (the paper's "too close" / "too far").
    min_gap : float
        Neighbours closer than this many pitches after the QP: the more compressed one is removed.
    margin : float
        Moving agents keep this many pitches inside the domain.
    ray_reach : float
        Boundary agents are searched this many pitches from a chain end.
    merge_reach : float
        Chains whose facing ends are closer than this many pitches are joined.
    grow_free_ends : bool
        Spawn a new agent beyond a chain end that has no boundary in reach (off by default: the
        fill swarms cover what a front does not reach, more evenly than a front growing sideways).
    field_cell : float
        Node spacing of the stress-field raster the steps sample (:mod:`.raster`), in pitches (one
        pitch gives the same beta and spacing on the specimen's FE field for a quarter of the
        raster's cost, but loses coverage at small holes: 94.9 against 95.5 % on the small bracket).
    edge_gap : float
        A path that runs into the layer's edge ends this many pitches from it (across the edge).
    """

    K: float = 5.0
    window: int = 16
    kill_below: float = 0.85
    spawn_above: float = 1.3
    min_gap: float = 0.5
    margin: float = 0.25
    ray_reach: float = 2.5
    merge_reach: float = 5.0
    grow_free_ends: bool = False
    field_cell: float = 0.5
    edge_gap: float = 0.25


@dataclass
class SwarmState:
    """The moving agents of one swarm, in chain order.

    Attributes
    ----------
    pos : (n, 2) float, mm
        Current locations ``x(k)``.
    head : (n, 2) float
        Unit direction of the last displacement ``x(k) - x(k-1)`` (the momentum).
    pid : (n,) int
        Path id each agent draws.
    start : (n,) bool
        Whether each agent starts a chain (agents of a chain are contiguous).
    """

    pos: Points2
    head: Points2
    pid: Ints
    start: Bools

    @property
    def n(self) -> int:
        """Number of moving agents."""
        return int(len(self.pos))


@dataclass
class Context:
    """What a swarm run shares across its steps."""

    raster: FieldRaster
    domain: Domain
    grid: Occupancy
    params: SwarmParams
    pitch: float
    next_pid: int
    stats: dict = field(default_factory=dict)

    def new_pids(self, k: int) -> Ints:
        """``k`` fresh path ids."""
        out = np.arange(self.next_pid, self.next_pid + k, dtype=np.int64)
        self.next_pid += k
        return out

    def count(self, key: str, value: float = 1) -> None:
        """Add to a statistic."""
        self.stats[key] = self.stats.get(key, 0) + value


_FLIP = np.array([1.0, -1.0])


def _unit(v: np.ndarray) -> np.ndarray:
    n = np.sqrt(np.add.reduce(v * v, axis=-1, keepdims=True))
    n[n == 0] = 1.0
    return v / n


def _right(v: np.ndarray) -> np.ndarray:
    """Clockwise normal ``-(v^perp)`` (Eq. 5: the radial direction points to the right of travel)."""
    return v[..., ::-1] * _FLIP


# ----------------------------------------------------------------------------------------------
# the extended chain (moving agents plus boundary agents) as one table, one row per agent
# ----------------------------------------------------------------------------------------------
# One float table instead of a dataclass of arrays: taking, inserting and gluing rows is then one
# numpy call instead of one per field (the step is dominated by the number of calls, not their size).

_T = slice(0, 2)  # ideal location t (boundary agents: reference point on the boundary), mm
_E = slice(2, 4)  # along-direction of the frame (stress direction, or boundary tangent)
_MASS = 4  # virtual mass
_H = slice(5, 7)  # last displacement direction (zero for boundary agents)
_P = slice(7, 9)  # location x(k) (spawned and boundary agents: t)
_KIND = 9  # 0 moving agent, 1 spawned this step, -1 boundary agent
_CHAIN = 10
_WIN = 11  # kill/spawn window
_PID = 12  # path id (-1 boundary agent, -3 spawned this step)
_SEG = 13  # boundary segment of a boundary agent (-1 otherwise)
_NCOL = 14


def _rows(
    t: Points2,
    e1: Points2,
    mass: Floats,
    head: Points2,
    pos: Points2,
    kind: float,
    chain: Floats,
    pid: Floats,
    seg: Floats | float = -1.0,
) -> np.ndarray:
    out = np.zeros((len(t), _NCOL))
    out[:, _T] = t
    out[:, _E] = e1
    out[:, _MASS] = mass
    out[:, _H] = head
    out[:, _P] = pos
    out[:, _KIND] = kind
    out[:, _CHAIN] = chain
    out[:, _WIN] = 0.0
    out[:, _PID] = pid
    out[:, _SEG] = seg
    return out


def _links(tab: np.ndarray) -> tuple[Bools, Points2, Floats]:
    """Links, radial unit vectors (Eq. 5-6) and target distances (in pitches) of neighbours."""
    chain = tab[:, _CHAIN]
    kind = tab[:, _KIND]
    link = chain[1:] == chain[:-1]
    radial = _unit(_right(tab[1:, _H] + tab[:-1, _H]))
    bnd = (kind[1:] < 0) | (kind[:-1] < 0)
    return link, radial, np.where(bnd, 0.5, 1.0)


_LO_MOV = np.array([-BOX_ALONG, -BOX_ACROSS])
_HI_MOV = np.array([BOX_ALONG, BOX_ACROSS])
_LO_BND = np.array([-BOUNDARY_SLIDE, 0.0])
_HI_BND = np.array([BOUNDARY_SLIDE, 0.0])


def _problem(tab: np.ndarray, pitch: float, K: float) -> ChainProblem:
    moving = (tab[:, _KIND] >= 0)[:, None]
    e1 = tab[:, _E]
    link, radial, target = _links(tab)
    return ChainProblem(
        t=tab[:, _T] / pitch,
        frame=np.stack([e1, np.stack([-e1[:, 1], e1[:, 0]], axis=1)], axis=1),
        lo=np.where(moving, _LO_MOV, _LO_BND),
        hi=np.where(moving, _HI_MOV, _HI_BND),
        weight=np.where(moving[:, 0], K * np.maximum(tab[:, _MASS], MASS_FLOOR), 0.0),
        link=link,
        radial=radial,
        target=target,
    )


def _windows(tab: np.ndarray, window: int) -> Floats:
    """Window of each agent: rank of moving agents within their chain // window (numbered from 0)."""
    m = len(tab)
    moving = tab[:, _KIND] >= 0
    chain = tab[:, _CHAIN]
    first = np.ones(m, dtype=bool)
    first[1:] = chain[1:] != chain[:-1]
    cum = np.cumsum(moving)
    first_idx = np.maximum.accumulate(np.where(first, np.arange(m), 0))
    before = cum[first_idx] - moving[first_idx]
    rank = np.maximum(cum - before - 1, 0)
    key = chain * (m + 1) + rank // max(1, window)
    new = np.ones(m, dtype=bool)
    new[1:] = key[1:] != key[:-1]  # keys are non-decreasing along the table
    return (np.cumsum(new) - 1).astype(float)


def _extreme_per_window(win: Ints, key: Floats) -> tuple[Ints, Ints]:
    """For each window, the index of the smallest finite key (ties: the lowest index)."""
    idx = np.flatnonzero(np.isfinite(key))
    if not len(idx):
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    order = idx[np.lexsort((idx, key[idx], win[idx]))]
    g = win[order]
    first = np.ones(len(g), dtype=bool)
    first[1:] = g[1:] != g[:-1]
    return g[first].astype(np.int64), order[first]


# ----------------------------------------------------------------------------------------------
# the stages
# ----------------------------------------------------------------------------------------------


def _ideal(st: SwarmState, ctx: Context) -> tuple[Points2, Points2, Floats]:
    """Stage 1: step direction (Eq. 2 with momentum), ideal locations and virtual masses."""
    s, mass, valid = ctx.raster.sample(st.pos)
    if not np.all(valid):
        link = ~st.start[1:]
        mean = st.head.copy()
        mean[:-1] += np.where(link[:, None], st.head[1:], 0.0)
        mean[1:] += np.where(link[:, None], st.head[:-1], 0.0)
        mean = _unit(mean)
        mean = np.where(np.add.reduce(mean * mean, axis=1)[:, None] > 0.25, mean, st.head)
        s = np.where(valid[:, None], s, mean)
        mass = np.where(valid, mass, 0.0)
        ctx.count("no_direction", int(np.count_nonzero(~valid)))
    sdir = np.where((np.add.reduce(s * st.head, axis=1) >= 0)[:, None], s, -s)
    return st.pos + ctx.pitch * sdir, sdir, mass


def _remove_blocked(st: SwarmState, t: Points2, sdir: Points2, mass: Floats, ctx: Context):
    """Stage 2: agents whose ideal location leaves the domain end their path; chains split.

    An agent stopped by the domain's boundary takes a last, shorter step that brings its bead's
    edge to the boundary (centre half a pitch from it), so paths reach the region's edge.

    Returns the remaining state and arrays, and the last points ``(points, pid)`` of the removed.
    """
    in_dom = ctx.domain.inside(t)
    ok = in_dom & ctx.grid.free_path(st.pos, t, st.pid)
    none = (np.zeros((0, 2)), np.zeros(0, np.int64))
    if np.all(ok):
        return st, t, sdir, mass, none
    ctx.count("blocked", int(np.count_nonzero(~ok)))
    # last partial step for those stopped by the boundary
    last = none
    ends = np.flatnonzero(~in_dom)
    if len(ends):
        dist, _, tangent, seg = ctx.domain.ray(st.pos[ends], sdir[ends], 2.0 * ctx.pitch)
        # the end point keeps `edge_gap` pitches from the layer's edge (like the slicer's infill,
        # whose beads overlap the perimeters a little) and half a pitch from beads laid before,
        # both measured across the boundary, so an end that meets the edge obliquely still reaches it
        hit = seg >= 0
        gap = np.where(hit & ctx.domain.edge[np.maximum(seg, 0)], ctx.params.edge_gap, 0.5) * ctx.pitch
        cos = np.abs(sdir[ends, 0] * tangent[:, 1] - sdir[ends, 1] * tangent[:, 0])
        reach = np.where(hit, dist - gap / np.maximum(np.where(hit, cos, 1.0), 0.5), 0.0)
        go = (reach > 0.1 * ctx.pitch) & (reach <= ctx.pitch)
        q = st.pos[ends[go]] + reach[go, None] * sdir[ends[go]]
        gp = st.pid[ends[go]]
        clear = ctx.grid.clear_of(
            np.concatenate([q, 0.5 * (q + st.pos[ends[go]])]),
            np.concatenate([gp, gp]),
            (ctx.params.min_gap + 1.0 / 12.0) * ctx.pitch,
        )
        fine = ctx.grid.free_path(st.pos[ends[go]], q, gp) & clear[: len(q)] & clear[len(q) :]
        # two ends converging on one boundary (a front heading into a hole) must not finish
        # closer than the gap to each other: keep the first of any such pair
        fi = np.flatnonzero(fine)
        if len(fi) > 1:
            dq = q[fi][:, None, :] - q[fi][None, :, :]
            close = np.triu(np.add.reduce(dq * dq, axis=2) < (ctx.params.min_gap * ctx.pitch) ** 2, k=1)
            fine[fi[np.any(close, axis=0)]] = False
        last = (q[fine], st.pid[ends[go]][fine])
        ctx.grid.mark(st.pos[ends[go]][fine], q[fine], st.pid[ends[go]][fine])
    gone_before = np.zeros(st.n, dtype=bool)
    gone_before[1:] = ~ok[:-1]
    start = (st.start | gone_before)[ok]
    if len(start):
        start[0] = True
    st2 = SwarmState(pos=st.pos[ok], head=st.head[ok], pid=st.pid[ok], start=start)
    return st2, t[ok], sdir[ok], mass[ok], last


def _extend(st: SwarmState, t: Points2, sdir: Points2, mass: Floats, ctx: Context) -> np.ndarray:
    """Stage 3: boundary agents at chain ends, new agents at free ends; returns the table."""
    p = ctx.params
    pitch = ctx.pitch
    n = st.n
    starts = np.flatnonzero(st.start)
    ends = np.append(starts[1:] - 1, n - 1)
    nc = len(starts)
    chain = (np.cumsum(st.start) - 1).astype(float)
    src = np.concatenate([starts, ends])
    dirs = np.concatenate([-_right(st.head[starts]), _right(st.head[ends])])
    dist, point, tangent, seg = ctx.domain.ray(t[src], dirs, p.ray_reach * pitch)
    hit = np.isfinite(dist)
    left = np.arange(2 * nc) < nc
    # ordering keys: 3j+1 moving agent j; 3j left of it; 3j+2 right of it
    keys = [3.0 * np.arange(n) + 1.0]
    parts = [_rows(t, sdir, mass, st.head, st.pos, 0.0, chain, st.pid)]
    if p.grow_free_ends:
        # free ends: one new agent a pitch further out, if there is room, only where the chain
        # really ends there: the ray continues the chain's own line (an end agent that turned with
        # the field, e.g. into the hoop stress at a hole, must not grow a chain along its travel)
        cand = t[src] + pitch * dirs
        spawn = ~hit & ctx.domain.inside(cand) & ctx.grid.free_for(cand, np.full(len(cand), -2))
        nb = np.concatenate([np.minimum(starts + 1, ends), np.maximum(ends - 1, starts)])
        along = _unit(t[src] - t[nb])
        square = np.abs(np.add.reduce(st.head[src] * along, axis=1)) < 0.5
        spawn &= (nb != src) & square & (np.add.reduce(along * dirs, axis=1) > 0.8)
        if np.any(spawn):
            idx = np.flatnonzero(spawn)
            d = np.min(np.linalg.norm(cand[idx][:, None, :] - t[None, :, :], axis=2), axis=1)
            spawn[idx[d < 0.75 * pitch]] = False
            if nc == 1 and n == 1 and spawn[0] and spawn[1]:
                spawn[1] = False  # a lone agent grows on one side per step
        sp = np.flatnonzero(spawn)
        ctx.count("spawn_free_end", len(sp))
        if len(sp):
            s_src = src[sp]
            keys.append(np.where(left[sp], 3.0 * s_src, 3.0 * s_src + 2.0))
            parts.append(
                _rows(
                    cand[sp],
                    sdir[s_src],
                    mass[s_src],
                    st.head[s_src],
                    cand[sp],
                    1.0,
                    chain[s_src],
                    ctx.new_pids(len(sp)).astype(float),
                )
            )
    bh = np.flatnonzero(hit)
    if len(bh):
        b_src = src[bh]
        keys.append(np.where(left[bh], 3.0 * b_src - 0.4, 3.0 * b_src + 2.4))
        z = np.zeros((len(bh), 2))
        parts.append(_rows(point[bh], tangent[bh], 0.0, z, point[bh], -1.0, chain[b_src], -1.0, seg[bh]))
    tab = (
        np.concatenate(parts)[np.argsort(np.concatenate(keys), kind="stable")] if len(parts) > 1 else parts[0]
    )
    tab[:, _WIN] = _windows(tab, p.window)
    return tab


def _propose(tab: np.ndarray, ctx: Context) -> tuple[Ints, Ints, Ints, Ints]:
    """Stage 4a: per window, the agent to kill and the pair to split (indices into the table).

    Returns kill windows, kill agents, spawn windows, spawn pairs (spawn between j and j + 1).
    """
    p = ctx.params
    kind = tab[:, _KIND]
    link, radial, target = _links(tab)
    gap = np.add.reduce((tab[1:, _T] - tab[:-1, _T]) * radial, axis=1) / (ctx.pitch * target)
    gap = np.where(link, gap, np.nan)
    lw = np.where(kind[:-1] >= 0, tab[:-1, _WIN], tab[1:, _WIN])
    kw, kpair = _extreme_per_window(lw, np.where(gap < p.kill_below, gap, np.inf))
    sw, spair = _extreme_per_window(lw, np.where(gap > p.spawn_above, -gap, np.inf))
    if len(kpair):
        # the victim: the moving agent of the pair whose other neighbour is closer too
        m = len(kind)
        g = np.where(np.isnan(gap), np.inf, gap)
        left_other = np.where(kpair - 1 >= 0, g[np.maximum(kpair - 1, 0)], np.inf)
        right_other = np.where(kpair + 1 < m - 1, g[np.minimum(kpair + 1, m - 2)], np.inf)
        victim = np.where(left_other <= right_other, kpair, kpair + 1)
        victim = np.where(kind[kpair] < 0, kpair + 1, np.where(kind[kpair + 1] < 0, kpair, victim))
        ok = kind[victim] >= 0
        kw, kpair = kw[ok], victim[ok]
    return kw, kpair, sw, spair


def _spawned(tab: np.ndarray, pairs: Ints) -> np.ndarray:
    """Place new agents in the gaps ``(j, j + 1)``, at the point that splits the gap by the targets."""
    a, b = tab[pairs], tab[pairs + 1]
    mov_a = a[:, _KIND] >= 0
    mov_b = b[:, _KIND] >= 0
    la = np.where(mov_a, 1.0, 0.5)
    lb = np.where(mov_b, 1.0, 0.5)
    t = a[:, _T] + (la / (la + lb))[:, None] * (b[:, _T] - a[:, _T])
    wa = mov_a.astype(float)[:, None]
    wb = mov_b.astype(float)[:, None]
    e1 = _unit(wa * a[:, _E] + wb * b[:, _E])
    head = _unit(wa * a[:, _H] + wb * b[:, _H])
    mass = (wa[:, 0] * a[:, _MASS] + wb[:, 0] * b[:, _MASS]) / np.maximum(wa[:, 0] + wb[:, 0], 1.0)
    out = _rows(t, e1, mass, head, t, 1.0, a[:, _CHAIN], -3.0)
    out[:, _WIN] = np.where(mov_a, a[:, _WIN], b[:, _WIN])
    return out


def _variant(tab: np.ndarray, kill: Ints, spawn_pairs: Ints) -> np.ndarray:
    """Return the swarm with the given agents killed and new agents in the given gaps."""
    keep = np.ones(len(tab), dtype=bool)
    keep[kill] = False
    if not len(spawn_pairs):
        return tab[keep]
    both = np.concatenate([tab, _spawned(tab, spawn_pairs)])
    keys = np.concatenate([np.arange(len(tab), dtype=float), spawn_pairs + 0.5])
    keep_all = np.concatenate([keep, np.ones(len(spawn_pairs), dtype=bool)])
    order = np.argsort(keys, kind="stable")
    return both[order[keep_all[order]]]


def _solve(tabs: list[np.ndarray], ctx: Context) -> tuple[np.ndarray, ChainProblem, Floats]:
    """Solve the QPs of several swarms as one banded system (they do not interact).

    The tables are glued with their chains renumbered apart, so no pair links two of them.
    Returns the glued table, its problem and the solution ``u``.
    """
    if len(tabs) > 1:
        shift = 0.0
        parts = []
        for tb in tabs:
            tb = tb.copy()
            tb[:, _CHAIN] += shift
            shift = float(tb[-1, _CHAIN]) + 1.0
            parts.append(tb)
        glued = np.concatenate(parts)
    else:
        glued = tabs[0]
    cp = _problem(glued, ctx.pitch, ctx.params.K)
    qp, _ = build_qp(cp)
    sol = solve(qp)
    ctx.count("qp_solves")
    ctx.count("qp_unknowns", qp.n)
    ctx.count("qp_" + sol.status.replace(":", "_"))
    return glued, cp, sol.x


def _window_potentials(tab: np.ndarray, cp: ChainProblem, u: Floats, size: int) -> Floats:
    """Potential per moving agent of each (variant, window) (Eq. 13 restricted to the window).

    ``tab[:, _WIN]`` must already number the windows of all variants apart; returns (size,).
    """
    pair, agent = potentials(cp, u)
    win = tab[:, _WIN].astype(np.intp)
    kind = tab[:, _KIND]
    lw = np.where(kind[:-1] >= 0, win[:-1], win[1:])
    tot = np.bincount(win, weights=agent, minlength=size) + np.bincount(lw, weights=pair, minlength=size)
    cnt = np.bincount(win, weights=(kind >= 0).astype(float), minlength=size)
    return np.where(cnt > 0, tot / np.maximum(cnt, 1.0), np.inf)


def _safety(tab: np.ndarray, x: Points2, ctx: Context) -> tuple[Bools, np.ndarray, np.ndarray]:
    """Stage 5: which agents survive (inside, free cells, at least min_gap from neighbours).

    Returns the survivors and the grid cells and samples along each agent's move (for marking).
    """
    kind = tab[:, _KIND]
    moving = kind >= 0
    pid = tab[:, _PID].astype(np.int64)
    start = np.where((kind == 0)[:, None], tab[:, _P], x)
    min_gap = ctx.params.min_gap * ctx.pitch
    # the new point and the middle of the move, so no part of the new trail comes within half a
    # pitch of another path (the vertex alone would let the middle of a move pass closer)
    m = len(x)
    clear = ctx.grid.clear_of(
        np.concatenate([x, 0.5 * (start + x)]), np.concatenate([pid, pid]), min_gap + ctx.pitch / 12.0
    )
    clear = clear[:m] & clear[m:]
    cells, samples = ctx.grid.cells(start, x)
    alive = ~moving | (ctx.domain.inside(x) & ctx.grid.free_cells(cells, pid) & clear)
    chain = tab[:, _CHAIN]
    head = tab[:, _H]
    # the grid does not hold this step's moves yet: two agents of one step may not come within
    # half a pitch of each other's new point or the middle of each other's move (chains closing in
    # around a corner or behind a hole, neighbours whose moves cut across); the later one gives way
    idx = np.flatnonzero(alive & moving)
    if len(idx) > 1:
        # candidates: the next two agents along the front, and for several chains any agents of
        # different chains near each other
        k = np.arange(len(idx))
        pairs = [np.stack([k[:-1], k[1:]], axis=1), np.stack([k[:-2], k[2:]], axis=1)]
        if chain[idx[-1]] != chain[idx[0]]:
            pairs.append(cKDTree(x[idx]).query_pairs(min_gap + 1.5 * ctx.pitch, output_type="ndarray"))
        pr = np.concatenate(pairs)
        a, b = idx[pr[:, 0]], idx[pr[:, 1]]
        # distance between the two moves (segments start -> x): at an end of one of them
        m2 = len(a)
        d = _point_segment(
            np.concatenate([x[a], x[b], start[a], start[b]]),
            np.concatenate([start[b], start[a], start[b], start[a]]),
            np.concatenate([x[b], x[a], x[b], x[a]]),
        ).reshape(4, m2)
        near = np.min(d, axis=0) < min_gap
        if np.any(near):
            alive[np.maximum(a[near], b[near])] = False
            ctx.count("killed_same_step", len(np.unique(np.maximum(a[near], b[near]))))
    for _ in range(8):
        idx = np.flatnonzero(alive & moving)
        if len(idx) < 2:
            break
        link = chain[idx[1:]] == chain[idx[:-1]]
        radial = _unit(_right(head[idx[1:]] + head[idx[:-1]]))
        dx = x[idx[1:]] - x[idx[:-1]]
        gap = np.add.reduce(dx * radial, axis=1)
        bad = link & ((gap < min_gap) | (np.add.reduce(dx * dx, axis=1) < min_gap * min_gap))
        if not np.any(bad):
            break
        j = np.flatnonzero(bad)
        gl = np.concatenate([[np.inf], np.where(link, gap, np.inf)])
        gr = np.concatenate([np.where(link, gap, np.inf), [np.inf]])
        victim = np.where(gl[j] <= gr[j + 1], j, j + 1)
        alive[idx[victim]] = False
        ctx.count("killed_too_close", len(np.unique(victim)))
    return alive, cells, samples


def _point_segment(p: Points2, a: Points2, b: Points2) -> Floats:
    """Distance from points to segments ``a -> b``, (n,)."""
    e = b - a
    den = np.add.reduce(e * e, axis=1)
    u = np.add.reduce((p - a) * e, axis=1) / np.where(den > 0, den, 1.0)
    q = a + np.minimum(np.maximum(u, 0.0), 1.0)[:, None] * e - p
    return np.sqrt(np.add.reduce(q * q, axis=1))


def _local_pitch(tab: np.ndarray, x: Points2, ctx: Context) -> Floats:
    """Local pitch of each agent: half the gap to each moving neighbour, the full gap to a boundary.

    Negative where the estimate is uncertain: an agent without a moving neighbour on both sides
    (a chain end, next to a boundary agent), whose other side may get paths the chain never sees;
    the engine measures those points on the finished layer (:mod:`.widths`).
    """
    m = len(tab)
    chain = tab[:, _CHAIN]
    bnd = tab[:, _KIND] < 0
    link = np.zeros(m + 1, dtype=bool)
    link[1:-1] = chain[1:] == chain[:-1]
    gap = np.full(m + 1, np.nan)
    # the radial distance (Eq. 8: across the mean travel of the pair), not the straight one, so a
    # front that runs oblique to its paths does not read as wider spacing
    d = x[1:] - x[:-1]
    radial = _unit(_right(tab[1:, _H] + tab[:-1, _H]))
    gap[1:-1] = np.abs(np.add.reduce(d * radial, axis=1))
    left_b = np.zeros(m, dtype=bool)
    right_b = np.zeros(m, dtype=bool)
    left_b[1:] = bnd[:-1]
    right_b[:-1] = bnd[1:]
    lpart = np.where(link[:-1], np.where(left_b, 1.0, 0.5) * gap[:-1], np.nan)
    rpart = np.where(link[1:], np.where(right_b, 1.0, 0.5) * gap[1:], np.nan)
    lpart = np.where(np.isnan(lpart), rpart, lpart)
    rpart = np.where(np.isnan(rpart), lpart, rpart)
    sure = link[:-1] & link[1:] & ~left_b & ~right_b
    out = np.where(np.isnan(lpart), ctx.pitch, lpart + rpart)
    out = np.minimum(np.maximum(out, 0.25 * ctx.pitch), 3.0 * ctx.pitch)
    return np.where(sure, out, -out)


def _merge(st: SwarmState, ctx: Context) -> SwarmState:
    """Stage 6: join chains whose facing ends met with no boundary between them."""
    starts = np.flatnonzero(st.start)
    if len(starts) < 2:
        return st
    a = st.pos[starts[1:] - 1]
    b = st.pos[starts[1:]]
    d = b - a
    close = np.add.reduce(d * d, axis=1) <= (ctx.params.merge_reach * ctx.pitch) ** 2
    # they must face each other: b lies to the right of a's travel
    close &= np.add.reduce(d * _right(st.head[starts[1:] - 1] + st.head[starts[1:]]), axis=1) > 0
    if not np.any(close):
        return st
    close[close] &= ~ctx.domain.crosses(a[close], b[close])
    if not np.any(close):
        return st
    start = st.start.copy()
    start[starts[1:][close]] = False
    ctx.count("merged", int(np.count_nonzero(close)))
    return SwarmState(st.pos, st.head, st.pid, start)


def _choose(tab: np.ndarray, kills: Ints, kw: Ints, spairs: Ints, sw: Ints, ctx: Context):
    """Stage 4b: solve X0, X-1, X+1 (Eq. 12) and keep per window the lowest potential (Eq. 13).

    Returns the chosen table, its problem and solution.
    """
    n_win = int(tab[-1, _WIN]) + 1 if len(tab) else 0
    variants = [tab]
    if len(kills):
        variants.append(_variant(tab, kills, np.zeros(0, np.int64)))
    if len(spairs):
        variants.append(_variant(tab, np.zeros(0, np.int64), spairs))
    if len(variants) == 1:
        _, cp, u = _solve(variants, ctx)
        return tab, cp, u
    sizes = [len(v) for v in variants]
    glued, cp, u = _solve(variants, ctx)
    wtab = glued.copy()
    wtab[:, _WIN] += np.repeat(n_win * np.arange(len(variants)), sizes)
    pot_all = _window_potentials(wtab, cp, u, n_win * len(variants)).reshape(len(variants), n_win)
    pot = np.full((3, n_win), np.inf)
    pot[0] = pot_all[0]
    vi = 1
    if len(kills):
        pot[1, kw] = pot_all[vi, kw]
        vi += 1
    if len(spairs):
        pot[2, sw] = pot_all[vi, sw]
    choice = np.argmin(pot, axis=0)  # ties keep X0
    take_kill = choice[kw] == 1
    take_spawn = choice[sw] == 2
    ctx.count("kills", int(np.count_nonzero(take_kill)))
    ctx.count("spawns", int(np.count_nonzero(take_spawn)))
    if not (np.any(take_kill) or np.any(take_spawn)):
        vi = 0
    elif len(kills) and np.all(take_kill) and not np.any(take_spawn):
        vi = 1
    elif len(spairs) and np.all(take_spawn) and not np.any(take_kill):
        vi = len(variants) - 1
    else:
        final = _variant(tab, kills[take_kill], spairs[take_spawn])
        _, cp, u = _solve([final], ctx)
        return final, cp, u
    lo = int(np.sum(sizes[:vi]))
    hi = lo + sizes[vi]
    sub = ChainProblem(
        t=cp.t[lo:hi],
        frame=cp.frame[lo:hi],
        lo=cp.lo[lo:hi],
        hi=cp.hi[lo:hi],
        weight=cp.weight[lo:hi],
        link=cp.link[lo : hi - 1],
        radial=cp.radial[lo : hi - 1],
        target=cp.target[lo : hi - 1],
    )
    return variants[vi], sub, u[2 * lo : 2 * hi]


def step(st: SwarmState, ctx: Context) -> tuple[SwarmState, Points2, Ints, Floats, Points2]:
    """Advance the swarm by one step.

    Parameters
    ----------
    st : SwarmState
    ctx : Context

    Returns
    -------
    state : SwarmState
        The next state (possibly empty).
    points : (m, 2) float, mm
        New locations of the surviving agents.
    pid : (m,) int
        Their path ids.
    pitch : (m,) float, mm
        Their local pitch, negative where uncertain (see :func:`_local_pitch`).
    prev : (m, 2) float, mm
        Their previous locations (spawned agents: the new location).
    """
    t, sdir, mass = _ideal(st, ctx)
    st, t, sdir, mass, (last, last_pid) = _remove_blocked(st, t, sdir, mass, ctx)
    last_pitch = np.full(len(last), -ctx.pitch)
    if st.n == 0:
        return st, last, last_pid, last_pitch, last
    tab = _extend(st, t, sdir, mass, ctx)
    kw, kills, sw, spairs = _propose(tab, ctx)
    final, cp, u = _choose(tab, kills, kw, spairs, sw, ctx)
    x = positions(cp, u) * ctx.pitch
    # boundary agents: tangent step done in the QP, now back onto the boundary
    bnd = final[:, _KIND] < 0
    if np.any(bnd):
        x[bnd] = ctx.domain.project_local(x[bnd], final[bnd, _SEG].astype(np.int64))
    alive, cells, samples = _safety(final, x, ctx)
    if not np.all(alive):
        final = final[alive]
        x = x[alive]
        cells = cells[alive]
        samples = samples[alive]
    pitch = _local_pitch(final, x, ctx)
    mv = final[:, _KIND] >= 0
    fm = final[mv]
    pid = fm[:, _PID].astype(np.int64)
    fresh = pid == -3
    if np.any(fresh):
        pid[fresh] = ctx.new_pids(int(np.count_nonzero(fresh)))
    xm = x[mv]
    spawned = (fm[:, _KIND] == 1)[:, None]
    prev = np.where(spawned, xm, fm[:, _P])
    moved = xm - prev
    step_len2 = np.add.reduce(moved * moved, axis=1)
    head = np.where((step_len2 > (0.1 * ctx.pitch) ** 2)[:, None], _unit(moved), fm[:, _H])
    chain = fm[:, _CHAIN]
    start = np.ones(len(chain), dtype=bool)
    start[1:] = chain[1:] != chain[:-1]
    new = SwarmState(pos=xm, head=head, pid=pid, start=start)
    ctx.grid.mark_cells(cells[mv], samples[mv], pid)  # the trails prev -> xm
    new = _merge(new, ctx)
    if len(last):
        return (
            new,
            np.concatenate([xm, last]),
            np.concatenate([pid, last_pid]),
            np.concatenate([pitch[mv], last_pitch]),
            np.concatenate([prev, last]),
        )
    return new, xm, pid, pitch[mv], prev
