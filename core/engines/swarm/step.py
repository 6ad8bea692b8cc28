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
from loadpath.field import StressField

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
    """

    K: float = 5.0
    window: int = 16
    kill_below: float = 0.85
    spawn_above: float = 1.3
    min_gap: float = 0.5
    margin: float = 0.25
    ray_reach: float = 2.5
    merge_reach: float = 2.5
    grow_free_ends: bool = False


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

    field: StressField
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


def _unit(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return np.where(n > 0, v / np.where(n > 0, n, 1.0), v)


def _right(v: np.ndarray) -> np.ndarray:
    """Clockwise normal ``-(v^perp)`` (Eq. 5: the radial direction points to the right of travel)."""
    return np.stack([v[..., 1], -v[..., 0]], axis=-1)


# ----------------------------------------------------------------------------------------------
# the extended chain (moving agents plus boundary agents) as flat arrays
# ----------------------------------------------------------------------------------------------


@dataclass
class _Ext:
    """Moving and boundary agents of all chains, in order.

    ``kind``: 0 moving agent, 1 spawned this step, -1 boundary agent.
    """

    t: Points2  # ideal location (boundary agents: reference point on the boundary), mm
    e1: Points2  # along-direction of the frame (stress direction, or boundary tangent)
    mass: Floats
    head: Points2  # last displacement direction (zero for boundary agents)
    pos: Points2  # location x(k) (spawned and boundary agents: t)
    kind: Ints
    chain: Ints
    win: Ints
    pid: Ints

    def take(self, idx: Ints | Bools) -> _Ext:
        return _Ext(*(getattr(self, f)[idx] for f in _FIELDS))

    @staticmethod
    def cat(parts: list[_Ext]) -> _Ext:
        return _Ext(*(np.concatenate([getattr(p, f) for p in parts]) for f in _FIELDS))

    @property
    def moving(self) -> Bools:
        return self.kind >= 0

    def links(self) -> tuple[Bools, Points2, Floats]:
        """Links, radial unit vectors (Eq. 5-6) and target distances (in pitches) of neighbours."""
        link = self.chain[1:] == self.chain[:-1]
        radial = _unit(_right(self.head[1:] + self.head[:-1]))
        bnd = (self.kind[1:] < 0) | (self.kind[:-1] < 0)
        return link, radial, np.where(bnd, 0.5, 1.0)

    def problem(self, pitch: float, K: float) -> ChainProblem:
        moving = self.moving
        e2 = np.stack([-self.e1[:, 1], self.e1[:, 0]], axis=1)
        lo = np.where(moving[:, None], [-BOX_ALONG, -BOX_ACROSS], [-BOUNDARY_SLIDE, 0.0])
        hi = np.where(moving[:, None], [BOX_ALONG, BOX_ACROSS], [BOUNDARY_SLIDE, 0.0])
        link, radial, target = self.links()
        return ChainProblem(
            t=self.t / pitch,
            frame=np.stack([self.e1, e2], axis=1),
            lo=lo,
            hi=hi,
            weight=np.where(moving, K * np.maximum(self.mass, MASS_FLOOR), 0.0),
            link=link,
            radial=radial,
            target=target,
        )


_FIELDS = tuple(_Ext.__dataclass_fields__)


def _gaps(ext: _Ext, pitch: float) -> Floats:
    """Radial gap of each neighbour pair over its target (NaN where not linked), (n - 1,)."""
    link, radial, target = ext.links()
    gap = np.sum((ext.t[1:] - ext.t[:-1]) * radial, axis=1) / (pitch * target)
    return np.where(link, gap, np.nan)


def _windows(ext: _Ext, window: int) -> Ints:
    """Window of each agent: rank of moving agents within their chain // window."""
    m = len(ext.kind)
    moving = ext.moving
    first = np.ones(m, dtype=bool)
    first[1:] = ext.chain[1:] != ext.chain[:-1]
    cum = np.cumsum(moving)
    first_idx = np.maximum.accumulate(np.where(first, np.arange(m), 0))
    before = cum[first_idx] - moving[first_idx]
    rank = np.maximum(cum - before - 1, 0)
    key = ext.chain * (m + 1) + rank // max(1, window)
    return np.unique(key, return_inverse=True)[1].astype(np.int64)


def _window_potential(ext: _Ext, cp: ChainProblem, u: Floats, n_win: int) -> Floats:
    """Potential per moving agent in each window (Eq. 13 restricted to the window), (n_win,)."""
    pair, agent = potentials(cp, u)
    lw = np.where(ext.kind[:-1] >= 0, ext.win[:-1], ext.win[1:])
    tot = np.bincount(ext.win, weights=agent, minlength=n_win)
    tot += np.bincount(lw, weights=pair, minlength=n_win)
    cnt = np.bincount(ext.win, weights=ext.moving.astype(float), minlength=n_win)
    return np.where(cnt > 0, tot / np.maximum(cnt, 1.0), np.inf)


def _extreme_per_window(win: Ints, key: Floats) -> tuple[Ints, Ints]:
    """For each window, the index of the smallest finite key (ties: the lowest index)."""
    ok = np.isfinite(key)
    idx = np.flatnonzero(ok)
    if not len(idx):
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    order = idx[np.lexsort((idx, key[idx], win[idx]))]
    g = win[order]
    first = np.ones(len(g), dtype=bool)
    first[1:] = g[1:] != g[:-1]
    return g[first], order[first]


# ----------------------------------------------------------------------------------------------
# the stages
# ----------------------------------------------------------------------------------------------


def _ideal(st: SwarmState, ctx: Context) -> tuple[Points2, Points2, Floats]:
    """Stage 1: step direction (Eq. 2 with momentum), ideal locations and virtual masses."""
    smp = ctx.field.sample(st.pos)
    link = ~st.start[1:]
    mean = st.head.copy()
    mean[:-1] += np.where(link[:, None], st.head[1:], 0.0)
    mean[1:] += np.where(link[:, None], st.head[:-1], 0.0)
    mean = _unit(mean)
    mean = np.where(np.linalg.norm(mean, axis=1)[:, None] > 0.5, mean, st.head)
    valid = smp.valid & np.all(np.isfinite(smp.direction), axis=1)
    s = np.where(valid[:, None], smp.direction, mean)
    mu = np.where(np.sum(s * st.head, axis=1) >= 0, 1.0, -1.0)
    sdir = _unit(mu[:, None] * s)
    mass = np.where(valid, smp.mass, 0.0)
    ctx.count("no_direction", int(np.count_nonzero(~valid)))
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
        dist, _, _ = ctx.domain.ray(st.pos[ends], sdir[ends], 2.0 * ctx.pitch)
        reach = np.where(np.isfinite(dist), dist - 0.5 * ctx.pitch, 0.0)
        go = (reach > 0.1 * ctx.pitch) & (reach <= ctx.pitch)
        q = st.pos[ends[go]] + reach[go, None] * sdir[ends[go]]
        fine = ctx.grid.free_path(st.pos[ends[go]], q, st.pid[ends[go]]) & ctx.grid.clear_of(
            q, st.pid[ends[go]], (ctx.params.min_gap + 1.0 / 12.0) * ctx.pitch
        )
        last = (q[fine], st.pid[ends[go]][fine])
        ctx.grid.mark(st.pos[ends[go]][fine], q[fine], st.pid[ends[go]][fine])
    gone_before = np.zeros(st.n, dtype=bool)
    gone_before[1:] = ~ok[:-1]
    start = (st.start | gone_before)[ok]
    if len(start):
        start[0] = True
    st2 = SwarmState(pos=st.pos[ok], head=st.head[ok], pid=st.pid[ok], start=start)
    return st2, t[ok], sdir[ok], mass[ok], last


def _extend(st: SwarmState, t: Points2, sdir: Points2, mass: Floats, ctx: Context) -> _Ext:
    """Stage 3: boundary agents at chain ends, new agents at free ends."""
    p = ctx.params
    pitch = ctx.pitch
    n = st.n
    starts = np.flatnonzero(st.start)
    ends = np.append(starts[1:] - 1, n - 1)
    nc = len(starts)
    chain = np.cumsum(st.start) - 1
    src = np.concatenate([starts, ends])
    dirs = np.concatenate([-_right(st.head[starts]), _right(st.head[ends])])
    dist, point, tangent = ctx.domain.ray(t[src], dirs, p.ray_reach * pitch)
    hit = np.isfinite(dist)
    # free ends: one new agent a pitch further out, if there is room
    cand = t[src] + pitch * dirs
    spawn = ~hit & ctx.domain.inside(cand) & ctx.grid.free_for(cand, np.full(len(cand), -2))
    # only where the chain really ends there: the ray continues the chain's own line (an end
    # agent that turned with the field, e.g. into the hoop stress at a hole, must not grow a
    # chain along the direction of travel)
    nb = np.concatenate([np.minimum(starts + 1, ends), np.maximum(ends - 1, starts)])
    along = _unit(t[src] - t[nb])
    lone = nb == src
    square = np.abs(np.sum(st.head[src] * along, axis=1)) < 0.5
    spawn &= ~lone & square & (np.sum(along * dirs, axis=1) > 0.8) & p.grow_free_ends
    if np.any(spawn):
        idx = np.flatnonzero(spawn)
        d = np.min(np.linalg.norm(cand[idx][:, None, :] - t[None, :, :], axis=2), axis=1)
        spawn[idx[d < 0.75 * pitch]] = False
        if nc == 1 and n == 1 and spawn[0] and spawn[1]:
            spawn[1] = False  # a lone agent grows on one side per step
    k = int(np.count_nonzero(spawn))
    ctx.count("spawn_free_end", k)
    left = np.arange(2 * nc) < nc
    # ordering keys: 3j+1 moving agent j; 3j left of it; 3j+2 right of it
    keys = [3 * np.arange(n) + 1.0]
    parts = [
        _Ext(t, sdir, mass, st.head, st.pos, np.zeros(n, np.int64), chain, np.zeros(n, np.int64), st.pid)
    ]
    sp = np.flatnonzero(spawn)
    if k:
        s_src = src[sp]
        keys.append(np.where(left[sp], 3 * s_src + 0.0, 3 * s_src + 2.0))
        parts.append(
            _Ext(
                cand[sp], sdir[s_src], mass[s_src], st.head[s_src], cand[sp],
                np.ones(k, np.int64), chain[s_src], np.zeros(k, np.int64), ctx.new_pids(k),
            )
        )
    bh = np.flatnonzero(hit)
    if len(bh):
        b_src = src[bh]
        keys.append(np.where(left[bh], 3 * b_src - 0.4, 3 * b_src + 2.4))
        nb = len(bh)
        parts.append(
            _Ext(
                point[bh], tangent[bh], np.zeros(nb), np.zeros((nb, 2)), point[bh],
                np.full(nb, -1, np.int64), chain[b_src], np.zeros(nb, np.int64), np.full(nb, -1, np.int64),
            )
        )
    ext = _Ext.cat(parts).take(np.argsort(np.concatenate(keys), kind="stable"))
    ext.win = _windows(ext, p.window)
    return ext


def _propose(ext: _Ext, ctx: Context) -> tuple[Ints, Ints, Ints, Ints]:
    """Stage 4a: per window, the agent to kill and the pair to split (indices into ``ext``).

    Returns kill windows, kill agents, spawn windows, spawn pairs (spawn between j and j + 1).
    """
    p = ctx.params
    gap = _gaps(ext, ctx.pitch)
    lw = np.where(ext.kind[:-1] >= 0, ext.win[:-1], ext.win[1:])
    kw, kpair = _extreme_per_window(lw, np.where(gap < p.kill_below, gap, np.inf))
    sw, spair = _extreme_per_window(lw, np.where(gap > p.spawn_above, -gap, np.inf))
    # the victim: the moving agent of the pair whose other neighbour is closer too
    m = len(ext.kind)
    left_other = np.where(kpair - 1 >= 0, gap[np.maximum(kpair - 1, 0)], np.inf)
    right_other = np.where(kpair + 1 < m - 1, gap[np.minimum(kpair + 1, m - 2)], np.inf)
    left_other = np.where(np.isnan(left_other), np.inf, left_other)
    right_other = np.where(np.isnan(right_other), np.inf, right_other)
    victim = np.where(left_other <= right_other, kpair, kpair + 1)
    victim = np.where(ext.kind[kpair] < 0, kpair + 1, np.where(ext.kind[kpair + 1] < 0, kpair, victim))
    ok = ext.kind[victim] >= 0
    return kw[ok], victim[ok], sw, spair


def _spawned(ext: _Ext, pairs: Ints, ctx: Context) -> _Ext:
    """New agents in the gaps ``(j, j + 1)``: at the point that splits the gap by the targets."""
    a, b = pairs, pairs + 1
    la = np.where(ext.kind[a] < 0, 0.5, 1.0)
    lb = np.where(ext.kind[b] < 0, 0.5, 1.0)
    frac = (la / (la + lb))[:, None]
    t = ext.t[a] + frac * (ext.t[b] - ext.t[a])
    mov_a = (ext.kind[a] >= 0)[:, None]
    mov_b = (ext.kind[b] >= 0)[:, None]
    e1 = _unit(np.where(mov_a, ext.e1[a], 0.0) + np.where(mov_b, ext.e1[b], 0.0))
    head = _unit(np.where(mov_a, ext.head[a], 0.0) + np.where(mov_b, ext.head[b], 0.0))
    wa = mov_a[:, 0].astype(float)
    wb = mov_b[:, 0].astype(float)
    mass = (wa * ext.mass[a] + wb * ext.mass[b]) / np.maximum(wa + wb, 1.0)
    k = len(pairs)
    return _Ext(
        t, e1, mass, head, t.copy(), np.ones(k, np.int64), ext.chain[a],
        np.where(ext.kind[a] >= 0, ext.win[a], ext.win[b]), np.full(k, -3, np.int64),
    )


def _variant(ext: _Ext, kill: Ints, spawn_pairs: Ints, ctx: Context) -> _Ext:
    """The swarm with the given agents killed and new agents in the given gaps."""
    keep = np.ones(len(ext.kind), dtype=bool)
    keep[kill] = False
    if not len(spawn_pairs):
        return ext.take(keep)
    new = _spawned(ext, spawn_pairs, ctx)
    keys = np.concatenate([np.arange(len(ext.kind), dtype=float), spawn_pairs + 0.5])
    both = _Ext.cat([ext, new])
    keep_all = np.concatenate([keep, np.ones(len(spawn_pairs), dtype=bool)])
    order = np.argsort(keys, kind="stable")
    return both.take(order[keep_all[order]])


def _solve_many(variants: list[_Ext], ctx: Context) -> list[tuple[ChainProblem, Floats]]:
    """Solve the QPs of several swarms as one banded system (they do not interact)."""
    probs = [v.problem(ctx.pitch, ctx.params.K) for v in variants]
    offsets = np.cumsum([0] + [cp.n for cp in probs])
    glued = ChainProblem(
        t=np.concatenate([cp.t for cp in probs]),
        frame=np.concatenate([cp.frame for cp in probs]),
        lo=np.concatenate([cp.lo for cp in probs]),
        hi=np.concatenate([cp.hi for cp in probs]),
        weight=np.concatenate([cp.weight for cp in probs]),
        link=np.concatenate(
            [np.concatenate([cp.link, [False]]) for cp in probs[:-1]] + [probs[-1].link]
        ),
        radial=np.concatenate(
            [np.concatenate([cp.radial, np.zeros((1, 2))]) for cp in probs[:-1]] + [probs[-1].radial]
        ),
        target=np.concatenate([np.concatenate([cp.target, [1.0]]) for cp in probs[:-1]] + [probs[-1].target]),
    )
    qp, _ = build_qp(glued)
    sol = solve(qp)
    ctx.count("qp_solves")
    ctx.count("qp_unknowns", qp.n)
    ctx.count("qp_" + sol.status.replace(":", "_"))
    return [
        (cp, sol.x[2 * offsets[i] : 2 * offsets[i + 1]]) for i, cp in enumerate(probs)
    ]


def _safety(ext: _Ext, x: Points2, ctx: Context) -> Bools:
    """Stage 5: which moving agents survive (inside, free cells, at least min_gap from neighbours)."""
    start = np.where((ext.kind == 0)[:, None], ext.pos, x)
    clear = ctx.grid.clear_of(x, ext.pid, (ctx.params.min_gap + 1.0 / 12.0) * ctx.pitch)
    alive = ~ext.moving | (ctx.domain.inside(x) & ctx.grid.free_path(start, x, ext.pid) & clear)
    for _ in range(8):
        idx = np.flatnonzero(alive & ext.moving)
        if len(idx) < 2:
            break
        sub = ext.take(idx)
        link, radial, _ = sub.links()
        gap = np.sum((x[idx[1:]] - x[idx[:-1]]) * radial, axis=1)
        dist = np.linalg.norm(x[idx[1:]] - x[idx[:-1]], axis=1)
        bad = link & ((gap < ctx.params.min_gap * ctx.pitch) | (dist < ctx.params.min_gap * ctx.pitch))
        if not np.any(bad):
            break
        j = np.flatnonzero(bad)
        gl = np.concatenate([[np.inf], np.where(link, gap, np.inf)])
        gr = np.concatenate([np.where(link, gap, np.inf), [np.inf]])
        victim = np.where(gl[j] <= gr[j + 1], j, j + 1)
        alive[idx[victim]] = False
        ctx.count("killed_too_close", len(np.unique(victim)))
    return alive


def _local_pitch(ext: _Ext, x: Points2, ctx: Context) -> Floats:
    """Local pitch of each agent: half the gap to each moving neighbour, the full gap to a boundary."""
    m = len(ext.kind)
    link = np.zeros(m + 1, dtype=bool)
    link[1:-1] = ext.chain[1:] == ext.chain[:-1]
    gap = np.full(m + 1, np.nan)
    gap[1:-1] = np.linalg.norm(x[1:] - x[:-1], axis=1)
    left_b = np.zeros(m, dtype=bool)
    right_b = np.zeros(m, dtype=bool)
    left_b[1:] = ext.kind[:-1] < 0
    right_b[:-1] = ext.kind[1:] < 0
    lpart = np.where(link[:-1], np.where(left_b, 1.0, 0.5) * gap[:-1], np.nan)
    rpart = np.where(link[1:], np.where(right_b, 1.0, 0.5) * gap[1:], np.nan)
    lpart = np.where(np.isnan(lpart), rpart, lpart)
    rpart = np.where(np.isnan(rpart), lpart, rpart)
    out = np.where(np.isnan(lpart), ctx.pitch, lpart + rpart)
    return np.clip(out, 0.25 * ctx.pitch, 3.0 * ctx.pitch)


def _merge(st: SwarmState, ctx: Context) -> SwarmState:
    """Stage 6: join chains whose facing ends met with no boundary between them."""
    starts = np.flatnonzero(st.start)
    if len(starts) < 2:
        return st
    a = st.pos[starts[1:] - 1]
    b = st.pos[starts[1:]]
    close = np.linalg.norm(b - a, axis=1) <= ctx.params.merge_reach * ctx.pitch
    # they must face each other: b lies to the right of a's travel
    close &= np.sum((b - a) * _right(st.head[starts[1:] - 1] + st.head[starts[1:]]), axis=1) > 0
    if not np.any(close):
        return st
    close[close] &= ~ctx.domain.crosses(a[close], b[close])
    if not np.any(close):
        return st
    start = st.start.copy()
    start[starts[1:][close]] = False
    ctx.count("merged", int(np.count_nonzero(close)))
    return SwarmState(st.pos, st.head, st.pid, start)


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
        Their local pitch.
    prev : (m, 2) float, mm
        Their previous locations (spawned agents: the new location).
    """
    t, sdir, mass = _ideal(st, ctx)
    st, t, sdir, mass, (last, last_pid) = _remove_blocked(st, t, sdir, mass, ctx)
    last_pitch = np.full(len(last), ctx.pitch)
    if st.n == 0:
        return st, last, last_pid, last_pitch, last
    ext = _extend(st, t, sdir, mass, ctx)
    kw, kills, sw, spairs = _propose(ext, ctx)
    variants = [ext]
    if len(kills):
        variants.append(_variant(ext, kills, np.zeros(0, np.int64), ctx))
    if len(spairs):
        variants.append(_variant(ext, np.zeros(0, np.int64), spairs, ctx))
    sols = _solve_many(variants, ctx)
    final, (cp, u) = ext, sols[0]
    if len(variants) > 1:
        n_win = int(ext.win.max()) + 1
        pot = np.full((3, n_win), np.inf)
        pot[0] = _window_potential(ext, *sols[0], n_win)
        vi = 1
        if len(kills):
            pk = _window_potential(variants[vi], *sols[vi], n_win)
            pot[1, kw] = pk[kw]
            vi += 1
        if len(spairs):
            ps = _window_potential(variants[vi], *sols[vi], n_win)
            pot[2, sw] = ps[sw]
        choice = np.argmin(pot, axis=0)  # ties keep X0
        take_kill = np.isin(kw, np.flatnonzero(choice == 1))
        take_spawn = np.isin(sw, np.flatnonzero(choice == 2))
        ctx.count("kills", int(np.count_nonzero(take_kill)))
        ctx.count("spawns", int(np.count_nonzero(take_spawn)))
        if np.any(take_kill) or np.any(take_spawn):
            if np.all(take_kill) and len(kills) and not np.any(take_spawn):
                final, (cp, u) = variants[1], sols[1]
            elif np.all(take_spawn) and len(spairs) and not np.any(take_kill):
                final, (cp, u) = variants[-1], sols[-1]
            else:
                final = _variant(ext, kills[take_kill], spairs[take_spawn], ctx)
                cp, u = _solve_many([final], ctx)[0]
    x = positions(cp, u) * ctx.pitch
    # boundary agents: tangent step done in the QP, now back onto the boundary
    bnd = final.kind < 0
    if np.any(bnd):
        x[bnd] = ctx.domain.project(x[bnd])[0]
    alive = _safety(final, x, ctx)
    final = final.take(alive)
    x = x[alive]
    pitch = _local_pitch(final, x, ctx)
    mv = final.moving
    fresh = final.pid[mv] == -3
    pid = final.pid[mv].copy()
    pid[fresh] = ctx.new_pids(int(np.count_nonzero(fresh)))
    xm = x[mv]
    prev = np.where((final.kind[mv] == 1)[:, None], xm, final.pos[mv])
    moved = xm - prev
    head = np.where(
        (np.linalg.norm(moved, axis=1) > 0.1 * ctx.pitch)[:, None], _unit(moved), final.head[mv]
    )
    chain = final.chain[mv]
    start = np.ones(len(chain), dtype=bool)
    start[1:] = chain[1:] != chain[:-1]
    new = SwarmState(pos=xm, head=head, pid=pid, start=start)
    ctx.grid.mark(prev, xm, pid)
    new = _merge(new, ctx)
    return (
        new,
        np.concatenate([xm, last]),
        np.concatenate([pid, last_pid]),
        np.concatenate([pitch[mv], last_pitch]),
        np.concatenate([prev, last]),
    )
