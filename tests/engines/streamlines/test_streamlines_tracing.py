"""Tracing through sign-less fields: sign flips, jumps, degenerate points, holes near holes."""

from __future__ import annotations

import numpy as np
import shapely
from loadpath import metrics as M
from loadpath.engines.streamlines import generate, resolve_params
from loadpath.engines.streamlines.directions import DirectionGrid
from loadpath.engines.streamlines.integrate import (
    END_BOUNDARY,
    END_DEGENERATE,
    END_SPACING,
    END_TURN,
    TraceSettings,
    trace,
)
from loadpath.engines.streamlines.segindex import SegmentIndex
from loadpath.field import AnalyticField, principal_stresses
from loadpath.toolpath import EngineInput
from shapely.geometry import LineString, box
from sl_fields import (
    PITCH,
    RandomSignField,
    bending,
    exact_min_spacing,
    open_hole,
    radial,
    turning_angles,
    two_close_holes,
    vertical_flipping,
)

SETTINGS = TraceSettings(step=0.6, method="rk2", max_turn=np.radians(35), max_length=200.0,
                         clearance=0.315, loop_radius=0.315)


def test_flipping_field_really_flips_its_direction_vectors():
    """Guard of the next test: the field's own direction vectors alternate in sign."""
    pts = np.array([[0.1, 1.0], [0.5, 1.0]])
    _, _, e1, _ = principal_stresses(vertical_flipping()(pts))
    assert e1[0, 1] * e1[1, 1] < 0  # (0, +1) next to (0, -1)


def test_tracing_through_a_field_whose_sign_flips():
    """Vertical tension with alternating shear sign: straight vertical lines, boundary to boundary.

    Interpolating the direction components (the thesis's scatteredInterpolant on u and v) would
    average (0, 1) and (0, -1) to zero between the columns and stop every streamline there.
    """
    region = box(0, 0, 6, 10)
    grid = DirectionGrid(AnalyticField(vertical_flipping(), region, scale=10.0), region, 0.3)
    seeds = np.array([[x, 5.0] for x in np.arange(0.3, 6, 0.45)])
    tr = trace(seeds, grid, SETTINGS)
    assert len(tr.lines) == len(seeds)
    assert np.all(tr.end_start == END_BOUNDARY) and np.all(tr.end_finish == END_BOUNDARY)
    for i in range(len(tr.lines)):
        ln = tr.lines.line(i)
        assert abs(ln[0, 1] - ln[-1, 1]) > 10 - 1e-3  # full height, both ends on the boundary
        assert np.ptp(ln[:, 0]) < 0.05  # straight up (the tiny shear tilts it by ~eps/2 rad)


def test_random_direction_signs_change_nothing():
    """The engine sees only sign-less information: flipping every sample's sign gives the same paths."""
    region, field = open_hole()
    a = generate(EngineInput(region=region, field=field, pitch=PITCH))
    b = generate(EngineInput(region=region, field=RandomSignField(field, seed=3), pitch=PITCH))
    assert len(a.paths) == len(b.paths)
    for p, q in zip(a.paths, b.paths, strict=True):
        np.testing.assert_allclose(p.points, q.points, atol=1e-9)


def test_streamlines_stop_at_a_jump_of_the_followed_stress():
    """max_abs turns by 90 degrees across a bent beam's neutral axis: paths end there, never bend."""
    region = box(0, 0, 30, 10)
    field = AnalyticField(bending(10, 30), region, scale=1.0)
    tp = generate(EngineInput(region=region, field=field, pitch=PITCH))
    axis = LineString([(0, 5), (30, 5)])
    params = resolve_params("default", PITCH)
    for p in tp.paths:
        # the jump is found on the direction grid (0.5 mm), so a path may end a little past the
        # exact axis, but none goes through: no path has points on both sides of the band
        y = p.points[:, 1]
        assert not (y.min() < 4.5 and y.max() > 5.5)
        assert np.all(turning_angles(p.points) <= params.max_turn_deg + 1e-6)
    # with the tensile stress there is no jump: trajectories cross the axis at 45 degrees
    tens = generate(EngineInput(region=region, field=field.with_principal("tensile"), pitch=PITCH))
    assert sum(LineString(p.points).crosses(axis) for p in tens.paths) > 10


def test_trace_ends_at_the_edge_of_an_undefined_zone_and_at_the_turn_limit():
    region = box(0, 0, 20, 10)
    grid = DirectionGrid(AnalyticField(radial((10.0, 5.0)), region, scale=10.0), region, 0.3)
    a = np.linspace(0, 2 * np.pi, 12, endpoint=False)
    seeds = np.stack([10.0 + 4 * np.cos(a), 5.0 + 4 * np.sin(a)], axis=1)
    tr = trace(seeds, grid, SETTINGS)
    ends = np.concatenate([tr.end_start, tr.end_finish])
    assert set(np.unique(ends)) <= {END_BOUNDARY, END_DEGENERATE, END_TURN}
    # every line reaches the outline; an end that does not stops near the centre
    for i in range(len(tr.lines)):
        ln = tr.lines.line(i)
        assert END_BOUNDARY in (tr.end_start[i], tr.end_finish[i])
        for tip, why in ((ln[0], tr.end_start[i]), (ln[-1], tr.end_finish[i])):
            if why != END_BOUNDARY:
                assert np.linalg.norm(tip - [10.0, 5.0]) < 1.0


def test_jobard_lefer_stop_keeps_the_clearance_exactly():
    region = box(0, 0, 20, 10)
    grid = DirectionGrid(AnalyticField(radial((-20.0, 5.0)), region, scale=10.0), region, 0.3)
    first = trace(np.array([[10.0, 5.0]]), grid, SETTINGS)
    obstacles = SegmentIndex(first.lines)
    # streamlines of a fan converge towards x < 0: seeded 0.5 mm away, they must stop
    seeds = np.array([[19.0, 5.5], [19.0, 4.5]])
    tr = trace(seeds, grid, SETTINGS, obstacles=obstacles)
    assert np.all(tr.end_finish == END_SPACING) or np.all(tr.end_start == END_SPACING)
    for i in range(len(tr.lines)):
        ln = tr.lines.line(i)
        d = obstacles.segment_distance(ln[:-1], ln[1:], 1.0)
        assert d.min() >= SETTINGS.clearance * (1 - 1e-9)
        assert d.min() < SETTINGS.clearance + 0.05  # and stops close to where it must


def test_a_hole_inside_another_holes_influence():
    region, field = two_close_holes()
    tp = generate(EngineInput(region=region, field=field, pitch=PITCH))
    params = resolve_params("default", PITCH)
    holes = [shapely.Polygon(r) for r in region.interiors]
    for p in tp.paths:
        ls = LineString(p.points)
        assert not any(ls.crosses(h) or ls.within(h) for h in holes)
    assert M.crossings(tp) == 0
    assert exact_min_spacing(tp.paths) >= params.min_spacing * (1 - 1e-9)
    # the narrow bridge between the holes (1.5 mm) is filled too
    bridge = box(14.6, 7.0, 16.0, 10.0).intersection(region)
    cov = M.coverage(tp, bridge)
    assert cov.coverage > 0.7, cov
    al = M.alignment(tp, field, PITCH, region=region)
    assert al.beta > 0.97
