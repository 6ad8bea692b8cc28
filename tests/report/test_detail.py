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
