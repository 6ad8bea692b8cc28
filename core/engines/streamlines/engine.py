"""The streamline engine: thesis stages I-III, faithfully or fast (``loadpath.engines.streamlines``).

Stages (thesis Fig. 4.2):

I. streamline generation - :mod:`.seeding`, :mod:`.integrate` (through :mod:`.directions`)
II. density control - (A) continuous filaments, :mod:`.density`; (B) gap filling, :mod:`.gapfill`
III. path linking - :mod:`.linking`; the local pitch of every vertex comes from :mod:`.widths`

``mode="faithful"`` runs the thesis's algorithm with its parameters (:mod:`.params`): Euler steps of
0.3 mm from seeds spread at 0.2 per mm² (or the caller's element centroids, ``seeds=``) traced to
full length, whole-streamline Delaunay density control, one-circle-at-a-time gap filling, constant
0.5 mm beads.  ``mode="default"`` is fast and closes the coverage gap: RK2 steps of one pitch from
boundary seeds one pitch apart across the field, exact segment spacing, gap rounds of many seeds at
once with a Jobard-Lefer stop, variable bead width, a minimum filament length and a turning limit.

Which paths are ``"continuous"``: whole streamlines that no spacing rule shortened (both ends on
the boundary, at a degenerate point or at the turning limit), as the thesis's density control keeps
them; everything trimmed or stopped for spacing, and every gap-filling piece, is ``"fill"``.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import shapely
from loadpath._typing import Points2
from loadpath.engines.streamlines._lines import Lines
from loadpath.engines.streamlines.density import Selected, drop_crossings, select, thesis_density_control
from loadpath.engines.streamlines.directions import DirectionGrid
from loadpath.engines.streamlines.gapfill import Raster, fill_rounds, thesis_gap_fill
from loadpath.engines.streamlines.integrate import END_NAMES, END_SPACING, TraceSettings, trace
from loadpath.engines.streamlines.linking import link
from loadpath.engines.streamlines.params import StreamlineParams, resolve_params
from loadpath.engines.streamlines.seeding import boundary_seeds, lattice
from loadpath.engines.streamlines.segindex import SegmentIndex
from loadpath.engines.streamlines.widths import tile
from loadpath.engines.finish.ends import extend_ends
from loadpath.errors import GeometryError, SettingsError
from loadpath.toolpath import EngineInput, Path, Toolpaths

END_GAP = 0.25
"""Extended path ends keep this many pitches inside the region (as the swarm's ``edge_gap``)."""

__all__ = ["generate"]


def generate(inp: EngineInput, mode: str = "default", **options: Any) -> Toolpaths:
    """Stress-following paths for one region (the engine contract of ``loadpath.engines``).

    Parameters
    ----------
    inp : EngineInput
        Replace region (holes and islands allowed), stress field (faithful mode switches it to the
        tensile principal stress), nominal pitch.
    mode : {"default", "faithful"}
    **options
        Any :class:`~loadpath.engines.streamlines.params.StreamlineParams` field, ``nozzle``,
        ``width_range``, ``flow_width`` (see :func:`~.params.resolve_params`), and ``seeds``
        ((n, 2) mm, e.g. the FE element centroids; faithful mode).  ``phase`` (pitches, default
        mode) moves the boundary seeds on along the boundary: 0.5 lays paths between those of 0.

    Returns
    -------
    Toolpaths
        Paths in print order; ``kind`` ``"continuous"`` or ``"fill"``; ``pitch`` per vertex.
        ``stats`` holds stage times (s), counts and why streamlines ended.
    """
    seeds = options.pop("seeds", None)
    params = resolve_params(mode, inp.pitch, **options)
    region = inp.region
    if region.geom_type not in ("Polygon", "MultiPolygon") or not region.is_valid:
        raise GeometryError(
            f"the replace region is a {'invalid ' if not region.is_valid else ''}{region.geom_type}; "
            "the streamline engine needs a valid Polygon or MultiPolygon (try region.buffer(0))"
        )
    field = inp.field if params.principal is None else inp.field.with_principal(params.principal)
    t0 = time.perf_counter()
    spacing = params.grid_spacing or min(params.step, 0.5)
    grid = DirectionGrid(field, region, spacing)
    times = {"field_grid": time.perf_counter() - t0}
    if params.mode == "faithful":
        lines, kinds, stats = _faithful(region, grid, params, seeds, times)
        widths = [np.full(len(ln), params.w) for ln in lines]
    else:
        if seeds is not None:
            raise SettingsError("seeds= is a faithful-mode option; the default mode seeds from the boundary")
        lines, kinds, stats = _default(region, grid, params, times)
        t = time.perf_counter()
        packed, pitch = tile(
            Lines.from_list(lines),
            region,
            params.width_min,
            params.width_max,
            params.min_spacing,
            grid.inside,
            params.max_turn_deg,
        )
        lines = packed.to_list()
        widths = [pitch[packed.offsets[i] : packed.offsets[i + 1]] for i in range(len(lines))]
        times["widths"] = time.perf_counter() - t
        if params.extend_ends and lines:
            t = time.perf_counter()
            lines, widths, st = extend_ends(
                lines,
                widths,
                region,
                params.pitch,
                edge_gap=END_GAP,
                clearance=params.min_spacing,
                field=field,
            )
            stats.update(st)
            times["ends"] = time.perf_counter() - t
    t = time.perf_counter()
    order = link(lines)
    paths = []
    for j, rev in order:
        pts, w = lines[j], widths[j]
        if rev:
            pts, w = pts[::-1], w[::-1]
        paths.append(Path(points=np.ascontiguousarray(pts), pitch=np.ascontiguousarray(w), kind=kinds[j]))
    times["linking"] = time.perf_counter() - t
    times["total"] = time.perf_counter() - t0
    stats.update(
        {
            "mode": params.mode,
            "times_s": times,
            "n_paths": len(paths),
            "n_continuous": int(sum(p.kind == "continuous" for p in paths)),
            "n_fill": int(sum(p.kind == "fill" for p in paths)),
            "params": {k: v for k, v in vars(params).items() if isinstance(v, (int, float, str, bool))},
        }
    )
    return Toolpaths(paths=tuple(paths), stats=stats)


def _trace_settings(params: StreamlineParams, region_extent: float, loop_radius: float) -> TraceSettings:
    return TraceSettings(
        step=params.step,
        method=params.method,
        max_turn=params.max_turn,
        max_length=params.max_length or region_extent,
        clearance=params.min_spacing,
        loop_radius=loop_radius,
    )


def _extent(region: shapely.Geometry) -> float:
    """Guard length of one branch: the region's bounding-box perimeter."""
    x0, y0, x1, y1 = region.bounds
    return 2.0 * ((x1 - x0) + (y1 - y0))


def _ends_stats(sel: list[Selected]) -> dict[str, int]:
    out: dict[str, int] = {}
    for s in sel:
        for r in np.concatenate([s.end_start, s.end_finish]):
            name = END_NAMES.get(int(r), "none")
            out[name] = out.get(name, 0) + 1
    return out


def _default(
    region: shapely.Geometry, grid: DirectionGrid, params: StreamlineParams, times: dict[str, float]
) -> tuple[list[Points2], list[str], dict[str, Any]]:
    settings = _trace_settings(params, _extent(region), params.min_spacing)
    t = time.perf_counter()
    # streamlines end on the boundary and where the direction is undefined (a jump of the followed
    # stress, a degenerate point): both are seeded, so trajectories that start at an interior
    # jump line are started too
    zone = grid.undefined_zone()
    ends = region.difference(zone.buffer(0.5 * grid.spacing)) if not zone.is_empty else region
    seeds, entry = boundary_seeds(ends, grid, params.pitch, params.boundary_seed_gap, params.phase)
    # Entry seeds are traced freely and the whole streamlines kept; exit seeds (mostly the other
    # ends of the same trajectories) are then traced against what was kept, so their duplicates
    # are rejected at the seed instead of being traced in full and thrown away.
    traced = trace(seeds[entry], grid, settings)
    times["trace"] = time.perf_counter() - t
    t = time.perf_counter()
    first = select(traced, params.min_spacing, params.min_length, runs="all")
    times["density"] = time.perf_counter() - t
    t = time.perf_counter()
    index = SegmentIndex(first.lines)
    traced_b = trace(seeds[~entry], grid, settings, obstacles=index, seed_clearance=params.fill_spacing)
    second = select(traced_b, params.min_spacing, params.min_length, runs="seed")
    times["trace_exits"] = time.perf_counter() - t
    rounds: list[dict[str, float]] = []
    added: list[Selected] = []
    if params.gap_fill:
        t = time.perf_counter()
        raster = Raster(region, cell=min(params.min_spacing, params.step) / 2.0)
        added, rounds = fill_rounds(
            region,
            grid,
            [first, second],
            settings,
            min_spacing=params.min_spacing,
            fill_spacing=params.fill_spacing,
            min_length=params.min_length,
            seed_cell=10.0 * params.pitch,
            seed_across=1.5 * params.pitch,
            max_waves=params.max_waves,
            raster=raster,
        )
        times["gap_fill"] = time.perf_counter() - t
    lines: list[Points2] = []
    kinds: list[str] = []
    for s in [first, second, *added]:
        for i in range(len(s.lines)):
            lines.append(s.lines.line(i))
            cont = bool(s.whole[i]) and s.end_start[i] != END_SPACING and s.end_finish[i] != END_SPACING
            kinds.append("continuous" if cont else "fill")
    stats: dict[str, Any] = {
        "seeds": int(len(seeds)),
        "traced": int(len(traced.lines) + len(traced_b.lines)),
        "traced_points": int(len(traced.lines.points) + len(traced_b.lines.points)),
        "gap_rounds": rounds,
        "ends": _ends_stats([first, second, *added]),
    }
    return lines, kinds, stats


def _faithful(
    region: shapely.Geometry,
    grid: DirectionGrid,
    params: StreamlineParams,
    seeds: Points2 | None,
    times: dict[str, float],
) -> tuple[list[Points2], list[str], dict[str, Any]]:
    spacing = params.min_spacing  # w + G_p
    settings = _trace_settings(params, _extent(region), 0.5 * spacing)
    t = time.perf_counter()
    corners = getattr(grid.field, "corners", None)
    if seeds is None and params.seeding == "centroids":
        if corners is None:
            raise SettingsError(
                "seeding = 'centroids' needs a finite-element stress field; use seeding = 'density'"
            )
        c = np.asarray(corners, dtype=float).mean(axis=1)
        seeds = c[grid.inside(c)]
    if seeds is None:
        # hexagonal lattice with the thesis's seed density: 2 / (sqrt(3) a^2) = rho
        a = float(np.sqrt(2.0 / (np.sqrt(3.0) * params.seed_density)))
        seeds = lattice(region, a)
    seeds = np.asarray(seeds, dtype=float).reshape(-1, 2)
    traced = trace(seeds, grid, settings)
    times["trace"] = time.perf_counter() - t
    t = time.perf_counter()
    chosen, dstats = thesis_density_control(traced.lines, region, spacing, grid.inside)
    filaments = traced.lines.subset(chosen)
    times["density"] = time.perf_counter() - t
    lines = [ln for ln in filaments.to_list() if len(ln) >= 2]
    kinds = ["continuous"] * len(lines)
    fstats: dict[str, int] = {}
    if params.gap_fill:
        t = time.perf_counter()
        max_it = params.max_fill_iterations or int(4.0 * region.area / spacing**2) + 100
        pieces, fstats = thesis_gap_fill(
            region,
            grid,
            filaments,
            settings,
            spacing=spacing,
            gap_diameter=params.fill_spacing,
            max_iterations=max_it,
        )
        lines += pieces
        kinds += ["fill"] * len(pieces)
        times["gap_fill"] = time.perf_counter() - t
    # guard (not in the thesis): no path crosses or touches another (closer than half the spacing)
    lines, src = drop_crossings(lines, np.arange(len(lines)), 0.5 * spacing)
    kinds = [kinds[i] for i in src]
    if params.min_length > 0:
        keep = [i for i, ln in enumerate(lines) if Lines.from_list([ln]).lengths()[0] >= params.min_length]
        lines = [lines[i] for i in keep]
        kinds = [kinds[i] for i in keep]
    stats: dict[str, Any] = {
        "seeds": int(len(seeds)),
        "traced": int(len(traced.lines)),
        "traced_points": int(len(traced.lines.points)),
        "density_control": dstats,
        "gap_fill": fstats,
    }
    return lines, kinds, stats
