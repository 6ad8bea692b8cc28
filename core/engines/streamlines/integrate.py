"""Streamline integration: many seeds traced at once, both ways, through a sign-less field.

Each seed starts two particles (thesis Eqs. 4.3-4.4: ``x_1F = x_0 + v_0 dt``, ``x_1B = x_0 - v_0 dt``)
and all particles advance in lockstep, one numpy operation per step for all of them.

Sign rule (thesis Sec. 4.1.1, Fig. 4.3b; App. C ``ForwardFlip``/``BackwardFlip``)
    At every evaluation the direction ``d`` or ``-d`` is taken, whichever makes the smaller angle
    with the previous step (``d . v_prev >= 0``).  RK2 applies the rule at both stages (the
    midpoint direction is aligned with the first stage), Euler (the thesis's Eq. 4.2) once.

Step length
    Constant ``step`` (the thesis's ``d_L``): directions are unit vectors, so the thesis's
    shrinking ``|v| dt`` near zero-velocity boundary nodes does not occur; the boundary is found
    exactly instead (below).

Termination, per branch (each end of a line records why it stopped, ``END_*``)
    ``END_BOUNDARY``  the step leaves the region: the last vertex is the exact crossing (bisection),
                      replacing the thesis's ``U ~ 0 && V ~ 0`` test, whose tolerance it never gives.
    ``END_DEGENERATE`` the direction is undefined (:mod:`.directions`).
    ``END_TURN``      the step would turn by more than ``max_turn`` (a sharp turn is unprintable;
                      the thesis has no limit - digest §6 - and its faithful mode keeps only the
                      90-degree bound that the sign rule implies).  Both RK2 stages are tested
                      (across a 90-degree jump the midpoint can land back on the near side and
                      hide the turn), and each branch's first step may turn only half as much,
                      because the path turns by the sum of both first steps at its seed.
    ``END_SPACING``   the step would come closer than ``clearance`` to an accepted path: the branch
                      ends on the exact clear fraction of the step (bisection), Jobard-Lefer style.
    ``END_LOOP``      the branch returns near its own seed (the thesis's "comes near to the other
                      branch", App. C, whose distance it never gives: here ``loop_radius``); after
                      tracing, any vertex that comes back within ``loop_radius`` of an earlier part
                      of its own line (more than ``2 loop_radius + 2 step`` of arc away) cuts the
                      line there too (:func:`_cut_loops`).
    ``END_LENGTH``    guard: ``max_length`` reached (closed trajectories around a centre-type point).
The thesis's loop exit ``if flagForward==1 && flagBackward==1 Break`` (App. C) is read as the
evident "both branches stopped".

(Over 400 lines: the batched tracer :func:`trace` and the history, assembly and loop cuts that
only it uses share the :class:`Traced` record and its per-particle arrays; they are one stage.)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from loadpath._typing import Ints, Points2
from loadpath.engines.streamlines._lines import Lines
from loadpath.engines.streamlines.directions import DirectionGrid
from loadpath.engines.streamlines.segindex import SegmentIndex
from scipy.spatial import cKDTree

__all__ = [
    "END_BOUNDARY",
    "END_DEGENERATE",
    "END_TURN",
    "END_SPACING",
    "END_LOOP",
    "END_LENGTH",
    "END_NAMES",
    "TraceSettings",
    "Traced",
    "trace",
]

END_BOUNDARY, END_DEGENERATE, END_TURN, END_SPACING, END_LOOP, END_LENGTH = 1, 2, 3, 4, 5, 6
END_NAMES = {
    END_BOUNDARY: "boundary",
    END_DEGENERATE: "degenerate",
    END_TURN: "turn",
    END_SPACING: "spacing",
    END_LOOP: "loop",
    END_LENGTH: "length",
}

_BISECT_BOUNDARY = 14  # step / 2^14: well under a micrometre
_BISECT_SPACING = 5  # step / 32


@dataclass(frozen=True)
class TraceSettings:
    """How to trace.

    Attributes
    ----------
    step : float, mm
    method : {"rk2", "euler"}
    max_turn : float, rad
    max_length : float, mm
        Per branch.
    clearance : float, mm
        Distance kept from ``obstacles``.
    loop_radius : float, mm
    """

    step: float
    method: str
    max_turn: float
    max_length: float
    clearance: float
    loop_radius: float


@dataclass(frozen=True)
class Traced:
    """Traced streamlines, one per seed that produced at least one segment.

    Attributes
    ----------
    lines : Lines
        Backward branch (reversed), seed, forward branch.
    seed : (m,) int
        Index of each line's seed in the seeds passed to :func:`trace`.
    seed_vertex : (m,) int
        Position of the seed within its line.
    end_start, end_finish : (m,) int
        Why the line's first and last vertex ended it (``END_*``).
    """

    lines: Lines
    seed: Ints
    seed_vertex: Ints
    end_start: Ints
    end_finish: Ints


def _align(d: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """``d`` or ``-d``, whichever points along ``ref`` (row-wise)."""
    s = np.where(np.sum(d * ref, axis=1) < 0, -1.0, 1.0)
    return d * s[:, None]


def _boundary_crossing(grid: DirectionGrid, a: Points2, b: Points2) -> Points2:
    """Last inside point on each segment ``a -> b`` with ``a`` inside and ``b`` outside."""
    lo = np.zeros(len(a))
    hi = np.ones(len(a))
    for _ in range(_BISECT_BOUNDARY):
        mid = 0.5 * (lo + hi)
        ins = grid.inside(a + mid[:, None] * (b - a))
        lo = np.where(ins, mid, lo)
        hi = np.where(ins, hi, mid)
    return a + lo[:, None] * (b - a)


def _defined_fraction(grid: DirectionGrid, x: Points2, step: Points2) -> np.ndarray:
    """Largest ``t`` (bisection) such that the direction is defined at ``x + t step``."""
    lo = np.zeros(len(x))
    hi = np.ones(len(x))
    for _ in range(_BISECT_SPACING):
        mid = 0.5 * (lo + hi)
        _, ok = grid(x + mid[:, None] * step)
        lo = np.where(ok, mid, lo)
        hi = np.where(ok, hi, mid)
    return lo


def _clear_fraction(obstacles: SegmentIndex, a: Points2, b: Points2, clearance: float) -> np.ndarray:
    """Largest ``t`` (bisection) such that ``[a, a + t (b - a)]`` keeps ``clearance`` from obstacles."""
    return obstacles.clear_fraction(a, b, clearance, _BISECT_SPACING)


def trace(
    seeds: Points2,
    grid: DirectionGrid,
    settings: TraceSettings,
    obstacles: SegmentIndex | None = None,
    seed_clearance: float | None = None,
) -> Traced:
    """Trace streamlines from all seeds at once, both ways.

    The spacing test against ``obstacles`` is deferred: every ``_CHECK_EVERY`` steps the new
    segments of all particles are tested in one batch, and a particle whose segment came too
    close is cut back to the exact clear fraction of its first offending segment.  The result is
    the same as testing every step, with a fraction of the per-call overhead.

    Parameters
    ----------
    seeds : (n, 2) float, mm
    grid : DirectionGrid
    settings : TraceSettings
    obstacles : SegmentIndex, optional
        Accepted paths to keep ``settings.clearance`` from.
    seed_clearance : float, mm, optional
        A seed closer than this to an obstacle is not traced (default ``settings.clearance``).

    Returns
    -------
    Traced

    (Over 120 lines: the integration loop keeps every particle's state in local arrays updated in
    place each step; the deferred spacing test needs them all.)
    """
    seeds = np.asarray(seeds, dtype=float).reshape(-1, 2)
    n = len(seeds)
    h = float(settings.step)
    cos_turn = float(np.cos(settings.max_turn))
    cos_half = float(np.cos(0.5 * settings.max_turn))
    d0, ok0 = grid(seeds)
    ok0 &= grid.inside(seeds)
    if obstacles is not None and n:
        need = settings.clearance if seed_clearance is None else max(seed_clearance, settings.clearance)
        ok0 &= obstacles.point_distance(seeds, need) >= need
    # particle 2i: forward, 2i + 1: backward
    pos = np.repeat(seeds, 2, axis=0)
    vel = np.repeat(d0, 2, axis=0)
    vel[1::2] *= -1.0
    origin = pos.copy()
    travelled = np.zeros(2 * n)
    reason = np.zeros(2 * n, dtype=np.int64)
    alive = np.repeat(ok0, 2)
    active = np.flatnonzero(alive)
    hist = _History(2 * n)
    max_steps = int(np.ceil(settings.max_length / h)) + 1
    block_start = 0
    for step in range(max_steps):
        if len(active) == 0:
            break
        x = pos[active]
        v = vel[active]
        d1, ok1 = grid(x)
        k1 = _align(d1, v)
        k = k1
        ok = ok1.copy()
        ended_here = np.zeros(len(active), dtype=bool)
        if settings.method == "rk2":
            d2, ok2 = grid(x + 0.5 * h * k1)
            k = _align(d2, k1)
            ok &= ok2
        # the first step of each branch may turn only half as much: the two branches meet at the
        # seed, where the path turns by the sum of both first turns
        first = travelled[active] == 0.0
        lim = np.where(first, cos_half, cos_turn)
        # both RK2 stages must agree with the previous step: across a jump of the followed stress
        # the midpoint can land back on the near side and hide the 90-degree turn at x
        turn_ok = (np.sum(k * v, axis=1) >= lim) & (np.sum(k1 * v, axis=1) >= lim)
        go = ok & turn_ok
        stop_reason = np.where(ok, END_TURN, END_DEGENERATE)
        new = x + h * k
        if settings.method == "rk2":
            # a branch that runs into an undefined zone ends on its edge, as it ends on the boundary
            edge = np.flatnonzero(ok1 & ~ok2 & (np.sum(k1 * v, axis=1) >= lim))
            if len(edge):
                t_edge = _defined_fraction(grid, x[edge], h * k1[edge])
                part = edge[t_edge > 0.05]
                if len(part):
                    go[part] = True
                    new[part] = x[part] + (t_edge[t_edge > 0.05, None] * h) * k1[part]
                    k[part] = k1[part]
                    stop_reason[part] = END_DEGENERATE
                    ended_here[part] = True
        inside = np.ones(len(active), dtype=bool)
        gi = np.flatnonzero(go)
        inside[gi] = grid.inside(new[gi])
        out = gi[~inside[gi]]
        if len(out):
            new[out] = _boundary_crossing(grid, x[out], new[out])
            stop_reason[out] = END_BOUNDARY
        step_len = np.linalg.norm(new - x, axis=1)
        back = go & (travelled[active] + step_len > 2.0 * settings.loop_radius + 2.0 * h)
        back &= np.linalg.norm(new - origin[active], axis=1) < settings.loop_radius
        stop_reason[back] = END_LOOP
        add = go & ~back & (step_len > 1e-9)
        hist.append(step, active[add], x[add], new[add])
        pos[active[add]] = new[add]
        vel[active[add]] = k[add]
        travelled[active] += np.where(add, step_len, 0.0)
        cont = go & inside & ~back & ~ended_here & (travelled[active] < settings.max_length)
        stopped = ~cont
        reason[active[stopped]] = np.where(
            go[stopped] & inside[stopped] & ~back[stopped] & ~ended_here[stopped],
            END_LENGTH,
            stop_reason[stopped],
        )
        alive[active[stopped]] = False
        active = active[cont]
        if obstacles is not None and (step - block_start + 1 >= _CHECK_EVERY or len(active) == 0):
            hit = hist.check(block_start, step, obstacles, settings.clearance)
            reason[hit] = END_SPACING
            alive[hit] = False
            active = active[alive[active]]
            block_start = step + 1
    if obstacles is not None and block_start <= max_steps:
        hit = hist.check(block_start, max_steps, obstacles, settings.clearance)
        reason[hit] = END_SPACING
        alive[hit] = False
    reason[np.flatnonzero(alive & (reason == 0))] = END_LENGTH
    pidx, ppos, step_no = hist.arrays()
    return _assemble(seeds, ok0, pidx, ppos, step_no, reason, settings)


_CHECK_EVERY = 8


class _History:
    """Vertices added by each step, with the spacing cut-backs of the deferred check."""

    def __init__(self, n_particles: int) -> None:
        self.steps: list[int] = []
        self.idx: list[np.ndarray] = []
        self.prev: list[np.ndarray] = []
        self.new: list[np.ndarray] = []
        self.cut = np.full(n_particles, np.iinfo(np.int64).max)  # last kept step per particle

    def append(self, step: int, idx: np.ndarray, prev: Points2, new: Points2) -> None:
        self.steps.append(step)
        self.idx.append(idx)
        self.prev.append(prev)
        self.new.append(new)

    def check(self, first: int, last: int, obstacles: SegmentIndex, clearance: float) -> np.ndarray:
        """Test the segments of steps ``first..last``; cut particles back; return those cut."""
        sel = [i for i in range(len(self.steps) - 1, -1, -1) if first <= self.steps[i] <= last]
        if not sel:
            return np.zeros(0, dtype=np.int64)
        sel = sel[::-1]
        idx = np.concatenate([self.idx[i] for i in sel])
        a = np.concatenate([self.prev[i] for i in sel])
        b = np.concatenate([self.new[i] for i in sel])
        st = np.concatenate([np.full(len(self.idx[i]), self.steps[i]) for i in sel])
        bad = ~obstacles.clear(a, b, clearance)
        if not np.any(bad):
            return np.zeros(0, dtype=np.int64)
        bi = np.flatnonzero(bad)
        # first offending step of each particle
        order = np.lexsort((st[bi], idx[bi]))
        bi = bi[order]
        firsts = bi[np.concatenate([[True], idx[bi][1:] != idx[bi][:-1]])]
        t = _clear_fraction(obstacles, a[firsts], b[firsts], clearance)
        part = idx[firsts]
        fst = st[firsts]
        # replace the offending vertex by the clear fraction of its step
        pos_by_step = {s_: k for k, s_ in enumerate(self.steps)}
        for s_ in np.unique(fst):
            k = pos_by_step[int(s_)]
            m = fst == s_
            where = np.searchsorted(self.idx[k], part[m])
            self.new[k] = self.new[k].copy()
            self.new[k][where] = a[firsts[m]] + t[m, None] * (b[firsts[m]] - a[firsts[m]])
        self.cut[part] = np.minimum(self.cut[part], fst)
        return part

    def arrays(self) -> tuple[np.ndarray, Points2, np.ndarray]:
        """All kept vertices: particle index, position, step number."""
        if not self.idx:
            return np.zeros(0, dtype=np.int64), np.zeros((0, 2)), np.zeros(0, dtype=np.int64)
        idx = np.concatenate(self.idx)
        pos = np.concatenate(self.new)
        st = np.concatenate([np.full(len(i), s) for s, i in zip(self.steps, self.idx, strict=True)])
        keep = st <= self.cut[idx]
        # a cut-back vertex that did not move at all is dropped
        prev = np.concatenate(self.prev)
        keep &= np.linalg.norm(pos - prev, axis=1) > 1e-9
        return idx[keep], pos[keep], st[keep]


def _assemble(
    seeds: Points2,
    ok0: np.ndarray,
    pidx: np.ndarray,
    ppos: Points2,
    step_no: np.ndarray,
    reason: np.ndarray,
    settings: TraceSettings,
) -> Traced:
    """Join each seed's backward (reversed) and forward vertices into one line."""
    n = len(seeds)
    sid = np.concatenate([pidx // 2, np.flatnonzero(ok0)])
    fwd = np.concatenate([pidx % 2 == 0, np.zeros(int(np.sum(ok0)), dtype=bool)])
    # order key within a line: backward vertices by decreasing step, seed, forward by step
    key = np.concatenate([np.where(pidx % 2 == 0, step_no + 1, -(step_no + 1)), np.zeros(int(np.sum(ok0)))])
    pts = np.concatenate([ppos, seeds[ok0]])
    order = np.lexsort((key, sid))
    sid, pts, key, fwd = sid[order], pts[order], key[order], fwd[order]
    counts = np.bincount(sid, minlength=n)
    keep_seed = counts >= 2
    vkeep = keep_seed[sid]
    sid, pts, key = sid[vkeep], pts[vkeep], key[vkeep]
    seeds_kept = np.flatnonzero(keep_seed)
    offsets = np.concatenate([[0], np.cumsum(counts[keep_seed])])
    seed_vertex = np.flatnonzero(key == 0) - offsets[:-1]
    lines = Lines(pts, offsets.astype(np.int64))
    traced = Traced(
        lines=lines,
        seed=seeds_kept,
        seed_vertex=seed_vertex,
        end_start=reason[2 * seeds_kept + 1],
        end_finish=reason[2 * seeds_kept],
    )
    return _cut_loops(traced, settings)


def _cut_loops(traced: Traced, settings: TraceSettings) -> Traced:
    """Cut lines where they come back within ``loop_radius`` of their own earlier part.

    Vertices of different lines are kept apart in a 3D KD-tree by a third coordinate (line index
    times a large number), so one ``query_pairs`` finds every self-approach of every line at once.
    """
    lines = traced.lines
    if len(lines) == 0:
        return traced
    vl = lines.vertex_line
    local = np.arange(len(vl)) - lines.offsets[vl]
    rel = local - traced.seed_vertex[vl]  # <0 backward, >0 forward
    seg = np.linalg.norm(np.diff(lines.points, axis=0), axis=1)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    s = cum - cum[lines.offsets[:-1] + traced.seed_vertex][vl]  # signed arc length from the seed
    big = 10.0 * (np.ptp(lines.points[:, 0]) + np.ptp(lines.points[:, 1]) + 1.0)
    tree = cKDTree(np.column_stack([lines.points, vl * big]))
    pairs = tree.query_pairs(settings.loop_radius, output_type="ndarray")
    if len(pairs) == 0:
        return traced
    i, j = pairs[:, 0], pairs[:, 1]
    far = np.abs(s[i] - s[j]) > 2.0 * settings.loop_radius + 2.0 * settings.step
    i, j = i[far], j[far]
    if len(i) == 0:
        return traced
    later = np.where(np.abs(s[i]) >= np.abs(s[j]), i, j)
    m = len(lines)
    cut_f = np.full(m, np.inf)
    cut_b = np.full(m, np.inf)
    fw = rel[later] > 0
    np.minimum.at(cut_f, vl[later[fw]], s[later[fw]])
    np.minimum.at(cut_b, vl[later[~fw]], -s[later[~fw]])
    keep = np.where(rel > 0, s < cut_f[vl], np.where(rel < 0, -s < cut_b[vl], True))
    new_lines, new_seed_vertex = [], []
    end_s = traced.end_start.copy()
    end_f = traced.end_finish.copy()
    end_f[np.isfinite(cut_f)] = END_LOOP
    end_s[np.isfinite(cut_b)] = END_LOOP
    for k in range(m):
        a, b = lines.offsets[k], lines.offsets[k + 1]
        kk = keep[a:b]
        new_lines.append(lines.points[a:b][kk])
        new_seed_vertex.append(int(np.sum(kk[: traced.seed_vertex[k]])))
    counts = np.array([len(c) for c in new_lines])
    ok = counts >= 2
    return Traced(
        lines=Lines.from_list([c for c, o in zip(new_lines, ok, strict=True) if o]),
        seed=traced.seed[ok],
        seed_vertex=np.asarray(new_seed_vertex, dtype=np.int64)[ok],
        end_start=end_s[ok],
        end_finish=end_f[ok],
    )
