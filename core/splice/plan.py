"""Plan a new infill block: print order, printed links, and per-segment width, E and feedrate.

Input: the paths an engine made for one replaced block (:class:`loadpath.toolpath.Path`, with the
local pitch at each vertex), the block's layer height and feedrate, the slicer's flow model.
Output: :class:`BlockPlan`, a list of **chains** (polylines printed without travel), each segment with
its bead width, filament and feedrate.  :mod:`loadpath.splice` writes it.

Steps
-----
1. Simplify each path within ``resolution`` (position) and ``pitch_resolution`` (local pitch), and
   drop vertices closer than ``min_segment`` to the previous one (G-code prints 3 decimals; a
   segment must carry a visible amount of E).
2. Order the paths greedily: from the current nozzle position, the nearest free path end next,
   reversing the path when its far end is nearer (what slicers do for infill); then 2-opt and,
   on orders of up to :data:`MAX_OR_OPT` paths, Or-opt moves shorten the travel further
   (:func:`order_paths`).  The first path starts where the nozzle is (the seam follows the
   previous block or layer).
3. Join consecutive paths into one chain with a printed **link** when the gap is at most
   ``link_max``, the straight link lies inside the replace region and crosses no other path
   (PrusaSlicer links its rectilinear lines the same way); otherwise the splicer travels.
4. Flow width per segment: the mean local pitch of its two vertices (variable width, solid infill),
   or a fixed flow width (sparse infill keeps the slicer's width).  Bead width from the flow model,
   clamped to ``width_range`` times the nozzle diameter (variable widths only: a fixed flow width is
   the slicer's own choice, e.g. Cura's combined sparse infill printed at double flow).
   Volume policy, with a target E (the replaced block's own): the engine's widths are kept when
   the block's filament lies within ``[1 - volume_floor, 1 + volume_cap]`` times the target;
   otherwise, when there is too much, the printed links give it back first (a link lies over
   the two path ends it joins, so thinning it, down to the narrowest bead, loses no coverage),
   and only then, or when there is too little, the flow widths are scaled by the one factor
   (bounded by ``max_correction``) that brings it to the nearer end of that band.  The cap
   protects the print (never much more plastic than the slicer planned); the floor keeps the
   block within the splicer's and the check's tolerance (3 %). Matching the slicer's volume
   exactly, as before, spread the engine's missing material uniformly over the bulk, where the
   beads already tile and it adds nothing, while the voids that caused the shortfall stayed voids:
   on the bench's L-bracket that cost more than the whole alignment gain
   (``benchmarks/bench_stiffness.py``). Where a gap needs a wider bead, the
   engine's local pitch already says so.  The band is empty by default (exact matching, as
   before) until the rewriter handles blocks that extrude other than the slicer's E in Cura's
   files (with a 2 % band, ``tests/splice/test_splice.py`` fails on cura-relE and
   cura-two-objects: retraction and logical E after the block); the engines now lay within a few
   per cent of the slicer's volume themselves (path ends carried on, regions grown by the
   slicer's own overlap), so the uniform correction stays small.
5. Feedrate: the block's own, lowered per segment where the volumetric rate
   ``area * multiplier * v`` would exceed ``max_volumetric_speed``.

(Over 400 lines: :func:`plan_block` with the simplification and ordering only it uses, and the
records it returns.)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import shapely
from loadpath._typing import Floats, Ints, Points2, Region
from loadpath.splice.compiled import kernel
from loadpath.splice.flow import FlowModel
from loadpath.toolpath import Path
from shapely.geometry import LineString

FEED_STEP = 120.0
"""Feedrates lowered for the volumetric limit are multiples of this, mm/min (2 mm/s)."""

__all__ = ["PlanOptions", "Chain", "BlockPlan", "plan_block", "simplify", "simplify_mask", "order_paths"]


@dataclass(frozen=True)
class PlanOptions:
    """How new paths become G-code moves.

    Attributes
    ----------
    nozzle_diameter : float, mm
    width_range : (2,) float
        Smallest and largest bead width, as multiples of the nozzle diameter.
    link_max : float
        Longest printed link between neighbouring path ends, in nominal pitches.
    min_segment : float, mm
        Vertices closer than this to the previous one are dropped.
    resolution : float, mm
        Largest distance of a dropped vertex from the simplified path in this first, fine pass
        (position and pitch); the splicer's final pass (:mod:`loadpath.splice.beadruns`) bounds the
        total at ``RunOptions.resolution`` times the flow width.
    pitch_resolution : float, mm
        Largest change of a dropped vertex's pitch against the simplified segment's.
    max_volumetric_speed : float, mm^3/s
        0: no limit.
    match_volume : bool
        Apply the volume policy (module docstring, step 4) against the replaced block's volume.
    volume_cap, volume_floor : float
        The band of filament, relative to the replaced block's, inside which the engine's widths
        are kept as they are (0, 0: match exactly).
    max_correction : float
        Largest relative change of the flow that the volume policy may apply.
    order : bool
        Reorder the paths (False: print them as given, each in its own direction).
    free_travel : float, mm
        Travels shorter than this cost no retraction (PrusaSlicer's ``retract_before_travel``:
        ``GCode::needs_retraction`` in ``src/libslic3r/GCode.cpp`` skips the retraction of a travel
        shorter than it); the order prefers them (:func:`order_paths`).  0: every travel costs its
        length only.  The splicer sets it from the file's retraction settings.
    retract_cost : float, mm
        What a retracted travel costs beyond its length, in mm of travel, in the order.  Measured on
        the bench's beam (PrusaSlicer MK3S settings, ``benchmarks/bench_printability.py``): a
        retraction with its wipe, lift and prime takes about 0.2 s beyond its travel, the time of a
        10 mm travel at 1000 mm/s^2.
    """

    nozzle_diameter: float = 0.4
    width_range: tuple[float, float] = (0.6, 1.6)
    link_max: float = 2.0
    min_segment: float = 0.05
    resolution: float = 0.005
    pitch_resolution: float = 0.025
    max_volumetric_speed: float = 0.0
    match_volume: bool = True
    volume_cap: float = 0.0
    volume_floor: float = 0.0
    max_correction: float = 0.15
    order: bool = True
    free_travel: float = 0.0
    retract_cost: float = 10.0


@dataclass(frozen=True)
class Chain:
    """A polyline printed in one go.

    Attributes
    ----------
    points : (n, 2) float, mm
    filament : (n - 1,) float, mm
        Filament pushed on each segment.
    width : (n - 1,) float, mm
        Bead width of each segment (``;WIDTH:``).
    feedrate : (n - 1,) float, mm/min
    """

    points: Points2
    filament: Floats
    width: Floats
    feedrate: Floats

    @cached_property
    def segments(self) -> Floats:
        """Length of each segment, ``(n - 1,)`` mm (once: the length and the rewrite both need them)."""
        return np.hypot(*(self.points[1:] - self.points[:-1]).T)

    @cached_property
    def length(self) -> float:
        """Printed length, mm (once: the rewrite and the block's report both ask)."""
        return float(np.sum(self.segments))


@dataclass(frozen=True)
class BlockPlan:
    """The planned block.

    Attributes
    ----------
    chains : tuple of Chain
        In print order.
    n_paths, n_links : int
        Paths printed and printed links between them.
    correction : float
        Flow factor applied by volume matching (1.0 when off).
    raw_filament : float, mm
        Filament the flow model gives before volume matching.
    stats : dict
    """

    chains: tuple[Chain, ...]
    n_paths: int
    n_links: int
    correction: float
    raw_filament: float
    stats: dict = field(default_factory=dict)

    @property
    def filament(self) -> float:
        """Filament extruded by the block, mm."""
        return float(sum(c.filament.sum() for c in self.chains))

    @property
    def length(self) -> float:
        """Printed length, mm."""
        return float(sum(c.length for c in self.chains))


def simplify_mask(
    points: Points2,
    pitch: Floats,
    sizes: Ints,
    tol: float,
    pitch_tol: float = 0.01,
    min_segment: float = 0.05,
) -> np.ndarray:
    """Return the vertices :func:`simplify` keeps, for paths given as one ragged array.

    Parameters
    ----------
    points : (N, 2) float, mm
        The vertices of every path, one path after the other.
    pitch : (N,) float, mm
    sizes : (P,) int
        Vertices per path (each >= 1); they sum to N.
    tol, pitch_tol, min_segment : float, mm
        As for :func:`simplify`.

    Returns
    -------
    (N,) bool
        Kept vertices (every path's first and last among them).
    """
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    pit = np.asarray(pitch, dtype=float)
    sizes = np.asarray(sizes, dtype=np.int64)
    keep = np.zeros(len(pts), dtype=bool)
    if not len(sizes):
        return keep
    ends = np.cumsum(sizes)
    starts = ends - sizes
    keep[starts] = keep[ends - 1] = True
    px, py = pts[:, 0].copy(), pts[:, 1].copy()
    compiled = kernel("rdp")  # a large splice loaded it (loadpath.splice.compiled): the same vertices
    if compiled is not None:
        compiled(px, py, pit, starts, ends, tol, pitch_tol, keep)
    else:
        _rdp_levels(keep, px, py, pit, starts, ends, tol, pitch_tol)
    if min_segment > 0:
        # then kept vertices closer than min_segment to the previous kept one go, and the one before
        # a path's last vertex when it is that close to it (paths of more than two kept vertices)
        kv = np.flatnonzero(keep)
        path = np.searchsorted(ends, kv, side="right")
        count = np.bincount(path, minlength=len(sizes))[path]
        head = np.ones(len(kv), dtype=bool)
        head[1:] = path[1:] != path[:-1]
        tail = np.ones(len(kv), dtype=bool)
        tail[:-1] = head[1:]
        gap = np.zeros(len(kv))
        gap[1:] = np.hypot(*np.diff(pts[kv], axis=0).T)  # from the previous kept vertex
        drop = ~head & ~tail & (gap < min_segment)
        before_tail = np.flatnonzero(tail & ~head)
        before_tail = before_tail[gap[before_tail] < min_segment] - 1
        drop[before_tail] = True
        drop &= (count > 2) & ~head & ~tail
        keep[kv[drop]] = False
    return keep


def _rdp_levels(keep, px, py, pit, starts, ends, tol: float, pitch_tol: float) -> None:
    """Ramer-Douglas-Peucker, one numpy pass per recursion level over the inner vertices of every
    segment still being split (segments [a, z], vertex indices into the ragged array); the kept
    vertices are marked in ``keep``."""
    a, z = starts, ends - 1
    while len(a):
        inner = z - a - 1
        a, z, inner = a[inner > 0], z[inner > 0], inner[inner > 0]
        if not len(a):
            break
        first = np.cumsum(inner) - inner  # each segment's first row below
        seg_id = np.repeat(np.arange(len(a)), inner)
        idx = np.arange(int(inner.sum())) + np.repeat(a + 1 - first, inner)
        # per segment: chord (dx, dy), its squared length; per inner vertex: offset from the start
        dx, dy = px[z] - px[a], py[z] - py[a]
        seg2 = dx * dx + dy * dy
        seg = np.sqrt(seg2)
        wa, dw = pit[a], pit[z] - pit[a]
        rx, ry = px[idx] - px[a][seg_id], py[idx] - py[a][seg_id]
        if np.all(seg > 0):  # the usual case: no chord of zero length (the same figures, fewer passes)
            dx, dy, seg2, seg = dx[seg_id], dy[seg_id], seg2[seg_id], seg[seg_id]
            dist = np.abs(rx * dy - ry * dx) / seg
            t = np.clip((rx * dx + ry * dy) / seg2, 0, 1)
        else:
            dx, dy, seg2, seg = dx[seg_id], dy[seg_id], seg2[seg_id], seg[seg_id]
            safe = np.where(seg > 0, seg, 1.0)
            dist = np.where(seg > 0, np.abs(rx * dy - ry * dx) / safe, np.hypot(rx, ry))
            t = np.where(seg2 > 0, np.clip((rx * dx + ry * dy) / np.where(seg2 > 0, seg2, 1.0), 0, 1), 0.0)
        err = np.maximum(dist / tol, np.abs(pit[idx] - (wa[seg_id] + t * dw[seg_id])) / pitch_tol)
        # worst vertex of each segment: its largest error (NaN ignored), the first one on a tie
        worst_err = np.fmax.reduceat(err, first)
        split = worst_err > 1.0
        rows = np.where(err == worst_err[seg_id], np.arange(len(err)), len(err))
        worst = np.minimum.reduceat(rows, first)[split]
        m = idx[worst]
        keep[m] = True
        a, z = np.concatenate([a[split], m]), np.concatenate([m, z[split]])


def simplify(
    paths: Sequence[tuple[Points2, Floats]], tol: float, pitch_tol: float = 0.01, min_segment: float = 0.05
) -> list[tuple[Points2, Floats]]:
    """Fewer vertices, same paths: Ramer-Douglas-Peucker on position and pitch together.

    A vertex is dropped when the simplified polyline passes within ``tol`` mm of it and the pitch
    interpolated along the simplified segment is within ``pitch_tol`` mm of its own (so the bead width
    is kept too).  Then vertices closer than ``min_segment`` to the previous kept one go (ends kept).
    All paths are simplified together (:func:`simplify_mask`): each recursion level is one numpy pass
    over the vertices of every segment still being split, and the ``min_segment`` pass one over all
    kept vertices.

    Parameters
    ----------
    paths : sequence of (points (n, 2) mm, pitch (n,) mm)
    tol : float, mm
        PrusaSlicer's ``gcode_resolution`` is 0.0125 mm.
    pitch_tol : float, mm
    min_segment : float, mm

    Returns
    -------
    list of (points (m, 2), pitch (m,))
        Each path's kept vertices (views into one array per call).
    """
    if not paths:
        return []
    sizes = np.array([len(p) for p, _ in paths])
    pts = np.concatenate([np.asarray(p, dtype=float).reshape(-1, 2) for p, _ in paths])
    pit = np.concatenate([np.asarray(w, dtype=float) for _, w in paths])
    keep = simplify_mask(pts, pit, sizes, tol, pitch_tol, min_segment)
    kept = np.bincount(np.repeat(np.arange(len(sizes)), sizes)[keep], minlength=len(sizes))
    bounds = np.cumsum(kept)[:-1]
    return list(zip(np.split(pts[keep], bounds), np.split(pit[keep], bounds), strict=True))


def order_paths(
    paths: Sequence[tuple[Points2, Floats]],
    start: Points2,
    passes: int = 4,
    max_2opt: int = 300,
    free_travel: float = 0.0,
    retract_cost: float = 0.0,
    end: Points2 | None = None,
) -> list[tuple[Points2, Floats]]:
    """Print order from ``start``: greedy nearest neighbour, then 2-opt and Or-opt (paths reversed where
    nearer).

    The greedy order takes the cheapest free path end next (what slicers do for infill); 2-opt then
    reverses any stretch of the order (each path in it turned round) that lowers the cost of the
    travels ``end(k - 1) -> start(k)`` summed, the first travel from the nozzle included, for up to
    ``passes`` passes (orders of more than ``max_2opt`` paths keep the greedy one).  On orders of up
    to :data:`MAX_OR_OPT` paths, :func:`_or_opt` then moves stretches of up to three paths elsewhere,
    and 2-opt runs again after each pass that moved one.  A travel costs its length, plus
    ``retract_cost`` when it is ``free_travel`` or longer (the slicer retracts it).  With ``end``,
    the travel from the last path to it counts too (where the nozzle goes after the block).

    Parameters
    ----------
    paths : sequence of (points (n, 2), pitch (n,))
    start : (2,) float, mm
        Nozzle position before the first path.
    free_travel, retract_cost : float, mm
        See :class:`PlanOptions` (0: the cost is the length).
    end : (2,) float, mm, optional
        Where the nozzle goes after the last path (the slicer's next extrusion).
    """
    m = len(paths)
    if m == 0:
        return []
    heads = np.array([p[0][0] for p in paths])
    tails = np.array([p[0][-1] for p in paths])
    key = (heads.tobytes(), tails.tobytes(), np.asarray(start, dtype=float).tobytes())
    key += (None if end is None else np.asarray(end, dtype=float).tobytes(),)
    key += (passes, max_2opt, float(free_travel), float(retract_cost))
    seq = _ORDERS.get(key)
    if seq is None:
        seq = _order(heads, tails, start, passes, max_2opt, free_travel, retract_cost, end)
        if len(_ORDERS) >= _ORDERS_KEPT:
            _ORDERS.pop(next(iter(_ORDERS)))
        _ORDERS[key] = seq
    out = []
    for k, rev in seq:
        pts, pitch = paths[k]
        out.append((pts[::-1], pitch[::-1]) if rev else (pts, pitch))
    return out


_ORDERS: dict[tuple, list[tuple[int, bool]]] = {}
"""The last orders :func:`order_paths` made, under the path ends, the start and the options they were
made from (all the order reads): a staggered run of identical layers prints the same runs from the
same place every other layer, and its 2-opt was a fifth of the 1000-layer specimen's splice."""
_ORDERS_KEPT = 16


def _order(
    heads: Points2,
    tails: Points2,
    start: Points2,
    passes: int,
    max_2opt: int,
    free_travel: float,
    retract_cost: float,
    end: Points2 | None = None,
) -> list[tuple[int, bool]]:
    """Make the order of :func:`order_paths` from the path ends: ``(path index, reversed)`` per path.

    Orders the 2-opt takes (``max_2opt`` paths or fewer) read every travel's cost from one table of
    all the ends (:func:`_cost_table`, which the 2-opt reads too): the greedy steps' costs are its
    rows, the figures each step measured before (issue 17: the steps' distances and costs were most
    of the order's time).  Longer ones, and ends that are not finite, keep the step-by-step order.
    """
    m = len(heads)
    cost = _travel_cost(free_travel, retract_cost)
    table = None
    if m <= max_2opt:
        table = _cost_table(heads, tails, np.asarray(start, dtype=float), cost, end)
        if not np.all(np.isfinite(table)):  # argmin and the step's comparison treat NaN apart
            table = None
    seq = _greedy(heads, tails, start, cost) if table is None else _greedy_from_table(table, m)
    if 2 < m <= max_2opt:
        seq = _two_opt(seq, heads, tails, np.asarray(start, dtype=float), passes, cost, table)
    # with an end, even one or two paths may be better the other way round (Or-opt turns them)
    if (2 < m or end is not None) and m <= MAX_OR_OPT and table is not None:
        for _ in range(passes):  # a move's gain opens 2-opt moves and back, each pass after a gain
            moved = _or_opt(seq, table, passes)
            if moved == seq:
                break
            seq = _two_opt(moved, heads, tails, np.asarray(start, dtype=float), passes, cost, table)
    return seq


MAX_OR_OPT = 24
"""Longest order (paths) :func:`_or_opt` is run on.  The orders it helps most are the few long runs
of a linked block (issue 19, ``benchmarks/bench_printability.py``: the cantilever's 6 and 10 runs
a layer, whose 2-opt orders travelled 83.6 and 67.7 mm where no order of them travels less than
71.4 and 65.6 mm; with the moves, those figures).  Its passes are a Python loop over the stretches
with numpy steps over the places: on random ends, 2.5 ms an order of 6 paths, 4.7 ms of 10, 12.8 ms
of 20 and 21 ms of 40 (2-opt alone 0.4-3.6 ms); the 1000-layer specimen's blocks of about 47 paths,
each with a start of its own, keep the 2-opt order."""

OR_SEGMENT = 3
"""Longest stretch of consecutive paths :func:`_or_opt` moves elsewhere in the order."""


def _or_opt(seq: list[tuple[int, bool]], table: np.ndarray, passes: int) -> list[tuple[int, bool]]:
    """Or-opt on an open tour of oriented paths from a fixed start: move stretches of up to
    :data:`OR_SEGMENT` consecutive paths to another place in the order, turned round or not.

    2-opt only reverses stretches in place, so a long path that the greedy order took early (the
    nearest end from the nozzle) and that would cost less travel printed last stays early: the
    move it needs is a relocation.  For each stretch the best place is found at once over every
    place in the rest of the order, from the same cost table (:func:`_cost_table`, ``(2m + 2,
    2m + 2)``; heads ``0..m-1``, tails ``m..2m-1``, the start ``2m``, the end ``2m + 1``).  Moves
    are taken while they lower the cost by more than 1e-6, for up to ``passes`` passes.

    Returns
    -------
    list of (path index, reversed)
        The new order (``seq`` itself when no move helped).
    """
    m = len(seq)
    c = table
    none = 2 * m + 1  # after the last path: the end, or nothing (cost 0)
    idx = np.array([k for k, _ in seq])
    rev = np.array([r for _, r in seq])
    s_id = np.where(rev, idx + m, idx)  # the end each path starts from
    e_id = np.where(rev, idx, idx + m)  # and the one it ends at
    improved_any = False
    for _ in range(passes):
        improved = False
        for length in range(1, min(OR_SEGMENT, m) + 1):
            i = 0
            while i + length <= m:
                prev = 2 * m if i == 0 else e_id[i - 1]
                nxt = s_id[i + length] if i + length < m else none
                a, z = s_id[i], e_id[i + length - 1]  # the stretch's first and last end
                freed = c[prev, a] + c[z, nxt] - c[prev, nxt]
                rest_s = np.concatenate([s_id[:i], s_id[i + length :]])
                rest_e = np.concatenate([e_id[:i], e_id[i + length :]])
                before = np.concatenate([[2 * m], rest_e])
                after = np.concatenate([rest_s, [none]])
                bridge = c[before, after]
                forward = c[before, a] + c[z, after] - bridge
                turned = c[before, z] + c[a, after] - bridge  # the stretch reversed: it starts at z
                fwd, trn = int(np.argmin(forward)), int(np.argmin(turned))
                flip = turned[trn] < forward[fwd]
                at, cost = (trn, turned[trn]) if flip else (fwd, forward[fwd])
                if freed - cost > 1e-6:
                    seg_s, seg_e = s_id[i : i + length], e_id[i : i + length]
                    if flip:  # each path turned round: its start is its old end
                        seg_s, seg_e = seg_e[::-1], seg_s[::-1]
                    s_id = np.concatenate([rest_s[:at], seg_s, rest_s[at:]])
                    e_id = np.concatenate([rest_e[:at], seg_e, rest_e[at:]])
                    improved = improved_any = True
                i += 1
        if not improved:
            break
    if not improved_any:
        return seq
    return [(int(a), False) if a < m else (int(a - m), True) for a in s_id]


def _greedy(heads: Points2, tails: Points2, start: Points2, cost) -> list[tuple[int, bool]]:
    """The greedy order of :func:`order_paths`, step by step: the cheapest free end from where the
    nozzle is (a head on a tie)."""
    m = len(heads)
    free = np.ones(m, dtype=bool)
    pos = np.asarray(start, dtype=float)
    seq: list[tuple[int, bool]] = []
    for _ in range(m):
        dh = np.where(free, cost(np.hypot(*(heads - pos).T)), np.inf)
        dt = np.where(free, cost(np.hypot(*(tails - pos).T)), np.inf)
        ih, it = int(np.argmin(dh)), int(np.argmin(dt))
        if dh[ih] <= dt[it]:
            k, rev = ih, False
        else:
            k, rev = it, True
        free[k] = False
        seq.append((k, rev))
        pos = heads[k] if rev else tails[k]
    return seq


def _greedy_from_table(table: np.ndarray, m: int) -> list[tuple[int, bool]]:
    """:func:`_greedy` from the :func:`_cost_table` of its ends (finite): the same order.

    Row ``p`` of the table holds the costs from end ``p`` to every head (columns ``0..m-1``) and
    tail (``m..2m-1``), the figures :func:`_greedy` computes from that end; the first smallest of a
    row's free entries is the cheapest head, or the cheapest tail when it is strictly cheaper.
    """
    free = np.ones(2 * m, dtype=bool)
    pos = 2 * m  # the start
    seq: list[tuple[int, bool]] = []
    for _ in range(m):
        j = int(np.argmin(np.where(free, table[pos, : 2 * m], np.inf)))
        k, rev = (j, False) if j < m else (j - m, True)
        free[k] = free[k + m] = False
        seq.append((k, rev))
        pos = k if rev else k + m  # a reversed path ends at its head
    return seq


def _cost_table(
    heads: Points2, tails: Points2, start: Points2, cost, end: Points2 | None = None
) -> np.ndarray:
    """Every travel's cost between the ends ``(2m + 2, 2m + 2)``: heads ``0..m-1``, tails ``m..2m-1``,
    the start ``2m``, the end ``2m + 1``; ``c[a, b] = cost(hypot(p[a] - p[b]))``, symmetric
    (``p[a] - p[b]`` is exactly ``-(p[b] - p[a])``).  Without an end its row and column are 0: the
    order may finish anywhere."""
    p = np.concatenate([heads, tails, np.asarray(start, dtype=float)[None]])
    if end is not None:
        p = np.concatenate([p, np.asarray(end, dtype=float)[None]])
    c = cost(np.hypot(p[:, None, 0] - p[None, :, 0], p[:, None, 1] - p[None, :, 1]))
    return c if end is not None else np.pad(c, ((0, 1), (0, 1)))


def _travel_cost(free_travel: float, retract_cost: float):
    """``cost(d)`` of travels of lengths ``d`` (:func:`order_paths`), vectorized."""
    if free_travel <= 0 or retract_cost <= 0:
        return lambda d: d
    return lambda d: d + retract_cost * (d >= free_travel)  # d: numpy array or scalar (np.hypot's)


def _order_by_island(
    paths: list[tuple[Points2, Floats]],
    start: Points2,
    region: Region | None,
    end: Points2 | None = None,
    **kw: float,
) -> list[tuple[Points2, Floats]]:
    """:func:`order_paths` island by island: all of one island's paths before the next island's.

    Travel between islands leaves the region and retracts; an order that hops between them (2-opt
    weighs only distance) costs a retraction per hop where the slicer pays one per island.  The
    next island is the one with the path end nearest to where the nozzle is; ``end`` (where the
    nozzle goes after the block) is weighed in the last island's order.
    """
    parts = list(getattr(region, "geoms", [])) if region is not None else []
    if len(parts) < 2 or len(paths) < 2:
        return order_paths(paths, start, end=end, **kw)
    mids = shapely.points(np.array([p[len(p) // 2] for p, _ in paths]))
    island = np.argmin(np.stack([shapely.distance(g, mids) for g in parts], axis=1), axis=1)
    groups = {int(k): [paths[i] for i in np.flatnonzero(island == k)] for k in np.unique(island)}
    out: list[tuple[Points2, Floats]] = []
    pos = np.asarray(start, dtype=float)
    while groups:
        near = {
            k: min(min(np.hypot(*(p[0] - pos)), np.hypot(*(p[-1] - pos))) for p, _ in g)
            for k, g in groups.items()
        }
        k = min(near, key=near.__getitem__)
        out += order_paths(groups.pop(k), pos, end=None if groups else end, **kw)
        pos = out[-1][0][-1]
    return out


def _two_opt(
    seq: list[tuple[int, bool]],
    heads: Points2,
    tails: Points2,
    start: Points2,
    passes: int,
    cost=None,
    table: np.ndarray | None = None,
) -> list[tuple[int, bool]]:
    """2-opt on an open tour of oriented paths from a fixed start (see :func:`order_paths`).

    Each step tries every reversal ``[i, j]`` for one ``i`` at once.  Where each path starts and ends
    (``s_id``, ``e_id``: rows of a table of the ``2m + 2`` ends' travel costs, made once) and the cost
    of the travel after each one (``link``, ``(m - 1,)``) are kept between steps and changed only where
    a reversal changed them: the same figures as when they were rebuilt at every step, without the
    ``O(m)`` rebuild (issue 17: the 2-opt was a third of the plan's time on the 100-layer specimen),
    and looked up instead of measured again (a step's distances and costs were most of its calls).
    """
    cost = cost or (lambda d: d)
    idx = np.array([k for k, _ in seq])
    rev = np.array([r for _, r in seq])
    m = len(idx)
    # every travel's cost from a table of all the ends (heads 0..m-1, tails m..2m-1, the start 2m,
    # the end 2m + 1):
    # c[a, b] = cost(hypot(p[a] - p[b])), the figures the steps computed from the points before
    # (symmetric: p[a] - p[b] is exactly -(p[b] - p[a]))
    c = _cost_table(heads, tails, start, cost) if table is None else table
    last = 2 * m + 1  # where the nozzle goes after the last path (cost 0 when nowhere in particular)
    s_id = np.where(rev, idx + m, idx)  # the end each path starts from
    e_id = np.where(rev, idx, idx + m)  # and the one it ends at
    link = np.append(c[s_id[1:], e_id[:-1]], c[e_id[-1], last])  # travel after each path
    for _ in range(passes):
        improved = False
        for i in range(m - 1):
            # reversing [i, j] for every j > i: the travel into i and the one after j change
            before = c[2 * m if i == 0 else e_id[i - 1]]
            old = before[s_id[i]] + link[i + 1 :]
            new = before[e_id[i + 1 :]]
            new[:-1] += c[s_id[i], s_id[i + 2 :]]
            new[-1] += c[s_id[i], last]
            gain = old - new
            best = int(np.argmax(gain))
            if gain[best] > 1e-6:
                jj = i + 1 + best
                idx[i : jj + 1] = idx[i : jj + 1][::-1]
                rev[i : jj + 1] = ~rev[i : jj + 1][::-1]
                turned = e_id[i : jj + 1][::-1].copy(), s_id[i : jj + 1][::-1].copy()
                s_id[i : jj + 1], e_id[i : jj + 1] = turned
                lo, hi = max(i - 1, 0), min(jj + 1, m - 1)  # the travels that changed
                link[lo:hi] = c[s_id[lo + 1 : hi + 1], e_id[lo:hi]]
                link[-1] = c[e_id[-1], last]
                improved = True
        if not improved:
            break
    return [(int(k), bool(r)) for k, r in zip(idx, rev, strict=True)]


def _segment_values(v: Floats) -> Floats:
    return 0.5 * (v[:-1] + v[1:])


def plan_block(
    paths: Sequence[Path],
    start: Points2,
    height: float,
    feedrate: float,
    flow: FlowModel,
    options: PlanOptions,
    region: Region | None = None,
    nominal_pitch: float | None = None,
    flow_width: float | None = None,
    target_filament: float | None = None,
    simplified: bool = False,
    end: Points2 | None = None,
) -> BlockPlan:
    """Plan one replaced block (see the module docstring).

    Parameters
    ----------
    paths : sequence of Path
    start : (2,) float, mm
        Nozzle position before the block.
    height : float, mm
        Bead height (the block's layer height).
    feedrate : float, mm/min
        The replaced block's extrusion feedrate (it includes the slicer's cooling slowdown).
    flow : FlowModel
    options : PlanOptions
    region : shapely Polygon or MultiPolygon, optional
        Replace region: links must lie inside it.  None: no links.
    nominal_pitch : float, mm, optional
        Pitch of the links' beads and the unit of ``link_max``; default the median path pitch.
    flow_width : float, mm, optional
        Fixed flow width for every segment (sparse infill); None: each segment's local pitch.
    target_filament : float, mm, optional
        Filament of the replaced block, for volume matching.
    simplified : bool
        The paths were already simplified with these options (:func:`simplify`): skip step 1.
    end : (2,) float, mm, optional
        Where the nozzle goes after the block (the slicer's next extrusion): the order weighs the
        travel there too.

    Returns
    -------
    BlockPlan

    (Over 120 lines: ordering, linking, widths and the volume correction of one block share the
    chain arrays they build.)
    """
    raw = [(p.points, p.pitch) for p in paths]
    if not simplified:
        raw = simplify(raw, options.resolution, options.pitch_resolution, options.min_segment)
    prepared = [(pts, pitch) for pts, pitch in raw if len(pts) >= 2 and np.any(pts[1:] != pts[:-1])]
    if options.order:
        prepared = _order_by_island(
            prepared, start, region, end, free_travel=options.free_travel, retract_cost=options.retract_cost
        )
    if not prepared:
        return BlockPlan((), 0, 0, 1.0, 0.0)
    all_pitch = np.concatenate([pp for _, pp in prepared])
    nominal = float(nominal_pitch) if nominal_pitch else float(np.median(all_pitch))
    link_max = options.link_max * nominal
    inner = None
    if region is not None and options.link_max > 0:
        inner = region.buffer(0.05 * nominal)
        shapely.prepare(inner)

    # chains: consecutive paths joined by printed links.  Path k's link comes from path k - 1's end
    # whatever was linked before, so every candidate is tested at once: near enough, inside the
    # region, crossing no path but the two it joins (one shapely call each, not one per path)
    m = len(prepared)
    linked = np.zeros(m, dtype=bool)
    if inner is not None and m > 1:
        heads = np.array([p[0] for p, _ in prepared])
        tails = np.array([p[-1] for p, _ in prepared])
        cand = 1 + np.flatnonzero(np.hypot(*(heads[1:] - tails[:-1]).T) <= link_max)
        if len(cand):
            segs = shapely.linestrings(np.stack([tails[cand - 1], heads[cand]], axis=1))
            ok = np.asarray(shapely.covers(inner, segs), dtype=bool)
            if m > 2 and ok.any():  # a link never crosses another path
                tree = shapely.STRtree([LineString(p) for p, _ in prepared])
                at = np.flatnonzero(ok)
                seg_i, hit = tree.query(segs[at], predicate="intersects")
                k = cand[at][seg_i]
                ok[at[np.unique(seg_i[(hit != k) & (hit != k - 1)])]] = False
            linked[cand[ok]] = True
    n_links = int(linked.sum())
    groups: list[list[tuple[Points2, Floats]]] = []
    for k, path in enumerate(prepared):
        if linked[k]:
            groups[-1].append(path)
        else:
            groups.append([path])
    chains_pts, chains_fw, chains_link = [], [], []
    for g in groups:
        pts = np.concatenate([p for p, _ in g])
        seg_fw, seg_link = [], []
        for j, (p, pp) in enumerate(g):
            if j > 0:
                seg_fw.append(np.array([nominal if flow_width is None else flow_width]))  # the link
                seg_link.append(np.ones(1, dtype=bool))
            seg_fw.append(_segment_values(pp) if flow_width is None else np.full(len(p) - 1, flow_width))
            seg_link.append(np.zeros(len(p) - 1, dtype=bool))
        chains_pts.append(pts)
        chains_fw.append(np.concatenate(seg_fw))
        chains_link.append(np.concatenate(seg_link))
    # every segment's length in one np.hypot over the chains' points, the steps from one chain's
    # last point to the next one's first left out (the same figures as chain by chain)
    all_pts = np.concatenate(chains_pts)
    step = np.ones(len(all_pts) - 1, dtype=bool)
    step[np.cumsum([len(p) for p in chains_pts[:-1]], dtype=np.int64) - 1] = False
    ln = np.hypot(*(all_pts[1:] - all_pts[:-1]).T)[step]
    fw = np.concatenate(chains_fw)
    link = np.concatenate(chains_link)

    wmin, wmax = (r * options.nozzle_diameter for r in options.width_range)
    if flow_width is not None:  # the slicer's own width (e.g. Cura's combined sparse infill at double flow)
        wmin, wmax = 0.0, float("inf")

    def areas(scale: float, link_scale: float = 1.0) -> tuple[Floats, Floats]:
        bead = np.clip(flow.bead_width(fw * np.where(link, link_scale, scale), height), wmin, wmax)
        return bead, flow.area(bead, height)

    def total(area: Floats) -> float:
        return float(np.sum(flow.filament_mm(flow.e_for_area(area)) * ln))

    bead, area = areas(1.0)
    raw = float(np.sum(flow.filament_mm(flow.e_for_area(area)) * ln))
    scale = 1.0
    t = float(target_filament or 0.0)
    band = (t * (1.0 - options.volume_floor), t * (1.0 + options.volume_cap))
    link_scale = 1.0
    if options.match_volume and t > 0 and raw > 0 and not band[0] <= raw <= band[1]:
        goal = band[0] if raw < band[0] else band[1]
        if raw > goal and np.any(link) and flow_width is None:
            # too much: the links give it back first (a link lies over the two ends it joins;
            # thinning it loses no coverage), down to the narrowest bead
            thin = areas(1.0, 0.0)[1]
            if total(thin) <= goal:
                lo_s, hi_s = 0.0, 1.0
                for _ in range(30):  # bisection on the links' flow
                    mid = 0.5 * (lo_s + hi_s)
                    lo_s, hi_s = (lo_s, mid) if total(areas(1.0, mid)[1]) > goal else (mid, hi_s)
                link_scale = lo_s
            else:
                link_scale = 0.0
            bead, area = areas(1.0, link_scale)
        lo, hi = 1.0 - options.max_correction, 1.0 + options.max_correction
        for _ in range(4):  # clamping makes the total non-linear in the scale: a few fixed-point steps
            got = total(area)
            if abs(got - goal) <= 1e-9 * goal:
                break
            scale = float(np.clip(scale * goal / got, lo, hi)) if got > 0 else scale
            bead, area = areas(scale, link_scale * scale if link_scale < 1.0 else scale)
    filament = flow.filament_mm(flow.e_for_area(area)) * ln
    f = np.full(len(ln), float(feedrate))
    if options.max_volumetric_speed > 0:
        limit = options.max_volumetric_speed * 60.0 / (area * flow.multiplier)
        # lowered in steps of 2 mm/s, so a slowly widening bead does not change F on every segment
        f = np.minimum(f, np.floor(limit / FEED_STEP) * FEED_STEP)
    chains = []
    a = 0
    for pts in chains_pts:
        k = len(pts) - 1
        chains.append(
            Chain(points=pts, filament=filament[a : a + k], width=bead[a : a + k], feedrate=f[a : a + k])
        )
        a += k
    stats = {
        "width_min": float(bead.min()),
        "width_max": float(bead.max()),
        "width_clamped": float(np.mean((bead <= wmin + 1e-9) | (bead >= wmax - 1e-9))),
        "slowed": float(np.mean(f < feedrate)),
    }
    return BlockPlan(tuple(chains), len(prepared), n_links, scale, raw, stats)
