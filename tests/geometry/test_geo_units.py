"""The building blocks on constructed input: chains and loop snapping, walls, pitch, grouping."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st
from loadpath.geometry import estimate_pitch, group_regions, region_difference
from loadpath.geometry.ops import bead_union, chains, clean
from loadpath.geometry.walls import walls
from shapely import box


def loop(x0, y0, x1, y1, gap=0.0):
    """A rectangle loop as segments, counter-clockwise from (x0, y0), the last one shortened by ``gap``."""
    p = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1], [x0, y0 + gap]])
    return p[:-1, 0], p[:-1, 1], p[1:, 0], p[1:, 1]


def cat(*loops):
    return tuple(np.concatenate(parts) for parts in zip(*loops, strict=True))


def test_loop_with_a_clipped_seam_is_closed():
    # PrusaSlicer clips 0.15 x nozzle = 0.06 mm off every loop; it is still one closed wall
    x0, y0, x1, y1 = loop(0, 0, 10, 5, gap=0.06)
    ch = chains(x0, y0, x1, y1, np.full(4, 0.45))
    assert ch.count == 1 and ch.closed.all() and ch.uniform.all()
    band = bead_union(x0, y0, x1, y1, np.full(4, 0.225))
    assert len(band.interiors) == 1
    # a closed ring with mitre joins: exactly the annulus between the offsets +-w/2
    assert band.area == pytest.approx(10.45 * 5.45 - 9.55 * 4.55, rel=1e-9)
    # an end gap wider than a bead is an open wall
    x0, y0, x1, y1 = loop(0, 0, 10, 5, gap=0.6)
    assert not chains(x0, y0, x1, y1, np.full(4, 0.45)).closed.any()


def test_variable_width_chain_is_buffered_segment_by_segment():
    x0, y0, x1, y1 = np.array([0.0, 5.0]), np.array([0.0, 0.0]), np.array([5.0, 10.0]), np.array([0.0, 0.0])
    half = np.array([0.2, 0.4])
    ch = chains(x0, y0, x1, y1, 2 * half)
    assert not ch.uniform.any()
    area = bead_union(x0, y0, x1, y1, half).area
    # two stadiums (discs approximated with 4 segments a quarter) overlapping at x = 5
    assert area == pytest.approx(5 * 0.4 + 5 * 0.8 + 0.5 * math.pi * (0.2**2 + 0.4**2) + 0.2 * 0.4 * 0.5,
                                 rel=0.05)


def test_bridged_chain_keeps_every_line_start():
    # two parallel lines joined across a 0.4 mm travel: the polyline must visit both ends of each line
    x0, y0, x1, y1 = np.array([0.0, 10.0]), np.array([0.0, 0.4]), np.array([10.0, 0.0]), np.array([0.0, 0.4])
    plain = bead_union(x0, y0, x1, y1, np.full(2, 0.2))
    bridged = bead_union(x0, y0, x1, y1, np.full(2, 0.2), bridge=0.5)
    assert bridged.area == pytest.approx(plain.area, rel=0.05)
    assert bridged.area < 10.5 * 0.8  # no diagonal shortcut across the rectangle


def _walls(loops, external, inside=()):
    x0, y0, x1, y1 = cat(*loops)
    n = len(x0)
    ext = np.concatenate([np.full(len(lp[0]), e) for lp, e in zip(loops, external, strict=True)])
    pts = np.array(inside, dtype=float).reshape(-1, 2)
    return walls(x0, y0, x1, y1, np.full(n, 0.45), np.full(n, 0.407), ext, pts[:, 0], pts[:, 1])


def test_plate_with_hole():
    w = 0.45
    outer = [loop(w / 2, w / 2, 20 - w / 2, 10 - w / 2, 0.06),
             loop(0.632, 0.632, 20 - 0.632, 10 - 0.632, 0.06)]
    hole = [loop(8 - w / 2, 3 - w / 2, 12 + w / 2, 7 + w / 2, 0.06),
            loop(8 - 0.632, 3 - 0.632, 12 + 0.632, 7 + 0.632, 0.06)]
    res = _walls(outer + hole, [True, False, True, False], inside=[(2, 2)])
    assert res.outline.area == pytest.approx(200 - 16, rel=1e-6)
    assert len(res.outline.interiors) == 1
    t = 0.632 + 0.407 / 2
    assert res.domain.area == pytest.approx((20 - 2 * t) * (10 - 2 * t) - (4 + 2 * t) ** 2, rel=1e-3)


def test_washer_without_infill_keeps_its_hole():
    # the walls fill the whole ring (0.85 mm wide, two 0.45 mm beads): no infill marks the inside, and
    # the hole is still air (external walls)
    w = 0.45
    outer = loop(w / 2, w / 2, 4 - w / 2, 4 - w / 2)
    loops = [outer, loop(0.85 - w / 2, 0.85 - w / 2, 3.15 + w / 2, 3.15 + w / 2)]
    res = _walls(loops, [True, True])
    assert len(res.outline.interiors) == 1
    assert res.outline.area == pytest.approx(16 - 2.3**2, rel=1e-6)
    assert res.domain.is_empty
    # a slit of 0.06 mm between two loops that nearly touch is no hole either
    loops = [outer, loop(0.96 - w / 2, 0.96 - w / 2, 3.04 + w / 2, 3.04 + w / 2)]
    res = _walls(loops, [True, True])
    assert len(res.outline.interiors) == 1 and res.outline.area == pytest.approx(16 - 2.08**2, rel=1e-6)


def test_empty_domain_bounded_by_inner_walls_is_part():
    # a domain that received no infill (inner walls around it) is inside the part, not a hole
    w = 0.45
    loops = [loop(w / 2, w / 2, 6 - w / 2, 6 - w / 2), loop(0.632, 0.632, 6 - 0.632, 6 - 0.632)]
    res = _walls(loops, [True, False])
    assert len(res.outline.interiors) == 0 and res.outline.area == pytest.approx(36, rel=1e-6)


def test_island_inside_a_hole():
    w = 0.45
    # a 30 mm square with a 20 mm square hole, and a 10 mm square island standing in the hole
    loops = [loop(w / 2, w / 2, 30 - w / 2, 30 - w / 2), loop(5 - w / 2, 5 - w / 2, 25 + w / 2, 25 + w / 2),
             loop(10 + w / 2, 10 + w / 2, 20 - w / 2, 20 - w / 2)]
    res = _walls(loops, [True, True, True], inside=[(2.5, 15), (15, 15)])
    polys = list(getattr(res.outline, "geoms", [res.outline]))
    assert sorted(round(p.area, 6) for p in polys) == [100.0, 900.0 - 400.0]


@given(pitch=st.floats(0.3, 6.0), angle=st.floats(0.0, 179.0), width=st.floats(0.3, 0.6))
@settings(max_examples=40, deadline=None)
def test_pitch_of_parallel_lines(pitch, angle, width):
    n = 15
    t = math.radians(angle)
    d = np.array([math.cos(t), math.sin(t)])
    nrm = np.array([-d[1], d[0]])
    k = np.arange(n)
    a = nrm * (k[:, None] * pitch) - 20 * d
    b = nrm * (k[:, None] * pitch) + 20 * d
    a[1::2], b[1::2] = b[1::2].copy(), a[1::2].copy()  # zigzag order
    est = estimate_pitch(a[:, 0], a[:, 1], b[:, 0], b[:, 1], min(width, pitch))
    assert est.pitch == pytest.approx(pitch, rel=1e-6)
    assert (est.angle - angle + 90) % 180 - 90 == pytest.approx(0, abs=0.05)


def test_pitch_of_a_grid_and_of_curves():
    xs = np.arange(0, 20, 2.0)
    x0 = np.r_[xs, np.zeros(10)]
    y0 = np.r_[np.zeros(10), xs]
    x1 = np.r_[xs, np.full(10, 20.0)]
    y1 = np.r_[np.full(10, 20.0), xs]
    est = estimate_pitch(x0, y0, x1, y1, 0.4)
    assert len(est.directions) == 2 and all(p == pytest.approx(2.0) for _, p, _ in est.directions)
    # a circle of short chords has no straight family
    a = np.linspace(0, 2 * np.pi, 200)
    c = np.c_[np.cos(a), np.sin(a)] * 10
    est = estimate_pitch(c[:-1, 0], c[:-1, 1], c[1:, 0], c[1:, 1], 0.4)
    assert not est.found


def test_pitch_of_staircases_counts_only_lines_alongside():
    # OrcaSlicer's crosshatch: parallel steps 0.7 mm apart across their direction but 2 mm apart along
    # it; two such staircases 3 mm apart are the fill's neighbouring lines
    i = np.arange(10)
    x0 = np.r_[4.0 * i, 4.0 * i]
    x1 = x0 + 2.0
    y0 = np.r_[0.7 * i, 0.7 * i + 3.0]
    est = estimate_pitch(x0, y0, x1, y0, 0.4)
    assert est.pitch == pytest.approx(3.0)
    # a single staircase has no neighbouring lines
    assert not estimate_pitch(x0[:10], y0[:10], x1[:10], y0[:10], 0.4).found


def test_group_regions_tolerance():
    a = box(0, 0, 150, 36).difference(shapely.Point(75, 18).buffer(3))
    nudged = shapely.affinity.translate(a, 0.001, 0.0)  # G-code rounding
    moved = shapely.affinity.translate(a, 0.5, 0.0)
    assert region_difference(a, nudged) < 0.02 < region_difference(a, moved)
    assert group_regions([a, nudged, moved, a]) == [0, 0, 1, 0]
    assert group_regions([a, a], keys=[0.2, 0.3]) == [0, 1]
    assert clean(box(0, 0, 10, 0.05)).is_empty  # a sliver goes
