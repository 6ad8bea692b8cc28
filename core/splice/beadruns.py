"""Bead runs: a planned chain cut into stretches of one bead width, each simplified on position only.

The engines give every vertex its own local pitch, so the planned bead width changes a little on
almost every segment; written as is, that is a ``;WIDTH:`` marker every other line and many vertices
kept only for the width.  A nozzle cannot print a width change over a fraction of a millimetre
anyway, so the splicer prints a chain as **runs**:

1. The extrusion per mm is averaged along the chain over ``smooth`` flow widths (the chain's
   filament kept exactly).
2. The chain is simplified on position only (:func:`loadpath.splice.plan.simplify`, Ramer-Douglas-
   Peucker); the filament between two kept vertices is what the plan put between them, so no
   material moves along the chain.  The tolerance is a fraction of the flow width minus what the
   first pass (position and pitch, ``PlanOptions.resolution``, 0.005 mm) used: the printed path is
   within ``resolution * flow width`` of the engine's (40 %: 0.18 mm at a 0.45 mm flow width, so
   the engine's centre line stays inside the printed bead; linked runs within
   ``linked_resolution``, 10 %).  The engines' far-field paths wobble
   by about 0.03 mm over tens of millimetres; following that wobble made the file 4x the slicer's
   for no mechanical gain (shipped example: a 6 % bound gives 3.1x the slicer's bytes, 10 % 2.4x).
3. Segments are grouped greedily, in print order, into runs while the widths of a run stay within
   ``width_step`` (relative, 15 %) of each other; segments shorter than ``short`` flow widths (links
   between neighbouring paths, stubs) join the run they fall in whatever their width.
4. Each run is printed at one width: the one whose cross-section over the run's length extrudes
   exactly the run's filament (so every chain, and every path in it, keeps its volume), at the
   slowest feedrate of its segments (the volumetric limit still holds: the run's cross-section is
   at most its widest segment's).  One ``;WIDTH:`` marker per run, and it is the width printed.
5. Since a run prints each of its stretches at one extrusion per mm, the material test of step 2
   held vertices for a placement along the path that step 4 does not keep: the chain is simplified
   again from the plan's vertices, on position only, with the runs' first vertices fixed, and
   steps 3-4 are made again (``RunOptions.refit``; issue 17: 2-3 % fewer moves on the example).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from loadpath._typing import Floats, Points2
from loadpath.splice.compiled import kernel
from loadpath.splice.corridor import corridor_fit
from loadpath.splice.flow import FlowModel
from loadpath.splice.plan import BlockPlan, Chain, simplify_mask

__all__ = ["RunOptions", "bead_runs", "runs_of_widths", "smooth_filament"]


@dataclass(frozen=True)
class RunOptions:
    """How chains are cut into runs of one width.

    Attributes
    ----------
    width_step : float
        Largest relative spread of the planned widths inside one run (0.15: a marker only where the
        width moved by more than 15 %).  0: every width change starts a run (no grouping).
    resolution : float
        Largest total deviation of the printed path from the engine's, as a fraction of the flow width.
    linked_resolution : float
        The same for a block of linked runs (:mod:`loadpath.engines.linking`;
        :attr:`loadpath.splice.BlockFill.linked`).  Issue 19, ``benchmarks/bench_printability.py``,
        PrusaSlicer 100 %, ``loadpath compare`` (4 parts x 2 engines): a linked run's long zig-zag
        lines simplified at 40 % lowered the predicted stiffness in all 8 cases; at 25 % the
        stiffness was back but the failure load lower in 3, at 15 % lower in 1 (the two-island
        part, streamlines, -1.4 %); at 10 % both were higher in all 8 (stiffness +0.4-3.1 %,
        coverage 96.0-97.5 -> 97.0-98.5 %), for files 1.26-1.62x the size at 40 % and print
        times up to 7 % longer (more, shorter segments to accelerate through).
        Why (issue 17, shipped example, streamlines, two blocks' beads buffered by their widths):
        40 % against 10 % loses 94 mm^2 of the 10,160 mm^2 the beads cover, and 88-90 % of the lost
        area lies more than 3 flow widths from any turn of over 45 degrees: not at the hairpins or
        links but along the long, gently curved zig-zag lines, where a chord tens of mm long sags to
        the inside of the curve by up to the bound and its neighbours' chords sag elsewhere, leaving
        slits between neighbouring beads (and more overlap on their other side).
        ``benchmarks/bench_lean.py``, 100 % PrusaSlicer and Cura, 4 parts and the example x 2
        engines: 40 % lowered the stiffness in all 18 cases (-0.24 to -3.0 %), coverage -0.8 to
        -2.0 points, the failure load in 17.  Solid infill only: see ``sparse_resolution``.
    sparse_resolution : float
        The same for a block of linked sparse runs (printed at the slicer's bead width,
        :attr:`loadpath.splice.BlockFill.flow_width`).  Their beads lie one to several bead widths
        apart, so no slit opens between neighbours whatever the chords' sag; what the bound moves
        is each line's direction, by up to ``sqrt(2 s / R)`` at a chord's ends on a curve of radius
        ``R`` for a sag ``s``, and the predicted stiffness with it (as ``s``).
        ``benchmarks/bench_sparse.py --thickness 12 --variants auto`` (40 files, issue 15) against
        10 %: outputs of the rectilinear and grid files 1.51-4.68x -> 1.25-3.49x the input's bytes,
        <= 1.5x on 27 of 40 files (20); stiffness within -0.33..+0.42 % on the 35 files whose
        density choice (:mod:`loadpath.plugin.density_choice`) stayed, the other 5 chose the other
        density (stiffness down to -2.6 %, failure load up to +4.5 % but one -3.3 %); geometric
        means: stiffness 1.6749 -> 1.6716, failure load 2.0941 -> 2.1017; 12 of 40 failure loads
        lower (the largest fall: the shelf at PrusaSlicer gyroid 20 %, 1.441 -> 1.298x); files at >= 1.5x
        stiffness 28 and failure load 34, as before.  At 40 % (the unlinked bound) the outputs were
        1.19-3.10x and the stiffness lower by up to 0.5 % (the twelfth round of
        ``benchmarks/printability_results.md`` measured 40 % too, and kept 10 %).
    corridor : bool
        Simplify with :func:`loadpath.splice.corridor.corridor_fit` (kept vertices move within the
        bound) instead of Ramer-Douglas-Peucker.  ``benchmarks/bench_lean.py`` (18 cases as above)
        at the linked runs' 10 %: 3-9 % fewer ``G1`` lines in the replaced blocks (example 2.47 ->
        2.34x the input's bytes), stiffness -0.26 to +0.15 %, failure load -2.5 to +2.3 %, coverage
        within 0.1 point; at 15 %: 15-31 % fewer (example 2.05x), stiffness lower in all 18 (down to
        -1.15 %).  Off by default: at 10 % the stiffness fell a little in 8 of 18 cases.
    smooth : float
        Length of the window, in flow widths, over which the planned extrusion per mm is averaged
        along a chain before the runs are cut (the engines' local pitch jumps by 20 % between
        vertices 0.4 mm apart where a neighbour path ends; a bead cannot follow that).  0: no smoothing.
    shift : float
        Largest distance, in flow widths, by which simplification may move material along a path
        (a dropped vertex's cumulative extrusion against the straight interpolation between the
        kept ones); width ramps keep their vertices.
    short : float
        Segments shorter than this many flow widths join the current run whatever their width.
    min_segment : float, mm
        Vertices closer than this to the previous kept one are dropped (ends kept).
    refit : bool
        Simplify again on position only, the runs' first vertices fixed (step 5 of
        :func:`bead_runs`; issue 17).

    Notes
    -----
    Defaults (issue 17, output size): the shipped example spliced from the same paths with
    ``width_step, resolution`` = 0.05, 0.10 (before) -> 0.15, 0.40: 2.67 -> 1.65x the slicer's
    bytes, ``;WIDTH:`` markers 5819 -> 1998, and the area the printed beads cover 99.5 % of what it
    was (their union's symmetric difference with the finer beads' 0.7 % of it); 0.20, 0.50 gave
    1.57x and 99.2 %.
    """

    width_step: float = 0.15
    resolution: float = 0.40
    linked_resolution: float = 0.10
    sparse_resolution: float = 0.25
    smooth: float = 5.0
    shift: float = 0.5
    short: float = 2.0
    min_segment: float = 0.05
    corridor: bool = False
    refit: bool = True

    def bound(self, linked: bool, sparse: bool) -> float:
        """The simplification bound of a block, a fraction of its flow width: ``resolution``, or
        for linked runs ``linked_resolution`` (solid infill) or ``sparse_resolution`` (sparse).

        Examples
        --------
        >>> o = RunOptions()
        >>> o.bound(False, False), o.bound(True, False), o.bound(True, True)
        (0.4, 0.1, 0.25)
        """
        if not linked:
            return self.resolution
        return self.sparse_resolution if sparse else self.linked_resolution


def runs_of_widths(
    width: Floats, length: Floats, step: float, short: float, start: np.ndarray | None = None
) -> np.ndarray:
    """Run index of every segment (see the module docstring, step 1).

    Parameters
    ----------
    width : (n,) float, mm
        Planned bead width per segment.
    length : (n,) float, mm
    step : float
        Largest relative spread of the widths in a run.
    short : float, mm
        Segments shorter than this join the current run.
    start : (n,) bool, optional
        Segments that begin a new chain: they always start a run.

    Returns
    -------
    (n,) int
        Non-decreasing run index, starting at 0.
    """
    n = len(width)
    if n == 0:
        return np.zeros(0, dtype=np.int64)
    compiled = kernel("runs")  # a large splice loaded it (loadpath.splice.compiled): the same runs
    if compiled is not None:
        is_first = np.zeros(n, dtype=bool) if start is None else start
        return compiled(np.asarray(width, dtype=float), np.asarray(length) < short, is_first, 1.0 + step)
    # Sequential by nature (each run's band depends on where the previous one ended); one pass of
    # plain floats over the segments of a chain, like the marker pass in Writer.extrude_many
    # (``min``/``max`` spelled as the comparisons they make, the indices kept in a list: a third
    # of the pass's time).
    w = width.tolist()
    is_short = (length < short).tolist()
    first = [False] * n if start is None else start.tolist()
    run = [0] * n
    k = -1
    lo = hi = None
    limit = 1.0 + step
    for i in range(n):
        if first[i]:
            k += 1
            lo = hi = None
        if is_short[i] and lo is not None:
            run[i] = k
            continue
        wi = w[i]
        if lo is None:
            lo = hi = wi
            k = max(k, 0)
        else:
            nlo = wi if wi < lo else lo
            nhi = wi if wi > hi else hi
            if nhi <= nlo * limit:
                lo, hi = nlo, nhi
            else:
                k += 1
                lo = hi = wi
        run[i] = k
    return np.array(run, dtype=np.int64)


def smooth_filament(
    filament: Floats, length: Floats, window: float, group: np.ndarray | None = None
) -> Floats:
    """Average the extrusion per mm over ``window`` mm of the chain: the new filament per segment.

    The window is centred on each segment's midpoint and clipped to the segment's group (a stretch
    between two path ends: no material crosses from one path to another); every group keeps its
    filament exactly.

    Parameters
    ----------
    filament, length : (n,) float, mm
    window : float, mm
    group : (n,) int, optional
        Non-decreasing group index per segment (default: one group).

    Returns
    -------
    (n,) float, mm
    """
    n = len(length)
    if window <= 0 or n < 2:
        return filament
    if group is None:
        group = np.zeros(n, dtype=np.int64)
    s = np.concatenate([[0.0], np.cumsum(length)])
    cum = np.concatenate([[0.0], np.cumsum(filament)])
    first = np.concatenate([[0], np.flatnonzero(np.diff(group)) + 1])
    last = np.concatenate([first[1:], [n]])
    g = np.repeat(np.arange(len(first)), last - first)
    lo, hi = s[first][g], s[last][g]
    mid = 0.5 * (s[:-1] + s[1:])
    a = np.maximum(mid - 0.5 * window, lo)
    b = np.minimum(mid + 0.5 * window, hi)
    dens = (np.interp(b, s, cum) - np.interp(a, s, cum)) / np.maximum(b - a, 1e-12)
    out = dens * length
    got = np.add.reduceat(out, first)
    want = np.add.reduceat(filament, first)
    return out * np.where(got > 0, want / np.where(got > 0, got, 1.0), 1.0)[g]


def bead_runs(
    plan: BlockPlan,
    flow: FlowModel,
    height: float,
    flow_width: float,
    done: float,
    path_ends: Points2 | None = None,
    options: RunOptions = RunOptions(),
) -> BlockPlan:
    """Print ``plan``'s chains simplified, as runs of one width (see the module docstring).

    Parameters
    ----------
    plan : BlockPlan
    flow : FlowModel
    height : float, mm
        Bead height.
    flow_width : float, mm
        The block's nominal flow width (pitch): the unit of ``options.resolution`` and ``short``.
    done : float, mm
        Deviation already used by the first simplification (``PlanOptions.resolution``).
    path_ends : (m, 2) float, mm, optional
        First and last points of the paths the chains were made of: kept as vertices, and no
        material crosses them (each path keeps its own volume; links are their own stretch).
    options : RunOptions

    Returns
    -------
    BlockPlan
        The filament of every path and link unchanged (to rounding), fewer vertices and width changes.
    """
    if not plan.chains or flow_width <= 0:
        return plan
    tol = max(options.resolution * flow_width - done, 0.0)
    shift = options.shift * flow_width
    # every chain's vertices in one array; vertex v of the block, chain of each
    sizes = np.array([len(c.points) for c in plan.chains])
    pts = np.concatenate([c.points for c in plan.chains])
    vstart = np.cumsum(sizes) - sizes  # first vertex of each chain
    vlast = vstart + sizes - 1
    is_first = np.zeros(len(pts), dtype=bool)
    is_first[vstart] = True
    is_last = np.zeros(len(pts), dtype=bool)
    is_last[vlast] = True
    seg_v = np.flatnonzero(~is_last)  # first vertex of each segment
    seg = np.hypot(*(pts[seg_v + 1] - pts[seg_v]).T)
    fil0 = np.concatenate([c.filament for c in plan.chains])
    feed0 = np.concatenate([c.feedrate for c in plan.chains])
    # 1. stretches between path ends (and chain ends); extrusion per mm smoothed inside each
    cut = np.zeros(len(pts), dtype=bool)
    if path_ends is not None:
        ends = np.unique(_as_complex(np.asarray(path_ends, dtype=float)))
        cut = _among(_as_complex(pts), ends)
    cut[vstart] = cut[vlast] = True
    stretch = np.cumsum(cut[seg_v]) - 1  # stretch of each segment (a chain end always cuts)
    fil = smooth_filament(fil0, seg, options.smooth * flow_width, stretch)
    # cumulative extrusion in mm of nominal bead, strictly increasing over the whole block (each
    # chain starts one unit above the previous one's end)
    rho = float(fil.sum() / max(seg.sum(), 1e-12))
    g = np.zeros(len(pts))
    g[seg_v + 1] = fil / rho
    g[vstart] = 1.0
    g = np.cumsum(g)
    # 2. simplification of every stretch, on position and on the cumulative extrusion: a dropped
    #    vertex is within tol of the new segment, and the material between kept vertices moves along
    #    the path by at most ``shift`` (width ramps keep their vertices); one-segment stretches (links)
    #    have nothing to drop
    # sharp turns (more than 90 degrees: a linked run's hairpins) bound the pieces simplified too,
    # though not the stretches (the material is smoothed across them as before): the material test
    # interpolates along the chord, which means nothing across a fold, and a chord spanning hairpins
    # split at the wrong vertices (issue 19: linked runs of the shipped example kept 24,746
    # vertices at 40 % against 17,936 at 10 %; 10,194 unlinked)
    turn = cut.copy()
    mid = np.arange(1, len(pts) - 1)
    mid = mid[~is_first[mid] & ~is_last[mid]]
    if len(mid):
        d1, d2 = pts[mid] - pts[mid - 1], pts[mid + 1] - pts[mid]
        turn[mid[np.sum(d1 * d2, axis=1) < 0.0]] = True
    chain_v = np.repeat(np.arange(len(sizes)), sizes)
    seg_of_v = np.cumsum(~is_last) - ~is_last  # segment index starting at vertex v
    cum = np.concatenate([[0.0], np.cumsum(fil)])  # filament before each segment (block order)
    ctx = (is_first, chain_v, seg_of_v, cum, feed0, stretch, flow, height, flow_width, options)
    keep, pts_k = _simplified(pts, g, turn, is_last, tol, shift, options)
    kv, ka, kb, nfil, nseg, run, rfirst, out_fil, out_w, out_f = _runs(pts_k, keep, *ctx)
    if options.refit and tol > 0 and shift > 0 and len(rfirst) and not options.corridor:
        # 5. again, the run starts fixed and on position only: a run prints its filament at one
        #    density per stretch, so the material test held vertices for a placement along the path
        #    the printed run does not keep (issue 17)
        fixed = turn.copy()
        fixed[ka[rfirst]] = True
        keep2, pts2 = _simplified(pts, g, fixed, is_last, tol, np.inf, options)
        if keep2.sum() < keep.sum():
            keep, pts_k = keep2, pts2
            kv, ka, kb, nfil, nseg, run, rfirst, out_fil, out_w, out_f = _runs(pts_k, keep, *ctx)
    pts = pts_k
    # back into chains
    # (slices of the arrays where np.split cut them: the same views, without its per-piece calls)
    segs = np.concatenate([[0], np.cumsum(np.bincount(chain_v[ka], minlength=len(sizes)))]).tolist()
    verts = np.concatenate([[0], np.cumsum(np.bincount(chain_v[kv], minlength=len(sizes)))]).tolist()
    chains = tuple(
        Chain(pts[kv[v0:v1]], out_fil[a:z], out_w[a:z], out_f[a:z])
        for v0, v1, a, z in zip(verts[:-1], verts[1:], segs[:-1], segs[1:], strict=True)
    )
    stats = {
        **plan.stats,
        "width_min": float(out_w.min()),
        "width_max": float(out_w.max()),
        "runs": len(rfirst),
    }
    return dataclasses.replace(plan, chains=chains, stats=stats)


def _simplified(
    pts: Points2,
    g: Floats,
    fixed: np.ndarray,
    is_last: np.ndarray,
    tol: float,
    shift: float,
    options: RunOptions,
) -> tuple[np.ndarray, Points2]:
    """Step 2 of :func:`bead_runs`: the vertices kept ``(N,) bool`` and where they go ``(N, 2)``, mm.

    Each piece between two ``fixed`` vertices of one chain (``is_last``: chain ends) is simplified
    within ``tol`` (mm) of position and ``shift`` (mm) of the cumulative extrusion ``g``
    (``np.inf``: on position only).
    """
    at = np.flatnonzero(fixed)
    first_v, last_v = at[:-1], at[1:]
    inner = ~is_last[first_v]  # not from one chain's end to the next chain's start
    first_v, last_v = first_v[inner], last_v[inner]
    keep = np.zeros(len(pts), dtype=bool)
    keep[fixed] = True
    long = np.flatnonzero(last_v - first_v > 1)
    if tol <= 0 or shift <= 0:
        keep[:] = True
    elif len(long) and options.corridor:
        lo, hi = first_v[long], last_v[long] + 1
        sizes_p = hi - lo
        rows = np.arange(int(sizes_p.sum())) + np.repeat(lo - (np.cumsum(sizes_p) - sizes_p), sizes_p)
        kept_p, moved_p = corridor_fit(pts[rows], g[rows], sizes_p, tol, shift, options.min_segment)
        keep[rows[kept_p]] = True
        pts = pts.copy()
        pts[rows[kept_p]] = moved_p[kept_p]
    elif len(long):
        # the pieces' vertices one after the other (a piece's last is the next one's first)
        sizes_p = last_v[long] - first_v[long] + 1
        offset = first_v[long] - (np.cumsum(sizes_p) - sizes_p)
        at_p = np.arange(int(sizes_p.sum())) + np.repeat(offset, sizes_p)
        kept = simplify_mask(pts[at_p], g[at_p], sizes_p, tol, shift, options.min_segment)
        keep[np.searchsorted(g, g[at_p[kept]])] = True
    return keep, pts


def _runs(pts, keep, is_first, chain_v, seg_of_v, cum, feed0, stretch, flow, height, flow_width, options):
    """Steps 3-4 of :func:`bead_runs` for the vertices ``keep`` (at ``pts``): the segments between
    kept vertices of one chain, their runs, and what each segment prints.

    Returns ``kv, ka, kb, nfil, nseg, run, rfirst, out_fil, out_w, out_f``: kept vertices; each new
    segment's first and last vertex, filament (mm), length (mm) and run; each run's first segment;
    the filament, width (mm) and feedrate (mm/min) printed on each new segment.
    """
    kv = np.flatnonzero(keep)  # kept vertices, in order; chain ends among them
    # 3. segments between consecutive kept vertices of the same chain: the plan's filament between
    #    them, the slowest original feedrate in between
    same = chain_v[kv[1:]] == chain_v[kv[:-1]]
    ka, kb = kv[:-1][same], kv[1:][same]
    nfil = cum[seg_of_v[kb - 1] + 1] - cum[seg_of_v[ka]]
    nfeed = np.minimum.reduceat(feed0, seg_of_v[ka]) if len(ka) else np.zeros(0)
    # (reduceat groups run to the next start: exactly the original segments of each new segment)
    nseg = np.hypot(*(pts[kb] - pts[ka]).T)
    nstretch = stretch[seg_of_v[ka]]
    nstart = is_first[ka]
    width = _width(nfil, nseg, flow, height)
    # 4. runs of one width (they may span a path end, never a chain end); inside a run each
    #    stretch is printed at its own mean extrusion, the marker says the run's width
    run = runs_of_widths(width, nseg, options.width_step, options.short * flow_width, nstart)
    key = run * (int(nstretch.max()) + 1) + nstretch
    pfirst = np.concatenate([[0], np.flatnonzero(np.diff(key)) + 1])
    at_first = np.zeros(len(nseg), dtype=bool)
    at_first[pfirst] = True
    piece = np.cumsum(at_first) - 1
    dens = np.add.reduceat(nfil, pfirst) / np.maximum(np.add.reduceat(nseg, pfirst), 1e-12)
    rfirst = np.concatenate([[0], np.flatnonzero(np.diff(run)) + 1])
    run_width = _width(np.add.reduceat(nfil, rfirst), np.add.reduceat(nseg, rfirst), flow, height)
    run_feed = np.minimum.reduceat(nfeed, rfirst)
    out_fil, out_w, out_f = dens[piece] * nseg, run_width[run], run_feed[run]
    return kv, ka, kb, nfil, nseg, run, rfirst, out_fil, out_w, out_f


def _as_complex(xy: np.ndarray) -> np.ndarray:
    """Points ``(n, 2)`` as ``x + iy``, ``(n,) complex``: equal where the points are (finite ones).

    (``xy @ [1, 1j]`` gave the same, through a mixed-type matrix product: 5 ms for a block's
    7000 vertices.)
    """
    out = np.empty(len(xy), dtype=complex)
    out.real, out.imag = xy[:, 0], xy[:, 1]
    return out


def _among(values: np.ndarray, table: np.ndarray) -> np.ndarray:
    """``np.isin(values, table)`` for a sorted, unique ``table`` (complex: one point each), by binary
    search (isin sorted the block's ~7000 vertices with its ~90 path ends: 1.4 ms, this 0.1 ms).

    Parameters
    ----------
    values : (n,) complex
    table : (m,) complex
        Sorted (``np.unique``).

    Returns
    -------
    (n,) bool
    """
    if not len(table):
        return np.zeros(len(values), dtype=bool)
    at = np.minimum(np.searchsorted(table, values), len(table) - 1)
    return table[at] == values


def _width(filament: Floats, length: Floats, flow: FlowModel, height: float) -> Floats:
    """Bead width that extrudes ``filament`` over ``length`` (mm of filament, mm) at ``height``."""
    area = filament / np.maximum(length, 1e-12) * flow.filament_area / flow.multiplier
    return np.asarray(flow.bead_width(area / height, height), dtype=float)
