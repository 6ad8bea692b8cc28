"""The level-set engine: paths that run edge to edge, link into zig-zags, and follow the stress.

Closed-form fields (no FEA): a uniform field, the Kirsch open hole, a cantilever in bending (whose
``max_abs`` direction jumps by 90 degrees across the neutral axis) and a density field from the
analysis' strain energy.  What a printer needs is checked on the paths themselves and after the
shared linking stage: how many runs a layer prints as (each a travel, and on PrusaSlicer a
retraction), coverage, alignment against the best straight infill.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import shapely
from loadpath import metrics as M
from loadpath.density import DensityOptions, density_field
from loadpath.engines import NAMES, Machine, generate
from loadpath.engines.levelset import GIVE_WAY, LevelSetOptions, fit
from loadpath.engines.linking import LinkOptions, link_paths, pieces
from loadpath.engines.registry import get as engine_named
from loadpath.errors import GeometryError, SettingsError
from loadpath.field import AnalyticField, kirsch_tensor
from loadpath.toolpath import EngineInput, Toolpaths
from shapely.geometry import MultiPolygon, Point, box

PITCH = 0.45


def uniform(angle_deg: float):
    c, s = np.cos(np.radians(angle_deg)), np.sin(np.radians(angle_deg))
    return lambda p: np.tile([10 * c * c, 10 * s * s, 10 * c * s], (len(p), 1))


def cantilever(height: float, length: float):
    """Clamped at x = 0, tip load at x = length: sxx = M y / I, sxy parabolic."""
    c, inertia = 0.5 * height, height**3 / 12.0

    def f(p):
        x, y = p[:, 0], p[:, 1] - c
        return np.stack([-(length - x) * y / inertia, np.zeros(len(p)), -(c * c - y * y) / (2 * inertia)], axis=1)

    return f


def open_hole(length=40.0, width=16.0, radius=3.0):
    cx, cy = length / 2, width / 2
    region = box(0, 0, length, width).difference(Point(cx, cy).buffer(radius, 64))
    return region, AnalyticField(lambda p: kirsch_tensor(p, (cx, cy), radius, 10.0), region, scale=10.0)


def _ends(tp):
    return np.array([p.points[k] for p in tp.paths for k in (0, -1)])


def _runs(tp, region, field=None):
    runs, _ = link_paths(tp.paths, region, PITCH, field=field)
    return runs


def test_registered_with_its_density_and_the_slicers_width():
    assert "levelset" in NAMES
    region = box(0, 0, 20, 10)
    tp = generate("levelset", EngineInput(region, AnalyticField(uniform(0), None), PITCH))
    assert tp.stats["residual"] < 1e-8 and tp.stats["n_paths"] == len(tp.paths) > 0


def test_uniform_field_lays_straight_lines_at_the_pitch_that_link_into_one_zigzag():
    """The slicer's rectilinear infill, turned to the stress: every path edge to edge, one run."""
    region = box(0, 0, 30, 12)
    field = AnalyticField(uniform(30.0), None)
    tp = generate("levelset", EngineInput(region, field, PITCH))
    d = np.array([np.cos(np.radians(30)), np.sin(np.radians(30))])
    for p in tp.paths:
        if np.hypot(*(p.points[-1] - p.points[0])) < 4 * PITCH:
            continue  # a corner's short path: its ends bend to the edges
        chord = p.points[-1] - p.points[0]
        assert abs(chord @ d) / np.hypot(*chord) > np.cos(np.radians(1.0))
        seg = np.diff(p.points[1:-1], axis=0)  # the end segments may bend to reach the edge
        seg = seg[np.hypot(*seg.T) > 1e-6]
        assert np.all(np.abs(seg @ d) / np.hypot(*seg.T) > np.cos(np.radians(2.0)))
    # every end on the boundary (a quarter pitch in, as the other engines' ends)
    dist = shapely.distance(region.exterior, shapely.points(_ends(tp)))
    assert np.all(dist < 0.5 * PITCH), dist.max()
    # the pitch is the nominal one, the length what that pitch lays in the region
    pitch = np.concatenate([p.pitch for p in tp.paths])
    assert np.median(pitch) == pytest.approx(PITCH, rel=0.03)
    assert tp.total_length == pytest.approx(region.area / PITCH, rel=0.03)
    runs = _runs(tp, region)
    assert len(runs) <= 2, len(runs)
    cov = M.coverage(tp, region)
    assert cov.coverage >= 0.97 and cov.overlap <= 0.03, cov


@pytest.mark.parametrize("angle", [0.0, 7.0])
def test_lines_across_a_narrow_strip_are_as_wide_at_their_ends_as_in_their_middles(angle):
    """Issue 19 (a 2.4 mm wall at 100 %): the lines cross the strip and end side by side on its
    edges, so ends are most of their length.  Each end's width was 1.8-1.9x its middle's (the normal
    at an end passes just beyond the neighbour's end: ``widths._end_sides``), and the strip's
    blocks extruded more than the slicer's plastic allowed and were kept as sliced."""
    region = box(0, 0, 2.4, 28.0)
    tp = generate("levelset", EngineInput(region, AnalyticField(uniform(angle), region, scale=10.0), 0.414))
    assert len(tp.paths) > 50
    ends = np.concatenate([[p.pitch[0], p.pitch[-1]] for p in tp.paths])
    middles = np.concatenate([p.pitch[1:-1] for p in tp.paths])
    assert np.median(ends) < 1.1 * np.median(middles), (np.median(ends), np.median(middles))
    assert sum(p.area for p in tp.paths) < region.area  # the lines stop at the inset: less than the whole strip


def test_sparse_line_ends_keep_the_slicers_gap_to_the_perimeter_not_a_share_of_the_pitch():
    """Sparse lines (the slicer's bead width at a 2 mm pitch) end a quarter bead width inside the
    region, where PrusaSlicer's own infill ends (0.10 mm at a 0.41 mm flow width), at any pitch."""
    region = box(0, 0, 30, 12)
    field = AnalyticField(uniform(30.0), None)
    width, pitch = 0.4, 2.0
    tp = generate("levelset", EngineInput(region, field, pitch), flow_width=width)
    dist = shapely.distance(region.exterior, shapely.points(_ends(tp)))
    long = np.array([np.hypot(*(p.points[-1] - p.points[0])) >= 4 * pitch for p in tp.paths for _ in (0, 1)])
    assert long.sum() >= 10
    # a quarter of the bead width (0.1 mm) and the sampling of the extension (a ninth of the pitch)
    assert np.all(dist[long] <= 0.25 * width + pitch / 9.0 + 1e-6), dist[long].max()
    assert np.median(dist[long]) <= 0.25 * width + 0.05, np.median(dist[long])
    assert np.all(dist >= 0.25 * width - 1e-6), dist.min()


def test_open_hole_follows_the_stress_better_than_any_straight_infill_and_prints_as_few_runs():
    region, field = open_hole()
    tp = generate("levelset", EngineInput(region, field, PITCH))
    ours = M.alignment(tp, field, PITCH, region=region)
    _, best = M.best_rectilinear(region, field, PITCH)
    assert ours.beta_curved > best.beta_curved + 0.02, (ours.beta_curved, best.beta_curved)
    cov = M.coverage(tp, region)
    assert cov.coverage >= 0.97 and cov.overlap <= 0.04, cov
    # nearly every path ends on the outline or the hole: few interior ends to pay a travel for
    dist = shapely.distance(region.boundary, shapely.points(_ends(tp)))
    assert np.mean(dist < 1.0 * PITCH) >= 0.9, np.mean(dist < PITCH)
    runs = _runs(tp, region, field)
    # a rectilinear slicer lays this plate (hole in the middle) as a handful of zig-zags
    assert len(runs) <= 12, len(runs)


def test_a_jump_of_the_followed_stress_cuts_the_fit_and_no_path_runs_along_it():
    """Bending, max_abs: the followed direction turns 90 degrees at the neutral axis."""
    region = box(0, 0, 30, 10)
    field = AnalyticField(cantilever(10, 30), region, scale=1.0)
    inp = EngineInput(region, field, PITCH)
    f = fit(inp, LevelSetOptions())
    assert not f.cut.is_empty
    # the cut lies along the neutral axis
    assert abs(f.cut.centroid.y - 5.0) < 0.5 and f.cut.bounds[2] - f.cut.bounds[0] > 20
    tp = generate("levelset", inp)
    for p in tp.paths:
        assert not shapely.LineString(p.points).crosses(shapely.LineString([(2, 5), (28, 5)])) or (
            np.ptp(p.points[:, 1]) > 1.0
        )
    cov = M.coverage(tp, region)
    assert cov.coverage >= 0.95, cov
    al = M.alignment(tp, field, PITCH, region=region)
    assert al.beta >= 0.95, al


def fading_pull(length: float, fade: float, across: float):
    """A pull along x that fades to nothing over the last ``fade`` mm before x = ``length`` (the end
    face of a grip zone), over a steady stress ``across`` along y: the larger principal stress turns
    from x to y where the pull falls below ``across``."""

    def f(p):
        sxx = 10.0 * np.clip((length - p[:, 0]) / fade, 0.0, 1.0)
        return np.stack([sxx, np.full(len(p), across), np.zeros(len(p))], axis=1)

    return f


@pytest.mark.parametrize("kind", ["solid", "sparse"])
def test_a_jump_in_the_edges_skin_is_not_cut_and_the_level_sets_run_to_the_edge(kind):
    """Where the pull fades at an end face, max_abs turns along the face in its last 0.8 mm.  Cut
    there, the level sets ended up to a millimetre short of the face and their links left a void
    beside it, where ``loadpath compare`` put the first ply's failure (0.26x the slicer's on a
    100-layer specimen pulled through its grip zone)."""
    region = box(0, 0, 30, 10)
    inp = EngineInput(region, AnalyticField(fading_pull(30.0, 2.0, 4.0), region, scale=10.0), PITCH)
    machine = Machine(flow_width=0.45) if kind == "sparse" else None
    assert fit(inp, LevelSetOptions()).cut.is_empty
    tp = generate("levelset", inp, **({"machine": machine} if machine else {}))
    assert tp.band is None
    right = _ends(tp)[:, 0].max()
    assert right > 30.0 - 0.25, right  # the ends keep the engine's gap to the edge, no more
    # the same turn three millimetres deep is a jump of the part's own: cut
    deep = EngineInput(region, AnalyticField(fading_pull(30.0, 7.5, 4.0), region, scale=10.0), PITCH)
    f = fit(deep, LevelSetOptions())
    assert not f.cut.is_empty and f.cut.bounds[0] > 24.0 and f.cut.bounds[2] < 28.0, f.cut.bounds
    # a narrow part (inradius 0.9 mm, under twice the skin) keeps its cut where it lies
    strip = box(0, 0, 30, 1.8)
    narrow = EngineInput(strip, AnalyticField(fading_pull(30.0, 2.0, 4.0), strip, scale=10.0), PITCH)
    assert not fit(narrow, LevelSetOptions()).cut.is_empty


def test_solid_infill_cut_along_its_length_gives_way_when_asked_sparse_and_an_open_hole_do_not():
    """Option ``give_way``: the pipeline then lays such solid infill with the swarm (issue 19)."""
    region = box(0, 0, 30, 10)
    beam = EngineInput(region, AnalyticField(cantilever(10, 30), region, scale=1.0), PITCH)
    asked = generate("levelset", beam, give_way=True)
    # the neutral axis runs the length of the part: about 30 mm against sqrt(300) = 17 mm
    assert asked.paths == () and asked.stats["give_way"] is True, asked.stats
    assert asked.stats["cut_mm"] > GIVE_WAY * np.sqrt(region.area) + 5.0
    # not asked (the engine named): the level sets, cut
    named = generate("levelset", beam)
    assert named.paths and named.stats["give_way"] is False and named.stats["cut_mm"] > 20.0
    # sparse infill (the slicer's bead width) keeps its level sets whatever the cut
    sparse = generate("levelset", beam, machine=Machine(flow_width=0.45), give_way=True)
    assert sparse.paths and sparse.stats["give_way"] is False and sparse.stats["cut_mm"] > 20.0
    # around the open hole the pull meets the hoop compression in short cuts: kept
    region2, field2 = open_hole()
    hole = generate("levelset", EngineInput(region2, field2, PITCH), give_way=True)
    assert hole.paths and hole.stats["give_way"] is False
    assert 0.0 < hole.stats["cut_mm"] < 0.75 * GIVE_WAY * np.sqrt(region2.area), hole.stats


def test_density_field_sets_where_the_lines_go_at_the_total_the_pitch_lays():
    region = box(0, 0, 40, 12)
    field = AnalyticField(cantilever(12, 40), region, scale=1.0)
    slicer_pitch, width = 2.0, 0.45
    df = density_field(field, region, width, slicer_pitch, DensityOptions())
    tp = generate("levelset", EngineInput(region, field, slicer_pitch, density=df), flow_width=width)
    assert "zones" not in tp.stats  # one fit over the whole region, no zones and no seams
    # the lines and the links the linking will print along the edge lay what the pitch lays
    links = tp.stats["edge_links_mm"]
    assert 0 < links < 0.3 * tp.total_length
    assert tp.total_length + links == pytest.approx(region.area / slicer_pitch, rel=0.05)
    # more line per area where the field is denser: the clamped end against the tip
    def length_in(geom):
        return sum(shapely.LineString(p.points).intersection(geom).length for p in tp.paths)

    root, tip = box(0, 0, 10, 12), box(30, 0, 40, 12)
    rho = df.sample(np.array([[5.0, 6.0], [35.0, 6.0]]))
    assert rho[0] > rho[1]
    assert length_in(root) > 1.3 * length_in(tip)


def test_sparse_lines_leave_the_slicers_plastic_for_the_links_along_the_edge():
    """Sparse infill (the slicer's bead width): the links the linking stage prints between the
    lines' ends along the edge are plastic too, so the lines are laid shorter by about their length,
    and the linked runs come out near the slicer's length.  Solid infill counts none (its flow
    follows its pitch)."""
    region = box(0, 0, 40, 16)
    field = AnalyticField(uniform(60.0), None)
    width, pitch = 0.45, 2.0
    tp = generate("levelset", EngineInput(region, field, pitch), flow_width=width)
    target = region.area / pitch
    links = tp.stats["edge_links_mm"]
    assert links > 0.03 * target
    assert tp.total_length + links == pytest.approx(target, rel=0.01)
    runs, _ = link_paths(tp.paths, region, pitch, LinkOptions().for_bead(width, pitch))
    linked = sum(r.length for r in runs)
    assert len(runs) < len(tp.paths) / 3
    # lines alone at the target would have come out 1 + links / target (here about 1.15) long
    assert linked == pytest.approx(target, rel=0.03)
    solid = generate("levelset", EngineInput(region, field, PITCH))
    assert solid.stats["edge_links_mm"] == 0.0


def test_phase_half_lays_the_paths_between_those_of_phase_zero():
    region = box(0, 0, 20, 10)
    field = AnalyticField(uniform(0.0), None)
    a = generate("levelset", EngineInput(region, field, PITCH))
    b = generate("levelset", EngineInput(region, field, PITCH), phase=0.5)
    ya = np.sort([p.points[:, 1].mean() for p in a.paths])
    yb = np.sort([p.points[:, 1].mean() for p in b.paths])
    gaps = np.abs(yb[:, None] - ya[None, :]).min(axis=1)
    assert np.median(gaps) == pytest.approx(0.5 * PITCH, abs=0.1 * PITCH)


def test_two_islands_and_determinism():
    region = MultiPolygon([box(0, 0, 12, 10), box(20, 0, 32, 10)])
    field = AnalyticField(uniform(60.0), None)
    a = generate("levelset", EngineInput(region, field, PITCH))
    b = generate("levelset", EngineInput(region, field, PITCH))
    assert len(a.paths) == len(b.paths)
    assert all(np.array_equal(p.points, q.points) for p, q in zip(a.paths, b.paths, strict=True))
    for island in region.geoms:
        assert any(island.buffer(1e-6).contains(shapely.LineString(p.points)) for p in a.paths)


def test_the_fit_sets_phis_constant_itself_so_another_solver_gives_the_same_level_sets(monkeypatch):
    # phi is defined up to a constant, which the solve holds only to ~1e-3 lines; the fit sets it
    # (mean 0, the exact minimiser), so SuperLU's default column ordering gives the same field
    import loadpath.fea.solver as solver
    from scipy.sparse.linalg import splu

    region, field = open_hole()
    inp = EngineInput(region, field, PITCH)
    ours = fit(inp, LevelSetOptions())
    assert abs(np.nanmean(ours.phi)) < 1e-9 and ours.residual < 1e-8, (np.nanmean(ours.phi), ours.residual)
    monkeypatch.setattr(solver, "symmetric_lu", lambda a: splu(a.tocsc()))  # scipy's own defaults
    other = fit(inp, LevelSetOptions())
    assert np.array_equal(np.isnan(ours.phi), np.isnan(other.phi))
    assert np.nanmax(np.abs(ours.phi - other.phi)) < 1e-8, np.nanmax(np.abs(ours.phi - other.phi))


def test_bad_options_and_regions_get_one_line():
    region = box(0, 0, 10, 10)
    field = AnalyticField(uniform(0.0), None)
    with pytest.raises(SettingsError, match="no option bogus"):
        generate("levelset", EngineInput(region, field, PITCH), bogus=1)
    with pytest.raises(SettingsError, match="align"):
        generate("levelset", EngineInput(region, field, PITCH), align=-1)
    bowtie = shapely.Polygon([(0, 0), (10, 10), (10, 0), (0, 10)])
    with pytest.raises(GeometryError, match="buffer"):
        generate("levelset", EngineInput(bowtie, field, PITCH))


@pytest.mark.parametrize("angle", [3.0, 6.0, 10.0])
def test_level_sets_meeting_the_edge_at_a_few_degrees_link_along_it_into_one_zigzag(angle):
    """A bending part's faces: the level sets reach the edge at a few degrees, their ends many
    pitches apart along it, and a link along the edge runs beside the path converging on it.  With
    the engine's own linking options (``Engine.linking``: the wedge beside that path allowed) they
    print as one zig-zag, inside the region, crossing nothing, covering more than the runs apart."""
    region = box(0, 0, 60, 6)
    tp = generate("levelset", EngineInput(region, AnalyticField(uniform(angle), None), PITCH))
    before, _ = link_paths(tp.paths, region, PITCH, LinkOptions())
    runs, st = link_paths(tp.paths, region, PITCH, LinkOptions(**engine_named("levelset").linking))
    assert len(runs) == 1 < len(before), (len(runs), len(before))
    line = shapely.LineString(runs[0].points)
    assert region.buffer(1e-3).covers(line) and line.is_simple
    cov0 = M.coverage(Toolpaths(paths=before), region)
    cov = M.coverage(Toolpaths(paths=runs), region)
    assert cov.coverage >= max(0.97, cov0.coverage), (cov, cov0)
    # each link a bead of its own: it lies on the wedge beside the path it enters, as a slicer's
    # zig-zag turn lies on its line ends; bounded here
    split = M.coverage(Toolpaths(paths=tuple(pieces(runs, st["links_at"]))), region)
    assert split.overlap <= 0.10, split


def half_quiet(angle_deg: float, quiet_from: float, level: float = 1e-2):
    """Uniform stress (10 MPa along ``angle_deg``) for x < quiet_from; beyond, stress ``level``
    times smaller whose direction turns every few tenths of a millimetre (numerical noise)."""
    loud = uniform(angle_deg)

    def f(p):
        out = loud(p)
        t = 40.0 * p[:, 0] + 57.0 * p[:, 1] + 13.0 * np.sin(7.0 * p[:, 0] * p[:, 1])
        c, s = np.cos(t), np.sin(t)
        noise = level * np.stack([10 * c * c, 10 * s * s, 10 * c * s], axis=1)
        return np.where((p[:, 0] < quiet_from)[:, None], out, noise)

    return f


def _turning(points: np.ndarray) -> float:
    """Total turning (degrees) along a polyline."""
    seg = np.diff(points, axis=0)
    seg = seg[np.hypot(*seg.T) > 1e-6]
    ang = np.arctan2(seg[:, 1], seg[:, 0])
    return float(np.degrees(np.abs(np.angle(np.exp(1j * np.diff(ang)))).sum()))


def test_where_the_stress_is_negligible_the_level_sets_run_straight_with_no_tiny_loops():
    """Issue 15 (a column loaded along its axis): where the in-plane stress is noise, following its
    direction lays tiny loops; relieved, the level sets there run straight at the pitch, and where
    the stress is not negligible they still follow it."""
    region = box(0, 0, 30, 12)
    field = AnalyticField(half_quiet(30.0, 12.0), region, scale=10.0)
    inp = EngineInput(region, field, PITCH)
    quiet = box(14, 0.5, 30, 11.5)  # away from the ends, which bend to reach the edge

    def measure(tp):
        pieces_ = [shapely.intersection(shapely.LineString(p.points), quiet) for p in tp.paths]
        lines = [np.asarray(shapely.get_coordinates(g)) for piece in pieces_ for g in shapely.get_parts(piece)]
        lines = [ln for ln in lines if len(ln) >= 2 and np.hypot(*(ln[-1] - ln[0])) > 0 or len(ln) > 2]
        closed = sum(1 for p in tp.paths if np.hypot(*(p.points[-1] - p.points[0])) < PITCH and len(p.points) > 3)
        turn = np.median([_turning(ln) / max(shapely.LineString(ln).length, 1e-9) for ln in lines if len(ln) > 2])
        return len(tp.paths), closed, turn

    noisy = generate("levelset", inp, relief=0.0)
    calm = generate("levelset", inp, quiet=1.0)  # relieve every region, not only quiet ones
    n_noisy, closed_noisy, turn_noisy = measure(noisy)
    n_calm, closed_calm, turn_calm = measure(calm)
    # the noise, followed, lays closed loops and winding paths; relieved, none and straight ones
    assert closed_calm == 0, (closed_calm, closed_noisy)
    # degrees per mm, median over the quiet pieces (the noise, followed: about 40)
    assert turn_calm < 5.0 and turn_calm < 0.25 * turn_noisy, (turn_calm, turn_noisy)
    # bounded path count: about one path per pitch across the region, as straight infill
    assert n_calm <= 2 * np.hypot(30, 12) / PITCH, (n_calm, n_noisy)
    cov = M.coverage(calm, region)
    assert cov.coverage >= 0.95 and cov.overlap <= 0.05, cov
    # the loud half still follows its stress
    loud = box(0, 0, 10, 12)
    d = np.array([np.cos(np.radians(30)), np.sin(np.radians(30))])
    segs = []
    for p in calm.paths:
        for g in shapely.get_parts(shapely.intersection(shapely.LineString(p.points), loud)):
            c = np.asarray(shapely.get_coordinates(g))
            if len(c) >= 2:
                segs.append(np.diff(c, axis=0))
    seg = np.concatenate(segs)
    seg = seg[np.hypot(*seg.T) > 1e-6]
    lengths = np.hypot(*seg.T)
    cosang = np.abs(seg @ d) / lengths
    assert np.average(cosang, weights=lengths) > np.cos(np.radians(5.0))


def test_a_layer_with_only_noise_stress_gets_straight_lines_at_the_pitch_by_default():
    """The column loaded along its axis: every layer's in-plane stress is noise."""
    region = box(0, 0, 16, 12)
    field = AnalyticField(half_quiet(30.0, -1.0), region, scale=10.0)
    inp = EngineInput(region, field, PITCH)
    tp = generate("levelset", inp)
    noisy = generate("levelset", inp, relief=0.0)
    inner = box(0.5, 0.5, 15.5, 11.5)
    turns = [
        _turning(c) / g.length
        for p in tp.paths
        for g in shapely.get_parts(shapely.intersection(shapely.LineString(p.points), inner))
        if g.length > 1 and len(c := np.asarray(shapely.get_coordinates(g))) > 2
    ]
    assert not turns or np.median(turns) < 5.0, np.median(turns)
    assert len(tp.paths) <= 2 * np.hypot(16, 12) / PITCH, (len(tp.paths), len(noisy.paths))
    cov = M.coverage(tp, region)
    assert cov.coverage >= 0.95 and cov.overlap <= 0.05, cov


def test_a_stressed_region_is_not_relieved_by_default():
    region, field = open_hole()
    inp = EngineInput(region, field, PITCH)
    a, b = fit(inp, LevelSetOptions()), fit(inp, LevelSetOptions(relief=0.0))
    assert np.array_equal(a.phi, b.phi, equal_nan=True)


def test_relief_options_are_checked():
    region = box(0, 0, 10, 10)
    field = AnalyticField(uniform(0.0), None)
    with pytest.raises(SettingsError, match="relief_floor"):
        generate("levelset", EngineInput(region, field, PITCH), relief_floor=2.0)
    with pytest.raises(SettingsError, match="straight"):
        generate("levelset", EngineInput(region, field, PITCH), straight=-1.0)


@pytest.mark.parametrize("size", [(60.0, 10.0), (80.0, 12.0)])
def test_cantilever_prints_fewer_runs_linked_along_its_cut_and_with_runs_inserted(size):
    """Issue 19 on the closed-form cantilever: the level sets end on the neutral-axis cut, which the
    engine returns as its band; linked along it, and with runs inserted into links laid before them
    (``LinkOptions.insert``), the layer prints as fewer runs, covering no less, crossing nothing."""
    length, height = size
    region = box(0, 0, length, height)
    field = AnalyticField(cantilever(height, length), region, scale=1.0)
    tp = generate("levelset", EngineInput(region, field, PITCH))
    assert tp.band is not None and tp.band.length > length  # the cut along the neutral axis
    lo = LinkOptions(**engine_named("levelset").linking)
    counts, covers = [], []
    for band, insert in ((None, False), (tp.band, False), (tp.band, True)):
        runs, _ = link_paths(tp.paths, region, PITCH, replace(lo, insert=insert), band=band)
        assert M.crossings(runs) == 0
        assert all(region.buffer(1e-3).covers(shapely.LineString(r.points)) for r in runs)
        counts.append(len(runs))
        covers.append(M.coverage(Toolpaths(paths=runs), region).coverage)
    assert counts[0] > counts[1] > counts[2], counts
    assert covers[2] >= covers[0] - 1e-4, covers


@pytest.mark.parametrize("size", [(60.0, 10.0), (80.0, 12.0)])
def test_healed_across_the_cut_the_cantilevers_level_sets_run_through_it_as_fewer_runs(size):
    """Option ``heal`` (issue 19): the direction blended across the neutral axis, where ``max_abs``
    jumps by 90 degrees, with its stress-weighted average; the fibres' stress along the beam sets it
    there, the fit is no longer cut along the beam, and the layer prints as fewer runs than the cut
    level sets, linked as the pipeline links them, covering as much and crossing nothing."""
    length, height = size
    region = box(0, 0, length, height)
    field = AnalyticField(cantilever(height, length), region, scale=1.0)
    inp = EngineInput(region, field, PITCH)
    cut, healed = fit(inp, LevelSetOptions()), fit(inp, LevelSetOptions(heal=1.0))
    assert cut.cut_mm > length - 10.0, cut.cut_mm
    assert healed.cut_mm < 0.1 * cut.cut_mm, healed.cut_mm
    lo = LinkOptions(**engine_named("levelset").linking)
    counts, covers, betas = [], [], []
    for heal in (0.0, 1.0):
        tp = generate("levelset", inp, heal=heal)
        runs, _ = link_paths(tp.paths, region, PITCH, lo, band=tp.band)
        assert M.crossings(runs) == 0
        counts.append(len(runs))
        covers.append(M.coverage(Toolpaths(paths=runs), region).coverage)
        betas.append(M.alignment(tp, field, PITCH, region=region).beta)
    # 6 and 10 runs cut, 2 and 2 healed; coverage 0.949 / 0.962 cut, 0.989 healed
    assert counts[1] <= counts[0] // 2, counts
    assert covers[1] >= 0.95 and covers[1] >= covers[0] - 0.01, covers
    # still aligned with the stress the cut level sets follow (0.998 cut, 0.982 / 0.985 healed): the
    # lines leave the principal direction only in the band round the neutral axis
    assert betas[1] >= 0.97, betas


def test_a_field_with_no_jump_is_not_healed():
    inp = EngineInput(box(0, 0, 40, 16), AnalyticField(uniform(20.0), None), PITCH)
    a, b = fit(inp, LevelSetOptions()), fit(inp, LevelSetOptions(heal=1.0))
    assert np.array_equal(a.phi, b.phi, equal_nan=True)
    with pytest.raises(SettingsError, match="heal"):
        LevelSetOptions(heal=-1.0)
