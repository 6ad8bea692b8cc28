"""The swarm engine: paper Algorithm 1, generalised to cover any layer region.

:func:`generate` runs

1. a first swarm from where the load enters (the paper: "where the largest external force is
   applied"): agents one pitch apart on the curve half a pitch inside the region next to
   ``load_entry``, heading into the part;
2. then, while the region is not covered (beads of the nominal pitch leave pieces wide enough for
   a path) and the coverage target is not met, further swarms on each uncovered piece: agents on a
   line across the piece through its deepest point, perpendicular to the local stress, one swarm
   heading each way from that line (their paths are joined at it).  This covers several islands,
   holes, concave outlines, branches the first swarm never reached, areas behind the starting
   line, loads through a hole or no load at all (then the first swarm is simply one of these).

A fill swarm's domain is the uncovered piece: its boundary runs along the beads already laid, so
its boundary agents keep the new paths a pitch from the old ones and its margin keeps them at
least ``(1/2 + margin)`` pitches away.  Everything is deterministic (no random choice).
"""

from __future__ import annotations

import time
from dataclasses import fields

import numpy as np
import shapely
from loadpath._typing import Floats, Ints, Points2, Region
from loadpath.engines.finish.boundary import Domain
from loadpath.engines.swarm.caps import settle_ends
from loadpath.engines.finish.ends import extend_ends
from loadpath.engines.swarm.gaps import gap_fill
from loadpath.engines.swarm.grid import Occupancy
from loadpath.engines.swarm.joins import join_ends
from loadpath.engines.swarm.raster import raster_for
from loadpath.engines.swarm.step import Context, SwarmParams, SwarmState, run
from loadpath.engines.finish.widths import centre_points, local_pitch
from loadpath.errors import SettingsError
from loadpath.field import StressField
from loadpath.toolpath import EngineInput, Path, Toolpaths
from shapely.geometry.base import BaseGeometry

__all__ = ["generate", "SwarmParams"]

_PARAM_NAMES = {f.name for f in fields(SwarmParams)}
_ENGINE_OPTIONS = {
    "coverage_target",
    "max_swarms",
    "fill",
    "fill_min_width",
    "widths",
    "width_cap",
    "extend_ends",
    "end_cap",
    "centre",
    "end_overlap",
    "gaps",
    "phase",
    "settle",
    "join",
    "hairpin",
}


class _Recorder:
    """Points of all paths, with the step at which each was laid (negative for backward swarms)."""

    def __init__(self) -> None:
        self.pts: list[Points2] = []
        self.pid: list[Ints] = []
        self.pitch: list[Floats] = []
        self.k: list[Ints] = []

    def add(self, pts: Points2, pid: Ints, pitch: Floats, k: int) -> None:
        if len(pts):
            self.pts.append(pts)
            self.pid.append(pid)
            self.pitch.append(pitch)
            self.k.append(np.full(len(pts), k, dtype=np.int64))

    def paths(self, min_points: int = 2) -> list[Path]:
        if not self.pts:
            return []
        pts = np.concatenate(self.pts)
        pid = np.concatenate(self.pid)
        pitch = np.concatenate(self.pitch)
        k = np.concatenate(self.k)
        order = np.lexsort((k, pid))
        pts, pid, pitch, k = pts[order], pid[order], pitch[order], k[order]
        # the seed point is recorded by both swarms of a fill pair: keep it once
        dup = np.zeros(len(pid), dtype=bool)
        dup[1:] = (pid[1:] == pid[:-1]) & (k[1:] == k[:-1])
        pts, pid, pitch = pts[~dup], pid[~dup], pitch[~dup]
        cuts = np.flatnonzero(np.diff(pid)) + 1
        out = []
        for p, w in zip(np.split(pts, cuts), np.split(pitch, cuts), strict=True):
            if len(p) >= min_points:
                out.append(Path(points=p, pitch=w))  # negative pitch: uncertain (see step)
        return out

    def lines(self, min_pid: int = 0) -> list[Points2]:
        """Points of the paths whose id is at least ``min_pid`` (all points, ends not joined)."""
        if not self.pts:
            return []
        pts = np.concatenate(self.pts)
        pid = np.concatenate(self.pid)
        k = np.concatenate(self.k)
        sel = pid >= min_pid
        pts, pid, k = pts[sel], pid[sel], k[sel]
        order = np.lexsort((k, pid))
        pts, pid = pts[order], pid[order]
        cuts = np.flatnonzero(np.diff(pid)) + 1
        return [p for p in np.split(pts, cuts) if len(p) >= 2]


def _run(state: SwarmState, ctx: Context, rec: _Recorder, direction: int, max_steps: int) -> None:
    """Advance a swarm until it dies (one compiled call) and record its points."""
    pts, pid, pitch, k = run(state, ctx, max_steps, direction)
    if len(pts):
        rec.pts.append(pts)
        rec.pid.append(pid)
        rec.pitch.append(pitch)
        rec.k.append(k)


def _order_chain(seeds: Points2, head: Points2) -> tuple[Points2, Points2]:
    """Order seeds so consecutive agents step to the right of the heading (Eq. 5)."""
    if len(seeds) > 1:
        right = np.stack([head[:-1, 1], -head[:-1, 0]], axis=1)
        if np.sum(np.sum((seeds[1:] - seeds[:-1]) * right, axis=1)) < 0:
            return seeds[::-1].copy(), head[::-1].copy()
    return seeds, head


def _sample_curve(line: shapely.LineString, pitch: float, phase: float = 0.0) -> Points2:
    """Points one pitch apart along a curve, centred on it and moved on by ``phase`` pitches, (n, 2)."""
    length = line.length
    n = int(np.floor(length / pitch + 1e-9)) + 1
    # one extra candidate at each end: with a phase the first may move into the curve, the last
    # off it (without, both lie outside it)
    s = 0.5 * (length - (n - 1) * pitch) + pitch * (np.arange(-1, n + 1) + phase % 1.0)
    s = np.clip(s[(s >= -1e-9) & (s <= length + 1e-9)], 0.0, length)
    return shapely.get_coordinates(shapely.line_interpolate_point(line, s))


def _load_seeds(
    region: Region, load_entry: BaseGeometry, pitch: float, phase: float = 0.0
) -> list[tuple[Points2, Points2]]:
    """Chains of seeds half a pitch inside the region next to where the load enters."""
    inner = region.buffer(-0.5 * pitch, join_style="mitre")
    if inner.is_empty:
        return []
    curve = inner.boundary
    gap = float(shapely.distance(load_entry, curve))
    near = curve.intersection(load_entry.buffer(gap + 0.25 * pitch))
    near = shapely.line_merge(near) if near.geom_type == "MultiLineString" else near
    chains = []
    for piece in shapely.get_parts(near):
        if piece.geom_type != "LineString" or piece.length < 0.5 * pitch:
            continue
        seeds = _sample_curve(piece, pitch, phase)
        if not len(seeds):
            continue
        foot = shapely.get_coordinates(shapely.shortest_line(shapely.points(seeds), load_entry)).reshape(
            -1, 2, 2
        )[:, 1]
        head = seeds - foot
        norm = np.linalg.norm(head, axis=1)
        head = np.where(norm[:, None] > 1e-9, head / np.maximum(norm, 1e-12)[:, None], np.nan)
        if np.any(~np.isfinite(head)):
            continue
        if chains:
            # pieces of one curve meet end to end (a hole's ring is cut at its first vertex): a
            # seed closer than a pitch to a seed of an earlier piece is dropped
            prev = np.concatenate([c[0] for c in chains])
            d2 = np.min(np.sum((seeds[:, None, :] - prev[None, :, :]) ** 2, axis=2), axis=1)
            keep = d2 >= (0.9 * pitch) ** 2
            seeds, head = seeds[keep], head[keep]
            if not len(seeds):
                continue
        chains.append(_order_chain(seeds, head))
    return chains


def _dominant(field: StressField, pts: Points2) -> Floats | None:
    smp = field.sample(pts)
    if not np.any(smp.valid):
        return None
    d = smp.direction[smp.valid]
    w = np.maximum(smp.mass[smp.valid], 1e-12)
    a = np.arctan2(d[:, 1], d[:, 0])
    th = 0.5 * np.arctan2(np.sum(w * np.sin(2 * a)), np.sum(w * np.cos(2 * a)))
    return np.array([np.cos(th), np.sin(th)])


def _fill_seeds(
    pieces: list[Region], field: StressField, pitch: float, inset: float, phase: float = 0.0
) -> list[tuple[Points2, Points2] | None]:
    """Seeds on a line across each uncovered piece, perpendicular to the stress at its deepest point.

    ``inset`` (mm): seeds keep this far inside the piece (a little more than the domain margin).
    The pieces of one round are done together (one field sample for all their deepest points).
    None for a piece with no room for a seed.
    """
    arr = np.array(pieces, dtype=object)
    cores = shapely.buffer(arr, -inset)
    circles = shapely.maximum_inscribed_circle(arr, 0.05 * pitch)
    centres = shapely.get_coordinates(shapely.get_point(circles, 0))
    smp = field.sample(centres)
    out: list[tuple[Points2, Points2] | None] = []
    for piece, core, c, ok, sd in zip(pieces, cores, centres, smp.valid, smp.direction, strict=True):
        if core.is_empty:
            out.append(None)
            continue
        if ok:
            s = np.asarray(sd, dtype=float)
        else:
            grid = np.asarray(core.representative_point().coords) + pitch * np.stack(
                np.meshgrid(np.arange(-5, 6), np.arange(-5, 6)), -1
            ).reshape(-1, 2)
            dom = _dominant(field, grid)
            s = dom if dom is not None else np.array([1.0, 0.0])
        n = np.array([-s[1], s[0]])
        reach = float(np.hypot(*np.subtract(*np.reshape(piece.bounds, (2, 2))))) + pitch
        line = shapely.LineString([c - reach * n, c + reach * n]).intersection(core)
        parts = [g for g in shapely.get_parts(line) if g.geom_type == "LineString" and g.length > 0]
        if not parts:
            seeds = np.asarray(core.representative_point().coords)
        else:
            best = min(parts, key=lambda g: g.distance(shapely.Point(c)))
            seeds = _sample_curve(best, pitch, phase)
            if not len(seeds):
                seeds = _sample_curve(best, pitch)
        out.append(_order_chain(seeds, np.tile(s, (len(seeds), 1))))
    return out


def _subtract_beads(left: np.ndarray, lines: list[Points2], pitch: float) -> np.ndarray:
    """Subtract beads of the nominal pitch along ``lines`` from the uncovered parts ``left``.

    Parameters
    ----------
    left : (k,) object array of Polygon, mm
    lines : list of (n_i, 2) float, mm
    pitch : float, mm

    Returns
    -------
    (k',) object array of Polygon, mm
        The parts the beads miss, unchanged, then what is left of those they reach.
    """
    if not lines or not len(left):
        return left
    coords = np.concatenate(lines)
    idx = np.repeat(np.arange(len(lines)), [len(x) for x in lines])
    # lines simplified within a fiftieth of a pitch first: the buffer's cost grows with the vertices
    # (a swarm lays one every step), and the pieces left only decide where fill swarms start
    lines = shapely.simplify(shapely.linestrings(coords, indices=idx), 0.02 * pitch, preserve_topology=False)
    beads = shapely.buffer(shapely.multilinestrings(lines), 0.5 * pitch, quad_segs=4)
    # a fill round's paths lie in its pieces: only the parts they reach are cut (the slivers
    # elsewhere, hundreds on a layer, are kept as they are)
    hit = shapely.STRtree(left).query(beads, predicate="intersects")
    keep = np.ones(len(left), dtype=bool)
    keep[hit] = False
    cut = shapely.get_parts(shapely.difference(left[np.sort(hit)], beads))
    cut = cut[(shapely.get_type_id(cut) == 3) & ~shapely.is_empty(cut)]
    return np.concatenate([left[keep], cut])


def _key(parts: np.ndarray) -> list[tuple]:
    """Identify parts by vertex count, area and bounds (a part left uncut keeps all three)."""
    nv = shapely.get_num_coordinates(parts)
    ar = np.round(shapely.area(parts), 12)
    bd = np.round(shapely.bounds(parts), 12)
    return [(int(n), float(a), *map(float, b)) for n, a, b in zip(nv, ar, bd, strict=True)]


def _pieces(left: np.ndarray, min_width: float, known: dict | None = None) -> list[Region]:
    """Pieces of the uncovered area at least ``min_width`` wide (mm), largest first.

    A path in the middle of a gap of width ``w`` between nominal beads is ``(w + pitch) / 2`` from
    the paths on either side, so any gap keeps the half-pitch rule; ``min_width`` only has to leave
    room for a moving agent inside the swarm's margin.  ``known`` keeps the verdicts of earlier
    rounds (parts no round cut are not tested again).
    """
    parts = left
    # a piece wide enough has at least the area of a disc of that width: test only those
    big = parts[(shapely.get_type_id(parts) == 3) & (shapely.area(parts) >= 0.5 * min_width * min_width)]
    # ... and bounds at least that wide both ways, and its narrowest enclosing rectangle too (most
    # slivers between beads fail one of these cheap tests before the buffer below)
    lo_hi = shapely.bounds(big)
    big = big[np.min(lo_hi[:, 2:] - lo_hi[:, :2], axis=1) >= min_width]
    known = {} if known is None else known
    keys = _key(big)
    new = np.array([k not in known for k in keys], dtype=bool)
    if np.any(new):
        test = big[new]
        rect = shapely.minimum_rotated_rectangle(test)
        is_poly = shapely.get_type_id(rect) == 3
        side = np.zeros(len(test))
        if np.any(is_poly):
            c = shapely.get_coordinates(shapely.get_exterior_ring(rect[is_poly])).reshape(-1, 5, 2)
            side[is_poly] = np.minimum(np.hypot(*(c[:, 1] - c[:, 0]).T), np.hypot(*(c[:, 2] - c[:, 1]).T))
        wide = side >= min_width
        wide[wide] = ~shapely.is_empty(shapely.buffer(test[wide], -0.5 * min_width))
        for k, v in zip((k for k, n in zip(keys, new, strict=True) if n), wide, strict=True):
            known[k] = bool(v)
    pieces = [g for g, k in zip(big, keys, strict=True) if known[k]]
    pieces.sort(key=lambda g: (-round(g.area, 6), round(g.centroid.x, 6), round(g.centroid.y, 6)))
    return pieces


def _state(seeds: Points2, head: Points2, pid: Ints) -> SwarmState:
    start = np.zeros(len(seeds), dtype=bool)
    start[0] = True
    return SwarmState(pos=seeds.copy(), head=head.copy(), pid=pid, start=start)


def generate(inp: EngineInput, K: float = 5.0, **options: object) -> Toolpaths:
    """Stress-aligned paths for one layer region by the swarm method.

    Parameters
    ----------
    inp : EngineInput
        Region, stress field (already set to the followed principal stress), nominal pitch ``l``
        (the step is ``h = l``), and where the load enters (or None).
    K : float
        Weight of the environment (alignment) potential against the aggregation (spacing)
        potential, Eq. 12: ``P = P_a + K P_e``.
    **options
        Fields of :class:`SwarmParams` (``window``, ``kill_below``, ``spawn_above``, ...), and
        ``coverage_target`` (default 0.995: stop starting swarms above this nominal-bead
        coverage), ``max_swarms`` (default 400), ``fill`` (default True: start further swarms on
        uncovered pieces), ``fill_min_width`` (default 0.6: the narrowest uncovered piece, in
        pitches, that gets a fill swarm), ``widths`` (default ``"measured"``: every point's local
        pitch measured on the finished layer, :mod:`.widths`; ``"geometric"``: only the points the
        swarm is unsure of (chain ends, next to a boundary, seeds), the others from the chain
        neighbours; ``"swarm"``: all from the chain neighbours during the step; on the stiffness
        benchmark's bracket "measured" gives 0.56 of the ceiling gain against 0.50 for
        "geometric"), ``centre`` (default 0.25: measured points move up to this many pitches
        toward the wider of their two gaps, so their bead sits between the mid-gaps instead of
        covering the nearer neighbour, :func:`.widths.centre_points`; 0 turns it off),
        ``width_cap`` (default 1.5: the widest bead, in pitches), ``extend_ends`` (default True:
        path ends carried on to the next bead or the edge, :mod:`.ends`), ``end_cap`` (default 0:
        an end stops where its square end meets the bead it runs into; the flow model's bead
        ``w h L`` ends at the end point, so anything more leaves a void there), ``end_overlap``
        (default 0: how much of its own width an extension may cover of the beads beside it;
        ``None``: only the centre-line clearance is checked, as the streamline engine does; on
        the bracket 0 gives 0.49 of the ceiling gain, ``None`` 0.32), ``gaps`` (default True:
        a straight bead in each void left where path ends meet, :mod:`.gaps`), ``phase``
        (default 0: the seeds of every swarm, one pitch apart along their line, move on by this
        many pitches; 0.5 gives a layer whose paths run between those of phase 0, which the
        pipeline prints on every other of a run of identical layers), ``join`` (default True: ends
        facing each other across a gap of up to two pitches become one path, :mod:`.joins`; on the
        bench bracket 409 -> 343 paths, coverage 98.77 -> 98.81 %, overlap 3.86 -> 3.68 %),
        ``hairpin`` (default None: off; a number ``c`` also joins neighbours that end side by side
        by a hairpin whose bridge keeps ``c`` pitches from other paths; with 0.5 the bench
        bracket has 263 paths, 98.91 % coverage, 3.37 % overlap, the specimen 0.19 % overlap, but
        the stiffness benchmark's share falls from 0.82 to 0.79: the bridge's square-ended bead
        lies half on the bead the two ends stop at),
        ``settle`` (default None: off; a number ``b`` pulls back the ends whose round bead end lies
        on another bead where that removes more overlap than ``b`` times the void it leaves,
        :mod:`.caps`; with 10 the bench bracket's overlap falls to 2.82 % at 98.68 % coverage, but
        the stiffness benchmark, whose beads end square, loses about 0.05 of its share of the
        ceiling gain).

    Returns
    -------
    Toolpaths
        Paths with the local pitch at every point; ``stats`` holds the counts (steps, QP solves and
        statuses, kills, spawns, swarms) and the time per stage.
    """
    if not (np.isfinite(K) and K >= 0):
        raise SettingsError(f"K = {K!r} must be a non-negative number (the paper uses 0.5 to 50; default 5)")
    opts = dict(options)
    coverage_target = float(opts.pop("coverage_target", 0.995))  # type: ignore[arg-type]
    max_swarms = int(opts.pop("max_swarms", 400))  # type: ignore[call-overload]
    fill = bool(opts.pop("fill", True))
    fill_min_width = float(opts.pop("fill_min_width", 0.6))  # type: ignore[arg-type]
    widths = str(opts.pop("widths", "measured"))
    width_cap = float(opts.pop("width_cap", 1.5))  # type: ignore[arg-type]
    extend = bool(opts.pop("extend_ends", True))
    end_cap = float(opts.pop("end_cap", 0.0))  # type: ignore[arg-type]
    centre = float(opts.pop("centre", 0.25))  # type: ignore[arg-type]
    gaps = bool(opts.pop("gaps", True))
    phase = float(opts.pop("phase", 0.0))  # type: ignore[arg-type]
    settle = opts.pop("settle", None)
    join = bool(opts.pop("join", True))
    hairpin = opts.pop("hairpin", None)
    hairpin = None if hairpin is None else float(hairpin)  # type: ignore[arg-type]
    settle = None if settle is None else float(settle)  # type: ignore[arg-type]
    end_overlap = opts.pop("end_overlap", 0.0)
    end_overlap = None if end_overlap is None else float(end_overlap)  # type: ignore[arg-type]
    if widths not in ("geometric", "swarm", "measured"):
        raise SettingsError(
            f"widths = {widths!r}; use 'geometric' (from the finished layer) or 'swarm' (from the chains)"
        )
    params_kw = {k: opts.pop(k) for k in list(opts) if k in _PARAM_NAMES}
    if opts:
        raise SettingsError(
            f"unknown swarm option(s) {', '.join(sorted(opts))}; known: "
            f"{', '.join(sorted(_PARAM_NAMES | _ENGINE_OPTIONS))}"
        )
    params = SwarmParams(K=float(K), **params_kw)  # type: ignore[arg-type]
    t0 = time.perf_counter()
    pitch = float(inp.pitch)
    region = shapely.make_valid(inp.region) if not inp.region.is_valid else inp.region
    region = shapely.normalize(region)
    stats: dict = {}
    grid = Occupancy(tuple(region.bounds), pitch / 3.0)
    t_raster = time.perf_counter()
    raster = raster_for(inp.field, tuple(region.bounds), params.field_cell * pitch)
    stats["time_raster_s"] = time.perf_counter() - t_raster
    rec = _Recorder()
    next_pid = 0
    diag = float(np.hypot(region.bounds[2] - region.bounds[0], region.bounds[3] - region.bounds[1]))
    max_steps = int(4 * (region.length + diag) / pitch) + 10
    swarms = 0

    def run_swarm(domain_region: Region, chains: list[tuple[Points2, Points2]], both_ways: bool) -> None:
        """One swarm from the seed chains (and, for a fill swarm, its twin heading the other way)."""
        nonlocal next_pid, swarms
        domain = Domain(domain_region, params.margin * pitch, None if domain_region is region else region)
        seeds0 = np.concatenate([c[0] for c in chains])
        head0 = np.concatenate([c[1] for c in chains])
        start0 = np.concatenate([np.arange(len(c[0])) == 0 for c in chains])
        pid0 = np.arange(next_pid, next_pid + len(seeds0), dtype=np.int64)
        next_pid += len(seeds0)
        for sign in (1, -1) if both_ways else (1,):
            seeds, head, start, pid = seeds0, head0, start0, pid0
            if sign < 0:  # the twin: reversed heading, so reversed chain order (Eq. 5)
                seeds, head, pid = seeds[::-1], -head[::-1], pid[::-1]
                start = np.roll(start[::-1], 1)
            ok = (
                domain.inside(seeds)
                & grid.free_for(seeds, pid)
                & grid.clear_of(seeds, pid, (params.min_gap + 1.0 / 12.0) * pitch)
            )
            if not np.any(ok):
                continue
            gone = np.zeros(len(seeds), dtype=bool)
            gone[1:] = ~ok[:-1]
            start = (start | gone)[ok]
            start[0] = True
            st = SwarmState(pos=seeds[ok].copy(), head=head[ok].copy(), pid=pid[ok], start=start)
            ctx = Context(
                raster=raster,
                domain=domain,
                grid=grid,
                params=params,
                pitch=pitch,
                next_pid=next_pid,
                stats=stats,
            )
            rec.add(st.pos, st.pid, np.full(st.n, -pitch), 0)
            grid.mark(st.pos, st.pos, st.pid)
            _run(st, ctx, rec, sign, max_steps)
            next_pid = ctx.next_pid
            swarms += 1

    t_first = time.perf_counter()
    if inp.load_entry is not None and not inp.load_entry.is_empty:
        chains = _load_seeds(region, inp.load_entry, pitch, phase)
        if chains:
            run_swarm(region, chains, both_ways=False)
    stats["time_first_swarm_s"] = time.perf_counter() - t_first
    t_fill = time.perf_counter()
    rounds = 0
    area = float(region.area)
    given_up: list[Region] = []
    left, counted = shapely.get_parts(region), 0
    known: dict = {}
    while fill and swarms < max_swarms:
        # only the paths laid since the last round are subtracted from what was left
        left = _subtract_beads(left, rec.lines(min_pid=counted), pitch)
        counted = next_pid
        pieces = _pieces(left, fill_min_width * pitch, known)
        if given_up:
            pieces = [p for p in pieces if not any(p.equals_exact(g, 1e-9) for g in given_up)]
        covered = 1.0 - sum(p.area for p in pieces) / area
        stats["coverage_nominal"] = covered
        if not pieces or covered >= coverage_target:
            break
        rounds += 1
        progressed = False
        # seeds for every piece at once: a round's swarms stay in their own pieces
        all_seeds = _fill_seeds(pieces, inp.field, pitch, (params.margin + 0.05) * pitch, phase)
        for piece, seeds in zip(pieces, all_seeds, strict=True):
            if swarms >= max_swarms:
                break
            if seeds is None:
                given_up.append(piece)
                continue
            before = sum(len(p) for p in rec.pts)
            run_swarm(piece, [seeds], both_ways=True)
            if sum(len(p) for p in rec.pts) > before + 1:
                progressed = True
            else:
                given_up.append(piece)
        if not progressed:
            break
    stats["time_fill_s"] = time.perf_counter() - t_fill
    stats["fill_rounds"] = rounds
    stats["swarms"] = swarms
    paths = rec.paths()
    if widths in ("geometric", "measured") and paths:
        t_w = time.perf_counter()
        everywhere = widths == "measured"
        only = None if everywhere else [p.pitch < 0 for p in paths]
        w, lft, rgt = local_pitch(
            [p.points for p in paths], region, pitch, cap=width_cap, only=only, sides=True
        )
        if centre > 0:
            # measured points move toward the wider gap, so their bead sits between the mid-gaps
            # on either side instead of covering the nearer neighbour (its width, L + R over 2,
            # stays: moving along the normal between parallel neighbours does not change L + R)
            moved = centre_points([p.points for p in paths], lft, rgt, centre * pitch, (0.5 + 0.03) * pitch)
            paths = [Path(points=q, pitch=p.pitch, kind=p.kind) for q, p in zip(moved, paths, strict=True)]
        stats["widths_measured"] = int(sum(np.count_nonzero(p.pitch < 0) for p in paths))
        paths = [
            Path(
                points=p.points,
                pitch=wi if everywhere else np.where(p.pitch < 0, wi, np.minimum(p.pitch, width_cap * pitch)),
                kind=p.kind,
            )
            for p, wi in zip(paths, w, strict=True)
        ]
        stats["time_widths_s"] = time.perf_counter() - t_w
    else:
        paths = [Path(points=p.points, pitch=np.abs(p.pitch), kind=p.kind) for p in paths]
    if extend and paths:
        t_e = time.perf_counter()
        pts, wid, st = extend_ends(
            [p.points for p in paths],
            [p.pitch for p in paths],
            region,
            pitch,
            edge_gap=params.edge_gap,
            field=inp.field,
            cap=end_cap,
            overlap=end_overlap,
        )
        paths = [Path(points=q, pitch=w, kind=p.kind) for q, w, p in zip(pts, wid, paths, strict=True)]
        stats.update(st)
        stats["time_ends_s"] = time.perf_counter() - t_e
    if join and paths:
        t_j = time.perf_counter()
        jp, jw, origin, st = join_ends(
            [p.points for p in paths], [p.pitch for p in paths], region, pitch, hairpin=hairpin
        )
        paths = [Path(points=q, pitch=w, kind=paths[o].kind) for q, w, o in zip(jp, jw, origin, strict=True)]
        stats.update(st)
        stats["time_joins_s"] = time.perf_counter() - t_j
    if gaps and paths:
        t_g = time.perf_counter()
        gp, gw, st = gap_fill(
            [p.points for p in paths], [p.pitch for p in paths], region, pitch, field=inp.field
        )
        paths += [Path(points=q, pitch=w, kind="fill") for q, w in zip(gp, gw, strict=True)]
        stats.update(st)
        stats["time_gaps_s"] = time.perf_counter() - t_g
    if settle is not None and paths:
        t_s = time.perf_counter()
        sp, sw, st = settle_ends(
            [p.points for p in paths], [p.pitch for p in paths], region, pitch, balance=settle
        )
        paths = [Path(points=q, pitch=w, kind=p.kind) for q, w, p in zip(sp, sw, paths, strict=True)]
        stats.update(st)
        stats["time_settle_s"] = time.perf_counter() - t_s
    stats["time_s"] = time.perf_counter() - t0
    stats["K"] = params.K
    return Toolpaths(paths=tuple(paths), stats=stats)
