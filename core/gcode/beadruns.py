"""Bead runs: a planned chain cut into stretches of one bead width, each simplified on position only.

The engines give every vertex its own local pitch, so the planned bead width changes a little on
almost every segment; written as is, that is a ``;WIDTH:`` marker every other line and many vertices
kept only for the width.  A nozzle cannot print a width change over a fraction of a millimetre
anyway, so the splicer prints a chain as **runs**:

1. The extrusion per mm is averaged along the chain over ``smooth`` flow widths (the chain's
   filament kept exactly).
2. The chain is simplified on position only (:func:`loadpath.gcode.plan.simplify`, Ramer-Douglas-
   Peucker); the filament between two kept vertices is what the plan put between them, so no
   material moves along the chain.  The tolerance is a fraction of the flow width minus what the
   first pass (position and pitch, ``PlanOptions.resolution``, 0.005 mm) used: the printed path is
   within ``resolution * flow width`` of the engine's (10 %: 0.041 mm at a 0.41 mm pitch, a tenth
   of the nozzle).  The engines' far-field paths wobble by about 0.03 mm over tens of millimetres;
   following that wobble made the file 4x the slicer's for no mechanical gain (shipped example: a
   6 % bound gives 3.1x the slicer's bytes, 10 % 2.4x).
3. Segments are grouped greedily, in print order, into runs while the widths of a run stay within
   ``width_step`` (relative) of each other; segments shorter than ``short`` flow widths (links
   between neighbouring paths, stubs) join the run they fall in whatever their width.
4. Each run is printed at one width: the one whose cross-section over the run's length extrudes
   exactly the run's filament (so every chain, and every path in it, keeps its volume), at the
   slowest feedrate of its segments (the volumetric limit still holds: the run's cross-section is
   at most its widest segment's).  One ``;WIDTH:`` marker per run, and it is the width printed.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from loadpath._typing import Floats, Points2
from loadpath.gcode.flow import FlowModel
from loadpath.gcode.plan import BlockPlan, Chain, simplify

__all__ = ["RunOptions", "bead_runs", "runs_of_widths", "smooth_filament"]


@dataclass(frozen=True)
class RunOptions:
    """How chains are cut into runs of one width.

    Attributes
    ----------
    width_step : float
        Largest relative spread of the planned widths inside one run (0.05: a marker only where the
        width moved by more than 5 %).  0: every width change starts a run (no grouping).
    resolution : float
        Largest total deviation of the printed path from the engine's, as a fraction of the flow width.
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
    """

    width_step: float = 0.05
    resolution: float = 0.10
    smooth: float = 5.0
    shift: float = 0.5
    short: float = 2.0
    min_segment: float = 0.05


def runs_of_widths(width: Floats, length: Floats, step: float, short: float) -> np.ndarray:
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

    Returns
    -------
    (n,) int
        Non-decreasing run index, starting at 0.
    """
    n = len(width)
    run = np.zeros(n, dtype=np.int64)
    if n == 0:
        return run
    # Sequential by nature (each run's band depends on where the previous one ended); one pass of
    # plain floats over the segments of a chain, like the marker pass in Writer.extrude_many.
    w = width.tolist()
    is_short = (length < short).tolist()
    k = 0
    lo = hi = None
    limit = 1.0 + step
    for i in range(n):
        if is_short[i] and lo is not None:
            run[i] = k
            continue
        wi = w[i]
        if lo is None:
            lo = hi = wi
        else:
            nlo, nhi = min(lo, wi), max(hi, wi)
            if nhi <= nlo * limit:
                lo, hi = nlo, nhi
            else:
                k += 1
                lo = hi = wi
        run[i] = k
    return run


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
    ends = None if path_ends is None else np.unique(np.asarray(path_ends, float) @ np.array([1.0, 1j]))
    # 1. stretches between path ends; extrusion per mm smoothed inside each; cumulative filament
    pieces: list[tuple[int, int, int]] = []  # (chain, first vertex, last vertex) of each stretch
    arcs, cums, feeds = [], [], []
    for ci, c in enumerate(plan.chains):
        seg = np.hypot(*np.diff(c.points, axis=0).T)
        cut = np.zeros(len(c.points), dtype=bool)
        if ends is not None:
            cut = np.isin(c.points @ np.array([1.0, 1j]), ends)
        cut[0] = cut[-1] = True
        group = np.cumsum(cut[:-1]) - 1
        fil = smooth_filament(c.filament, seg, options.smooth * flow_width, group)
        arcs.append(np.concatenate([[0.0], np.cumsum(seg)]))
        cums.append(np.concatenate([[0.0], np.cumsum(fil)]))
        feeds.append(c.feedrate)
        at = np.flatnonzero(cut)
        pieces.extend((ci, a, z) for a, z in zip(at[:-1], at[1:], strict=True))
    # 2. simplification of every stretch at once, on position and on the cumulative extrusion
    #    (in mm of nominal bead): a dropped vertex is within tol of the new segment, and the
    #    material between kept vertices moves along the path by at most ``shift`` flow widths
    #    (width ramps keep their vertices)
    rho = sum(float(c[-1]) for c in cums) / max(sum(float(a[-1]) for a in arcs), 1e-12)
    gcum = [c / rho for c in cums]
    gpieces = [(plan.chains[o].points[a : z + 1], gcum[o][a : z + 1]) for o, a, z in pieces]
    shift = options.shift * flow_width
    simple = simplify(gpieces, tol, shift, options.min_segment) if tol > 0 and shift > 0 else gpieces
    owner = np.array([o for o, _, _ in pieces])
    chains, n_runs = [], 0
    for ci, (s, cum, f) in enumerate(zip(arcs, cums, feeds, strict=True)):
        mine = [simple[k] for k in np.flatnonzero(owner == ci)]
        pts = np.concatenate([mine[0][0]] + [p[1:] for p, _ in mine[1:]])
        g_kept = np.concatenate([mine[0][1]] + [q[1:] for _, q in mine[1:]])
        group = np.repeat(np.arange(len(mine)), [len(p) - 1 for p, _ in mine])
        # kept vertices are original ones: find them by their cumulative extrusion (increasing:
        # every planned segment extrudes)
        vi = np.minimum(np.searchsorted(gcum[ci], g_kept), len(s) - 1)
        if not np.array_equal(plan.chains[ci].points[vi], pts):
            raise AssertionError("bead_runs: kept vertices are not the chain's own")  # a bug, not input
        # 3. filament between kept vertices: exactly what the plan put there; feedrate: the
        #    slowest original segment in between
        fil = np.diff(cum[vi])
        feed = np.minimum.reduceat(f, vi[:-1])
        seg = np.hypot(*np.diff(pts, axis=0).T)
        width = _width(fil, seg, flow, height)
        # 4. runs of one width (they may span a path end); inside a run each path's stretch is
        #    printed at its own mean extrusion, the marker says the run's width (within width_step)
        run = runs_of_widths(width, seg, options.width_step, options.short * flow_width)
        key = run * (group.max() + 1) + group  # (run, stretch) pieces, in order
        first = np.concatenate([[0], np.flatnonzero(np.diff(key)) + 1])
        piece = np.cumsum(np.isin(np.arange(len(seg)), first)) - 1
        dens = np.add.reduceat(fil, first) / np.maximum(np.add.reduceat(seg, first), 1e-12)
        rfirst = np.concatenate([[0], np.flatnonzero(np.diff(run)) + 1])
        run_width = _width(np.add.reduceat(fil, rfirst), np.add.reduceat(seg, rfirst), flow, height)
        run_feed = np.minimum.reduceat(feed, rfirst)
        chains.append(Chain(pts, dens[piece] * seg, run_width[run], run_feed[run]))
        n_runs += len(rfirst)
    widths = np.concatenate([c.width for c in chains])
    stats = {**plan.stats, "width_min": float(widths.min()), "width_max": float(widths.max()), "runs": n_runs}
    return dataclasses.replace(plan, chains=tuple(chains), stats=stats)


def _width(filament: Floats, length: Floats, flow: FlowModel, height: float) -> Floats:
    """Bead width that extrudes ``filament`` over ``length`` (mm of filament, mm) at ``height``."""
    area = filament / np.maximum(length, 1e-12) * flow.filament_area / flow.multiplier
    return np.asarray(flow.bead_width(area / height, height), dtype=float)
