"""Reused paths are cut to each layer's own region (clip_to)."""

from __future__ import annotations

import numpy as np
from loadpath.pipeline.paths import clip_to
from loadpath.toolpath import Path
from shapely.geometry import Point, box


def test_paths_are_cut_where_a_layer_region_lacks_a_sliver():
    region = box(0, 0, 20, 6).difference(Point(10, 3).buffer(1.0))
    inside = Path(np.array([[1.0, 0.5], [19.0, 0.5]]), np.array([0.4, 0.4]))
    across = Path(
        np.array([[1.0, 3.0], [9.0, 3.0], [11.0, 3.0], [19.0, 3.0]]), np.array([0.3, 0.4, 0.5, 0.6])
    )
    stub = Path(np.array([[10.0, 1.5], [10.0, 2.5]]), np.array([0.4, 0.4]))
    out = clip_to([inside, across, stub], region, min_length=0.8)
    assert out[0] is inside  # untouched
    cut = out[1:]
    # the path across the hole becomes two pieces ending on its rim; the stub's inside piece is short
    assert len(cut) == 2
    for p in cut:
        assert region.buffer(1e-9).contains(Point(p.points[0])) and region.buffer(1e-9).contains(
            Point(p.points[-1])
        )
        assert np.all(np.abs(p.points[:, 1] - 3.0) < 1e-9)
    left, right = sorted(cut, key=lambda p: p.points[0, 0])
    assert np.isclose(left.points[-1, 0], 9.0) and np.isclose(right.points[0, 0], 11.0)
    # widths come from the nearest old vertex
    assert np.allclose(left.pitch, [0.3, 0.4]) and np.allclose(right.pitch, [0.5, 0.6])
