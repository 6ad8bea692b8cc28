"""The report's close-up: thin centre lines a reader can follow, not beads that tile into one colour."""

from __future__ import annotations

import re

import numpy as np
from loadpath.field import AnalyticField, kirsch_tensor
from loadpath.metrics import rectilinear
from loadpath.report.layers import _alignment, _detail
from shapely.geometry import Point, box

REGION = box(0, 0, 150, 36).difference(Point(75, 18).buffer(3, quad_segs=32))
FIELD = AnalyticField(lambda p: kirsch_tensor(p, (75, 18), 3.0, 30.0), REGION, scale=30.0)


def _segs(angle):
    tp = rectilinear(REGION, 0.45, angle)
    a = np.concatenate([p.points[:-1] for p in tp.paths])
    b = np.concatenate([p.points[1:] for p in tp.paths])
    return a, b, np.full(len(a), 0.45), _alignment(FIELD, a, b)


def test_close_up_draws_thin_lines_coloured_by_alignment():
    svg = _detail(REGION, FIELD, _segs(45.0), _segs(0.0), 0.45)
    widths = [float(w) for w in re.findall(r'stroke-width="([0-9.]+)"', svg)]
    # every path and tick is a line of at most 1.5 px (beads at this zoom would be 7 px): the pitch
    # (0.45 mm, about 7 px here) leaves visible gaps between neighbouring paths
    assert widths and max(widths) <= 1.5
    px_per_mm = (960 // 2 - 6 - 8) / max(25 * 0.45, 0.2 * 150)  # each panel spans 30 mm here
    assert 0.45 * px_per_mm > 4 * max(widths)
    # the slicer's 45-degree lines and the aligned lines get different colours (alignment 0.71 vs 1)
    colours = set(re.findall(r'stroke="(#[0-9a-f]{6})"', svg))
    assert len(colours) >= 3  # grey ticks + two alignment levels at least
    assert "grey ticks: the principal stress direction" in svg
    assert svg.count("<clipPath") == 2


def _dense(region, angle=0.0):
    tp = rectilinear(region, 0.45, angle)
    a = np.concatenate([p.points[:-1] for p in tp.paths])
    b = np.concatenate([p.points[1:] for p in tp.paths])
    return a, b, np.full(len(a), 0.45)


def _close_up_draws_material(region, field):
    """The close-up of ``region`` shows paths and stress ticks (its window is not inside a hole)."""
    a, b, w = _dense(region)
    cos = _alignment(field, a, b)
    svg = _detail(region, field, (a, b, w, cos), (a, b, w, cos), 0.45)
    # each panel draws its paths (coloured) and the field's grey ticks: a window inside a hole,
    # or outside the part, drew neither (and crashed with "arange: cannot compute length")
    assert svg.count('stroke="#8c8c8c"') == 2
    return svg


def test_close_up_of_a_cut_out_larger_than_the_window():
    # a shelf bracket with a 50 mm lightening cut-out: the window (30 x 21 mm) fits inside the hole
    plate = box(0, 0, 150, 100).difference(Point(60, 50).buffer(25, quad_segs=32))
    field = AnalyticField(lambda p: kirsch_tensor(p, (60, 50), 25.0, 30.0), plate, scale=30.0)
    _close_up_draws_material(plate, field)


def test_close_up_without_a_hole_and_with_several_islands():
    bar = box(0, 0, 150, 36)
    uniform = AnalyticField(lambda p: kirsch_tensor(p, (500, 500), 0.1, 30.0), bar, scale=30.0)
    _close_up_draws_material(bar, uniform)
    # two thin islands far apart: the middle of the bounds is empty, the grid away from the ends
    # misses both strips
    two = box(0, 0, 150, 3).union(box(0, 97, 150, 100))
    f2 = AnalyticField(lambda p: kirsch_tensor(p, (500, 500), 0.1, 30.0), two, scale=30.0)
    _close_up_draws_material(two, f2)
