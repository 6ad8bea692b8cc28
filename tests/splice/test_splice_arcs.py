"""G2/G3 arcs in the new paths (issue 17): only where the file's settings allow them, on the path.

Real files: PrusaSlicer 2.9.2 with ``arc_fitting = emit_center`` (``tests/data/current``) and a
PrusaSlicer 2.5 slice (no such key).  The same curved fill (rings about each block's centre) is
spliced into both: the 2.5 file gets no ``G2``/``G3`` at all; the 2.9.2 file gets arcs among its new
lines, passes the splice check, is smaller than with arcs off, extrudes the same filament, and every
point of its new extrusions (arcs sampled as the parser reads them) lies on the rings within the
bound the arcs are fitted to.
"""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import numpy as np
import pytest
import shapely
from loadpath import gcode
from loadpath.splice.arcfit import ArcOptions, arcs_allowed, fit_arcs
from loadpath.toolpath import Path as ToolPath
from shapely.geometry import LineString
from splice_helpers import infill_blocks, rectilinear_fills, run_splice

DATA = Path(__file__).parent.parent / "data" / "current"
ARC_FILE = DATA / "prusaslicer-2.9.2-calicat-mini-arcs-m486.gcode"
PITCH = 0.45


def _rings(fill):
    """The fill's region covered by rings about its centroid, PITCH apart (vertices 0.3 mm apart)."""
    reg = fill.region
    c = reg.centroid
    minx, miny, maxx, maxy = reg.bounds
    inner = reg.buffer(-PITCH / 2)
    paths = []
    for r in np.arange(PITCH, np.hypot(maxx - minx, maxy - miny), PITCH):
        t = np.linspace(0.0, 2 * np.pi, max(16, int(2 * np.pi * r / 0.3)))
        g = LineString(np.c_[c.x + r * np.cos(t), c.y + r * np.sin(t)]).intersection(inner)
        for part in getattr(g, "geoms", [g]):
            if part.geom_type == "LineString" and part.length > 1.0:
                pts = np.asarray(part.coords)
                paths.append(ToolPath(pts, np.full(len(pts), PITCH)))
    return dataclasses.replace(fill, paths=tuple(paths), nominal_pitch=PITCH)


def _new_moves(program, result, out):
    lmap = result.line_map(program.n_lines)
    new = np.ones(out.n_lines, dtype=bool)
    new[lmap[lmap >= 0]] = False
    m = out.moves
    return m[new[m["line"]]]


def test_arcs_only_where_the_file_allows_them(sliced):
    program = gcode.read(sliced("prusa", "ohs", "solid"))
    assert not arcs_allowed(program.config)  # PrusaSlicer 2.5: no arc_fitting key
    fills = [_rings(f) for f in rectilinear_fills(program, infill_blocks(program)[:2])]
    result, out, check = run_splice(program, fills)
    assert check.problems == []
    assert not re.search(rb"^G[23] ", result.data, re.M)
    assert not out.moves["arc"].any()


def test_arcs_follow_the_path_and_keep_the_filament():
    program = gcode.read(ARC_FILE)
    assert arcs_allowed(program.config)
    fills = [_rings(f) for f in rectilinear_fills(program, infill_blocks(program)[:4])]
    result, out, check = run_splice(program, fills)
    assert check.problems == []
    plain, _, check0 = run_splice(program, fills, options={"arcs": None})
    assert check0.problems == []
    new = _new_moves(program, result, out)
    arcs = new[new["arc"] & new["extrude"]]
    assert len(np.unique(arcs["line"])) >= 10
    assert len(result.data) < len(plain.data)
    # the same filament per block as the splice without arcs
    for a, b in zip(result.blocks, plain.blocks, strict=True):
        assert a.filament_new == pytest.approx(b.filament_new, abs=1e-4)
    # every point of the new extrusions (arc chords' ends) on the rings: the runs' bound (40 % of
    # the flow width) plus the vertex tolerance, the parser's chords and the written rounding
    rings = shapely.union_all([LineString(p.points) for f in fills for p in f.paths])
    ext = new[new["extrude"]]
    pts = shapely.points(np.r_[np.c_[ext["x0"], ext["y0"]], np.c_[ext["x1"], ext["y1"]]])
    bound = 0.4 * PITCH + ArcOptions().tol + 0.01
    assert float(np.max(shapely.distance(pts, rings))) <= bound
    # inside the arcs: their chords' ends lie on the rings as closely
    mid = shapely.points(np.c_[0.5 * (arcs["x0"] + arcs["x1"]), 0.5 * (arcs["y0"] + arcs["y1"])])
    assert float(np.max(shapely.distance(mid, rings))) <= bound


def test_fit_arcs_on_a_circle_and_not_across_a_width_change():
    t = np.linspace(0.0, np.pi / 2, 13)  # 90 degrees of a 10 mm circle in 12 segments
    pts = np.c_[10 * np.cos(t), 10 * np.sin(t)]
    seg = np.hypot(*np.diff(pts, axis=0).T)
    fil, f = 0.04 * seg, np.full(12, 1800.0)
    w = np.full(12, 0.45)
    arcs = fit_arcs(pts, fil, w, f, ArcOptions(tol=0.005, chord=0.05))
    assert [(a.first, a.stop, a.ccw) for a in arcs] == [(0, 12, True)]
    assert arcs[0].centre == pytest.approx((0.0, 0.0), abs=1e-9)
    w2 = w.copy()
    w2[6:] = 0.5
    arcs = fit_arcs(pts, fil, w2, f, ArcOptions(tol=0.005, chord=0.05))
    assert [(a.first, a.stop) for a in arcs] == [(0, 6), (6, 12)]
    # clockwise, and a straight line is no arc
    assert [a.ccw for a in fit_arcs(pts[::-1], fil, w, f, ArcOptions(tol=0.005, chord=0.05))] == [False]
    line = np.c_[np.linspace(0, 10, 13), np.zeros(13)]
    assert fit_arcs(line, fil, w, f, ArcOptions()) == []
