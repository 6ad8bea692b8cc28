"""Figures and numbers of one distinct layer (one engine run) for the report.

For the representative layer of each engine run: the stress field over the replace region, the
slicer's paths and the new paths coloured by their alignment ``|s . p|`` with the followed principal
direction, the spacing histograms, and the metrics of :mod:`loadpath.metrics` for both (beta,
spacing variance, coverage, overlap), with the extruded volume before and after and the engine time.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import shapely
from loadpath import metrics
from loadpath.field import StressField
from loadpath.gcode import Program
from loadpath.gcode.rowindex import move_rows
from loadpath.report.closeup import detail_centre
from loadpath.report.svg import Canvas, histogram
from loadpath.toolpath import Path

__all__ = ["LayerReport", "layer_report", "segments_of", "paths_of"]

_THIN = 0.35
"""Drawn width of a path in the whole-layer figure, as a share of its bead: neighbouring paths stay
apart at any zoom of the (vector) figure."""


@dataclass
class LayerReport:
    """One distinct layer.

    Attributes
    ----------
    title : str
    layers : list of int
        1-based layer numbers that print these paths.
    numbers : dict
        Everything for ``metrics.json`` (JSON-able).
    figure : str
        SVG: the field, the slicer's paths and the new paths, stacked.
    detail : str
        SVG: the slicer's and the new paths side by side around the most stressed point.
    hist : str
        SVG: spacing histograms.
    """

    title: str
    layers: list[int]
    numbers: dict[str, Any] = field(default_factory=dict)
    figure: str = ""
    detail: str = ""
    hist: str = ""


def segments_of(moves: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Start points, end points and widths (mm; NaN widths become 0.4) of extruding moves."""
    m = moves[moves["extrude"]]
    a = np.column_stack([m["x0"], m["y0"]])
    b = np.column_stack([m["x1"], m["y1"]])
    w = np.where(np.isfinite(m["width"]), m["width"], 0.4)
    return a, b, w


def paths_of(moves: np.ndarray, pitch: float, turn_deg: float = 60.0, min_pitches: float = 2.0) -> list[Path]:
    """Split a block's extrusions into its lines, as separate paths with a constant pitch.

    Consecutive extrusions form a polyline; it is cut where it turns by more than ``turn_deg`` (the
    slicer's zig-zag links along the edge), and pieces shorter than ``min_pitches`` pitches (the links
    themselves) are dropped, so a rectilinear fill becomes its lines, as the metrics expect.
    """
    m = moves[moves["extrude"]]
    if len(m) == 0:
        return []
    d = np.column_stack([m["x1"] - m["x0"], m["y1"] - m["y0"]])
    ang = np.arctan2(d[:, 1], d[:, 0])
    turn = np.abs((np.diff(ang) + np.pi) % (2 * np.pi) - np.pi)
    brk = np.ones(len(m), dtype=bool)
    brk[1:] = (
        (np.abs(m["x0"][1:] - m["x1"][:-1]) > 1e-6)
        | (np.abs(m["y0"][1:] - m["y1"][:-1]) > 1e-6)
        | (turn > np.radians(turn_deg))
    )
    starts = np.flatnonzero(brk)
    out = []
    for a, z in zip(starts, np.r_[starts[1:], len(m)], strict=True):
        pts = np.vstack([[m["x0"][a], m["y0"][a]], np.column_stack([m["x1"][a:z], m["y1"][a:z]])])
        if np.sum(np.hypot(*np.diff(pts, axis=0).T)) >= min_pitches * pitch:
            out.append(Path(pts, np.full(len(pts), pitch)))
    return out


def _travel(moves: np.ndarray) -> float:
    """XY travel of moves that do not extrude (wipes included), mm."""
    t = moves[~moves["extrude"]]
    return float(np.sum(np.hypot(t["x1"] - t["x0"], t["y1"] - t["y0"])))


def _alignment(field_: StressField, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``|s . p|`` at each segment's middle (NaN where the direction is undefined)."""
    if len(a) == 0:
        return np.zeros(0)
    smp = field_.sample(0.5 * (a + b))
    d = b - a
    d /= np.maximum(np.hypot(d[:, 0], d[:, 1]), 1e-12)[:, None]
    cos = np.abs(np.sum(smp.direction * d, axis=1))
    return np.where(smp.valid, cos, np.nan)


def _field_ticks(
    canvas: Canvas, field_: StressField, region, step: float, stroke: str | None = None, width_px: float = 0.0
) -> None:
    """Draw ticks of the followed principal direction every ``step`` mm.

    Coloured by ``|s| / scale`` (or all ``stroke``), ``0.18 step`` wide (or ``width_px``).
    """
    if region.is_empty or not step > 0:
        return
    x0, y0, x1, y1 = region.bounds
    gx, gy = np.meshgrid(np.arange(x0 + step / 2, x1, step), np.arange(y0 + step / 2, y1, step))
    pts = np.column_stack([gx.ravel(), gy.ravel()])
    pts = pts[shapely.contains_xy(region, pts[:, 0], pts[:, 1])]
    if len(pts) == 0:
        return
    smp = field_.sample(pts)
    ok = smp.valid
    half = 0.42 * step * smp.direction[ok]
    wide = width_px / canvas.s if width_px > 0 else 0.18 * step
    canvas.segments(pts[ok] - half, pts[ok] + half, smp.mass[ok], wide, stroke=stroke)


def clip_segments(a: np.ndarray, b: np.ndarray, box: tuple[float, float, float, float]) -> tuple:
    """Clip segments ``a[i] -> b[i]`` to an axis-aligned box (Liang-Barsky, vectorized).

    Returns ``(a', b', keep)``: the clipped ends of the segments that touch the box and the boolean
    mask of which input segments they are.
    """
    x0, y0, x1, y1 = box
    d = b - a
    t0 = np.zeros(len(a))
    t1 = np.ones(len(a))
    keep = np.ones(len(a), dtype=bool)
    for p, q in (
        (-d[:, 0], a[:, 0] - x0),
        (d[:, 0], x1 - a[:, 0]),
        (-d[:, 1], a[:, 1] - y0),
        (d[:, 1], y1 - a[:, 1]),
    ):
        par = p == 0
        keep &= ~(par & (q < 0))
        with np.errstate(divide="ignore", invalid="ignore"):
            r = np.where(par, 0.0, q / np.where(par, 1.0, p))
        t0 = np.where(~par & (p < 0), np.maximum(t0, r), t0)
        t1 = np.where(~par & (p > 0), np.minimum(t1, r), t1)
    keep &= t0 <= t1
    return (a + t0[:, None] * d)[keep], (a + t1[:, None] * d)[keep], keep


def _detail(region, field_: StressField, old: tuple, new: tuple, pitch: float, width: int = 960) -> str:
    """Draw the slicer's and the new paths side by side, zoomed on the region's largest hole.

    Stress concentrates at holes; without one, the view centres on the most stressed point away
    from the region's ends (supports and loads sit there).  Paths are drawn as thin centre lines
    (1.3 px, a fifth of the pitch at this zoom) coloured by alignment, over grey ticks of the
    followed principal direction on a dark region: drawn as beads they tile the region into one
    solid colour and the reader cannot see where a path goes.
    """
    x0, y0, x1, y1 = region.bounds
    big = max(x1 - x0, y1 - y0)
    ww = min(x1 - x0, max(25 * pitch, 0.2 * big))
    wh = min(y1 - y0, 0.7 * ww)
    c = detail_centre(region, field_, ww, wh)
    bx0 = float(np.clip(c[0] - ww / 2, x0, x1 - ww))
    by0 = float(np.clip(c[1] - wh / 2, y0, y1 - wh))
    bounds = (bx0, by0, bx0 + ww, by0 + wh)
    half = width // 2 - 6
    view = region.intersection(shapely.box(*bounds))
    uid = f"clip{abs(hash((bounds, pitch))) % 10**8}"
    out = []
    for k, ((a, b, _w, cos), label) in enumerate(zip((old, new), ("the slicer", "loadpath"), strict=True)):
        cv = Canvas(bounds, width=half, pad=4)
        cv.region(region, fill="#262626", stroke="#bbbbbb")
        _field_ticks(cv, field_, view, 1.5 * pitch, stroke="#8c8c8c", width_px=1.0)
        ca, cb, keep = clip_segments(a, b, bounds)  # clipped here too: not every viewer honours clipPath
        cv.segments(ca, cb, np.nan_to_num(cos[keep]), 1.3 / cv.s)
        cv.items.append(
            f'<rect x="{cv.pad}" y="{cv.pad}" width="{9 * len(label) + 12}" height="22" '
            'fill="white" opacity="0.85"/>'
        )
        cv.text(cv.pad + 6, cv.pad + 16, label, 14)
        out.append(
            f'<g transform="translate({k * (half + 12)},0)" clip-path="url(#{uid}{k})">'
            f"{''.join(cv.items)}</g>"
            f'<clipPath id="{uid}{k}"><rect x="0" y="0" width="{half}" height="{cv.height}"/>'
            "</clipPath>"
        )
        h = cv.height
    caption = (
        f'<text x="{width / 2:.0f}" y="{h + 16}" font-size="12" text-anchor="middle" '
        'font-family="sans-serif">'
        "lines: path centres, coloured by alignment |s . p| with the principal stress (yellow: along it, "
        "purple: across); grey ticks: the principal stress direction</text>"
    )
    h2 = h + 24
    return (
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{h2}" viewBox="0 0 {width} {h2}">'
        f'<rect width="100%" height="100%" fill="white"/>{"".join(out)}{caption}</svg>'
    )


def layer_report(
    job_result,
    program: Program,
    output: Program | None,
    splice_result,
    field_: StressField,
    title: str,
    filament_area: float,
    with_metrics: bool = True,
) -> LayerReport:
    """Build the report of one engine run (see the module docstring)."""
    unit = job_result.units[0]
    region = unit.region
    pitch = unit.pitch
    blocks = [b.block_index for b in unit.blocks]
    old_moves = np.concatenate([program.moves[program.block(i).moves] for i in blocks])
    new_moves = []
    if output is not None and splice_result is not None:
        for i in blocks:
            for a, z in splice_result.output_ranges(program, i):
                new_moves.append(output.moves[move_rows(output, a, z)])
    new_moves = np.concatenate(new_moves) if new_moves else old_moves[:0]
    oa, ob, ow = segments_of(old_moves)
    na, nb, nw = segments_of(new_moves)
    cos_old, cos_new = _alignment(field_, oa, ob), _alignment(field_, na, nb)

    # figure: field, slicer's paths, new paths (stacked panels of the same size)
    x0, y0, x1, y1 = region.bounds
    pad = 0.04 * max(x1 - x0, y1 - y0)
    bounds = (x0 - pad, y0 - pad, x1 + pad, y1 + pad)
    panels = []
    for name in ("field", "old", "new"):
        c = Canvas(bounds, width=960)
        c.region(region)
        if name == "field":
            _field_ticks(c, field_, region, max(2.5 * pitch, (x1 - x0) / 90))
            label = (
                "stress field: followed principal direction, colour |s| / scale "
                f"(principal = {job_result.job.principal})"
            )
        elif name == "old":  # centre lines a third of the bead wide: beads would merge into one colour
            c.segments(oa, ob, np.nan_to_num(cos_old), _THIN * ow)
            label = "the slicer's paths (centre lines; zoom in), colour = alignment |s . p|"
        else:
            c.segments(na, nb, np.nan_to_num(cos_new), _THIN * nw)
            label = "loadpath's paths (centre lines; zoom in), colour = alignment |s . p|"
        c.text(c.pad + 4, c.pad + 14, label, 13)
        panels.append(c)
    total_h = sum(p.height for p in panels)
    y = 0
    body = []
    for p in panels:
        body.append(f'<g transform="translate(0,{y})">{"".join(p.items)}</g>')
        y += p.height
    figure = (
        f'<svg xmlns="http://www.w3.org/2000/svg" width="960" height="{total_h}" viewBox="0 0 960 {total_h}">'
        f'<rect width="100%" height="100%" fill="white"/>{"".join(body)}</svg>'
    )

    detail = _detail(region, field_, (oa, ob, ow, cos_old), (na, nb, nw, cos_new), pitch)
    numbers: dict[str, Any] = {
        "object": unit.object,
        "kind": unit.kind,
        "principal": job_result.job.principal,
        "layers": [u.layer + 1 for u in job_result.units],
        "z": unit.z,
        "height": unit.height,
        "pitch_mm": pitch,
        "flow_width_mm": unit.flow_width,
        "region_area_mm2": float(region.area),
        "engine": job_result.engine,
        # the engine tried first, where it gave way to this one (the level sets on a solid layer a
        # neutral axis cuts: {"engine": "levelset", "cut_mm": ...}); None otherwise
        "gave_way": job_result.paths.stats.get("gave_way"),
        "engine_s": job_result.seconds,
        "n_paths_engine": len(job_result.paths.paths),
        "staggered_layers": [
            u.layer + 1 for u, s in zip(job_result.units, job_result.staggered, strict=True) if s
        ],
    }
    reps = [r for r in (splice_result.blocks if splice_result else ()) if r.block in blocks]
    area = filament_area
    if reps:
        numbers["volume_old_mm3"] = float(sum(r.filament_old for r in reps)) * area
        numbers["volume_new_mm3"] = float(sum(r.filament_new for r in reps)) * area
        numbers["flow_correction"] = float(np.mean([r.correction for r in reps]))
        numbers["print_s_old"] = float(sum(r.seconds_old for r in reps))
        numbers["print_s_new"] = float(sum(r.seconds_new for r in reps))
        numbers["retractions_new"] = int(sum(r.n_retracts for r in reps))
    numbers["alignment_mean_old"] = _finite_mean(cos_old)
    numbers["alignment_mean_new"] = _finite_mean(cos_new)
    hist = ""
    if with_metrics:
        old_paths = paths_of(old_moves, pitch)
        new_paths = _printed(job_result.paths.paths)
        row_old, sp_old = _metrics(old_paths, region, field_, pitch, unit.flow_width)
        row_new, sp_new = _metrics(new_paths, region, field_, pitch, None)
        row_old["travel_mm"], row_new["travel_mm"] = _travel(old_moves), _travel(new_moves)
        numbers["old"], numbers["new"] = row_old, row_new
        hist = histogram(
            [("slicer", sp_old, "#888888"), ("loadpath", sp_new, "#21908d")],
            0.0,
            2.5,
            xlabel="distance to the nearest neighbouring path / pitch",
        )
    return LayerReport(title, numbers["layers"], numbers, figure, detail, hist)


def _finite_mean(v: np.ndarray) -> float:
    """Mean of the finite values, NaN when there is none (``np.nanmean`` warns "Mean of empty slice")."""
    v = v[np.isfinite(v)]
    return float(v.mean()) if len(v) else float("nan")


def _printed(paths) -> list[Path]:
    """Simplify the engine's paths as the splicer's first pass does (0.005 mm, pitch 0.025 mm).

    The engines return a vertex every few hundredths of a millimetre (31 000 vertices for 123 paths
    on the shipped example, 3 300 after this pass), which made the report's metrics take 7 s per
    layer; on the simplified paths they take 2 s.  Shipped example, raw -> simplified: beta 0.99993
    -> 0.99992, spacing variance 0.00705 -> 0.00706, coverage 0.9984 -> 0.9962 and overlap 0.0027
    -> 0.0049 (the pitch tolerance evens out per-vertex width noise; the splicer smooths it more).
    """
    from loadpath.splice.plan import PlanOptions, simplify

    o = PlanOptions()
    simple = simplify([(p.points, p.pitch) for p in paths], o.resolution, o.pitch_resolution, o.min_segment)
    return [Path(pts, w, p.kind) for (pts, w), p in zip(simple, paths, strict=True) if len(pts) >= 2]


def _metrics(
    paths: list[Path], region, field_: StressField, pitch: float, flow_width: float | None
) -> tuple[dict[str, float | None], np.ndarray]:
    """Compute the report's metrics (:mod:`loadpath.metrics`; spacing by the "nearest" definition only)."""
    al = metrics.alignment(paths, field_, pitch, region=region)
    sp = metrics.spacing(paths, pitch, "nearest")
    cov = metrics.coverage(paths, region, flow_width)
    row = {
        "beta": al.beta,
        "beta_curved": al.beta_curved,
        "spacing_mean": sp.mean,
        "spacing_var": sp.variance,
        "spacing_p5": sp.p5,
        "spacing_p95": sp.p95,
        "spacing_min": sp.min,
        "coverage": cov.coverage,
        "overlap": cov.overlap,
        "n_paths": float(len(paths)),
        "length_mm": float(sum(p.length for p in paths)),
        "crossings": float(metrics.crossings(paths)),
    }
    return _clean(row), sp.values


def _clean(row: dict[str, float]) -> dict[str, float | None]:
    return {k: (None if not np.isfinite(v) else float(v)) for k, v in row.items()}
