"""Faithful mode (the thesis's algorithm) and the termination of gap filling in both modes."""

from __future__ import annotations

import time

import numpy as np
import pytest
from loadpath import metrics as M
from loadpath.engines.streamlines import generate, resolve_params
from loadpath.engines.streamlines._lines import Lines
from loadpath.engines.streamlines.density import Selected, circumcircles, thesis_density_control
from loadpath.engines.streamlines.directions import DirectionGrid
from loadpath.engines.streamlines.gapfill import Raster, fill_rounds, thesis_gap_fill
from loadpath.engines.streamlines.integrate import TraceSettings
from loadpath.errors import SettingsError
from loadpath.fea.field import FEStressField
from loadpath.field import AnalyticField, kirsch_tensor
from loadpath.toolpath import EngineInput
from scipy.spatial import Delaunay
from shapely import contains_xy
from shapely.geometry import Point, box
from sl_fields import PITCH, open_hole

W, GP = 0.5, -0.05


def _dead_centre(length=16.0, width=8.0):
    """Uniform tension except a stress-free disc in the middle (no direction there)."""
    region = box(0, 0, length, width)
    c = np.array([length / 2, width / 2])

    def f(p):
        t = np.tile([10.0, 0.0, 0.0], (len(p), 1))
        t[np.linalg.norm(p - c, axis=1) < 2.5] = 0.0
        return t

    return region, AnalyticField(f, region, scale=10.0)


def test_faithful_mode_follows_the_thesis():
    region, field = open_hole(20, 8, 2)
    tp = generate(EngineInput(region=region, field=field, pitch=PITCH), mode="faithful")
    p = tp.stats["params"]
    assert (p["w"], p["G_p"], p["step"], p["method"], p["principal"]) == (W, GP, 0.3, "euler", "tensile")
    assert tp.stats["seeds"] == round(0.2 * region.area, -1) or abs(tp.stats["seeds"] - 0.2 * region.area) < 3
    for path in tp.paths:
        np.testing.assert_array_equal(path.pitch, W)  # constant w x h beads
        steps = np.linalg.norm(np.diff(path.points, axis=0), axis=1)
        assert np.all(steps <= 0.3 + 1e-9)
    assert M.crossings(tp) == 0
    cont = [q for q in tp.paths if q.kind == "continuous"]
    fill = [q for q in tp.paths if q.kind == "fill"]
    assert cont and fill
    assert tp.stats["gap_fill"]["stopped"] == 0  # ended because no gap was left, not by the bound
    cov = M.coverage(tp, region)
    assert 0.75 < cov.coverage < 0.97, cov  # the thesis's band (87-90 % on its plates)


def test_continuous_filaments_satisfy_eq_4_5():
    """No Delaunay triangle between two kept continuous filaments has D < w + G_p (inside the part)."""
    region, field = open_hole(20, 8, 2)
    tp = generate(EngineInput(region=region, field=field, pitch=PITCH), mode="faithful", gap_fill=False)
    assert all(q.kind == "continuous" for q in tp.paths)
    lines = Lines.from_list([q.points for q in tp.paths])
    tri = Delaunay(lines.points).simplices
    owner = lines.vertex_line[tri]
    mixed = ~np.all(owner == owner[:, :1], axis=1)
    centre, r = circumcircles(*(lines.points[tri[mixed, k]] for k in range(3)))
    inside = contains_xy(region, centre[:, 0], centre[:, 1])
    assert np.all(2 * r[inside] >= W + GP - 1e-9)


def test_faithful_takes_the_callers_seeds():
    region, field = open_hole(20, 8, 2)
    seeds = np.array([[1.0, y] for y in np.arange(0.5, 8, 0.5)])
    inp = EngineInput(region=region, field=field, pitch=PITCH)
    tp = generate(inp, mode="faithful", seeds=seeds, gap_fill=False)
    assert tp.stats["seeds"] == len(seeds)
    assert 0 < len(tp.paths) <= len(seeds)


def test_thesis_density_control_removes_whole_neighbours():
    """Three parallel lines 0.3 mm apart and one 1 mm away: the middle ones go, whole."""
    ys = [0.0, 0.3, 0.6, 1.6]
    x = np.arange(0, 10.01, 0.3)
    lines = Lines.from_list([np.stack([x, np.full_like(x, y)], axis=1) for y in ys])
    region = box(-1, -1, 11, 3)
    chosen, stats = thesis_density_control(lines, region, W + GP, lambda p: np.ones(len(p), bool))
    assert chosen.tolist() == [True, False, True, True]
    assert stats["removed"] == 1 and stats["chosen"] == 3


def test_thesis_gap_fill_terminates_where_seeds_give_nothing():
    """Largest empty circle in a stress-free zone: its streamline is empty, the circle is remembered."""
    region, field = _dead_centre(8.0, 8.0)
    grid = DirectionGrid(field, region, 0.3)
    settings = TraceSettings(0.3, "euler", np.pi / 2, 100.0, W + GP, 0.5 * (W + GP))
    x = np.arange(0, 8.01, 0.3)
    fil = Lines.from_list([np.stack([x, np.full_like(x, y)], axis=1) for y in (0.25, 7.75)])
    t = time.process_time()
    pieces, stats = thesis_gap_fill(
        region, grid, fil, settings, spacing=W + GP, gap_diameter=W, max_iterations=5000
    )
    assert stats["stopped"] == 0 and stats["iterations"] < 5000
    assert time.process_time() - t < 60
    assert pieces  # the live part is filled
    for p in pieces:  # nothing was placed in the dead zone
        assert np.all(np.linalg.norm(p - [4.0, 4.0], axis=1) > 2.0)


def test_thesis_gap_fill_stops_at_its_bound():
    region, field = _dead_centre()
    grid = DirectionGrid(field, region, 0.3)
    settings = TraceSettings(0.3, "euler", np.pi / 2, 100.0, W + GP, 0.5 * (W + GP))
    _, stats = thesis_gap_fill(
        region, grid, Lines.from_list([]), settings, spacing=W + GP, gap_diameter=W, max_iterations=7
    )
    assert stats["iterations"] == 7 and stats["stopped"] == 1


def _default_fill(region, field, **over):
    params = resolve_params("default", PITCH, **over)
    grid = DirectionGrid(field, region, 0.5)
    d = params.min_spacing
    settings = TraceSettings(params.step, "rk2", params.max_turn, 100.0, d, d)
    z = np.zeros(0, dtype=np.int64)
    empty = Selected(Lines.from_list([]), np.zeros(0, dtype=bool), z, z, z)
    return params, fill_rounds(
        region,
        grid,
        [empty],
        settings,
        min_spacing=params.min_spacing,
        fill_spacing=params.fill_spacing,
        min_length=params.min_length,
        seed_cell=10 * PITCH,
        seed_across=1.5 * PITCH,
        max_waves=params.max_waves,
        raster=Raster(region, params.min_spacing / 2),
    )


def test_default_gap_rounds_terminate_on_adversarial_inputs():
    # nothing can be kept: every streamline is shorter than the minimum length
    region, field = _dead_centre(6.0, 6.0)
    params, (added, rounds) = _default_fill(region, field, min_length=50.0)
    assert added == [] and len(rounds) <= params.max_waves
    # a stress-free zone in the middle: its cells are exhausted, the rest is filled
    region, field = _dead_centre()
    params, (added, rounds) = _default_fill(region, field)
    assert 0 < len(rounds) <= params.max_waves
    assert sum(len(s.lines) for s in added) > 0


def test_default_mode_on_a_stress_free_part_returns_nothing_quickly():
    region = box(0, 0, 20, 10)
    field = AnalyticField(lambda p: np.zeros((len(p), 3)), region)
    t = time.process_time()
    tp = generate(EngineInput(region=region, field=field, pitch=PITCH))
    assert tp.paths == () and time.process_time() - t < 5


def test_faithful_principal_is_the_tensile_one():
    """Compression dominates: max_abs runs along y, the thesis's S1 (tensile) along x."""
    region = box(0, 0, 6, 6)
    field = AnalyticField(lambda p: np.tile([1.0, -5.0, 0.0], (len(p), 1)), region, scale=5.0)
    tp = generate(EngineInput(region=region, field=field, pitch=PITCH), mode="faithful", gap_fill=False)
    d = np.concatenate([np.diff(p.points, axis=0) for p in tp.paths])
    assert np.all(np.abs(d[:, 1]) < 1e-9)
    default = generate(EngineInput(region=region, field=field, pitch=PITCH))
    d = np.concatenate([np.diff(p.points, axis=0) for p in default.paths])
    # along y (bead cells move the vertices next to the outline a little)
    assert np.sum(np.abs(d[:, 1])) > 0.99 * np.sum(np.linalg.norm(d, axis=1))


def test_kirsch_reference_is_the_field_we_think():
    """Guard: sigma_tt = 3 S beside the hole, so the faithful tests run on a real concentration."""
    t = kirsch_tensor(np.array([[10.0, 6.0]]), (10.0, 4.0), 2.0, 10.0)
    assert abs(t[0, 0] - 30.0) < 1e-9
    assert Point(10, 4).buffer(2).area > 0



def test_faithful_seeds_at_element_centroids_of_an_fe_field():
    """The thesis seeds at the FE element centroids (Sec. 4.2): one streamline per element."""
    region = box(0, 0, 6, 4)
    xs, ys = np.meshgrid(np.linspace(0, 6, 7), np.linspace(0, 4, 5))
    pts = np.stack([xs.ravel(), ys.ravel()], axis=1)
    tri = Delaunay(pts).simplices
    field = FEStressField(pts[tri], np.tile([10.0, 0.0, 0.0], (len(tri), 3, 1)), 10.0)
    tp = generate(EngineInput(region=region, field=field, pitch=PITCH), mode="faithful", seeding="centroids")
    assert tp.stats["seeds"] == len(tri)
    region2, f2 = open_hole(20, 8, 2)
    with pytest.raises(SettingsError, match="finite-element"):
        generate(EngineInput(region=region2, field=f2, pitch=PITCH), mode="faithful", seeding="centroids")
