"""Reused paths are cut to each layer's own region (clip_to) unless they lie in it (reuses, lies_in)."""

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


def test_a_region_off_by_rounding_reuses_the_runs_a_sliver_does_not():
    """reuses: a layer whose perimeters differ from the representative's by rounding (up to 28 um) prints
    its linked runs as they are; one that lacks a sliver (0.75 mm2 by the hole, as on the 1000-layer
    specimen) or whose edge lies 2.5 tolerances off is cut to its own region and linked again."""
    from loadpath.pipeline.paths import reuses
    from loadpath.tolerances import TOL

    rep = box(0, 0, 150, 36).difference(Point(75, 18).buffer(3.0, 32))
    rounded = box(0.004, -0.003, 150.028, 36.0).difference(Point(75.005, 18.0).buffer(3.006, 32))
    assert reuses(rep, rep) and reuses(rounded, rep) and reuses(rep, rounded)
    sliver = rep.difference(box(71.6, 17.5, 72.1, 19.0))  # 0.66 mm2 off the hole's rim
    assert 0.5 < rep.area - sliver.area < 0.75
    assert not reuses(sliver, rep) and not reuses(rep, sliver)
    off = box(0, 0, 150 + 2.5 * TOL.region_reuse_mm, 36).difference(Point(75, 18).buffer(3.0, 32))
    assert not reuses(off, rep)


def test_a_segment_across_a_hole_does_not_lie_in_the_region_though_its_vertices_do():
    """lies_in tests segments, not vertices: the streamlines' 3.5 mm steps at a 4 mm sparse pitch put
    two vertices 0.17 and 0.01 mm inside the rim of a 3.8 mm hole and the segment between them 0.35
    mm into it (the Cura file with combined sparse infill; its check allows 0.2 mm)."""
    from loadpath.pipeline.paths import lies_in
    from loadpath.tolerances import TOL

    region = box(100, 90, 150, 120).difference(Point(125, 105).buffer(3.8, 64))
    chord = Path(np.array([[119.54, 101.94], [123.05, 101.56], [126.58, 101.54], [130.05, 102.11]]),
                 np.full(4, 4.0))
    assert all(region.contains(Point(q)) for q in chord.points)
    assert not lies_in([chord], region)
    assert lies_in([chord], region, tol=0.4)  # 0.35 mm out
    beside = Path(chord.points - [0.0, 0.5], chord.pitch)  # the same 0.5 mm further from the hole
    assert lies_in([beside], region) and lies_in([], region)
    rounded = box(100, 90, 150 - 0.5 * TOL.region_reuse_mm, 120)  # an edge off by rounding
    assert lies_in([Path(np.array([[101.0, 95.0], [150.0, 95.0]]), np.full(2, 4.0))], rounded)



def test_lies_in_is_covered_by_of_the_whole_lines():
    """lies_in tests whole only the lines that meet an edge of the grown region, the others by their
    first vertex: the same answer as covered_by on every line, for random polylines inside, across
    the hole, wholly in it, wholly outside, along the edge and ending on it."""
    import shapely
    from loadpath.pipeline.paths import lies_in
    from loadpath.tolerances import TOL

    region = box(100, 90, 150, 120).difference(Point(125, 105).buffer(3.8, 64))
    grown = region.buffer(TOL.region_reuse_mm, quad_segs=4)
    rng = np.random.default_rng(5)
    answers = []
    for _ in range(400):
        paths = []
        for _ in range(int(rng.integers(1, 4))):
            start = rng.choice([[101.0, 91.0], [125.0, 105.0], [121.0, 105.0], [160.0, 95.0], [100.0, 100.0]])
            steps = rng.normal(0, rng.choice([0.05, 0.5, 3.0]), (int(rng.integers(2, 30)), 2))
            paths.append(Path(start + np.cumsum(steps, axis=0), np.full(len(steps), 0.45)))
        lines = [shapely.LineString(p.points) for p in paths]
        want = all(grown.covers(line) for line in lines)
        assert lies_in(paths, region) == want
        answers.append(want)
    assert 20 < sum(answers) < 380  # both answers, often

def test_the_shipped_examples_layers_print_their_representatives_runs(tmp_path):
    """On the shipped example every layer of an engine run whose region is its representative's within
    rounding prints the representative's linked runs (or its staggered copy's): the run links once per
    job and copy, plus once per layer cut to its own region, and the cache holds just those linkings
    (before, each of the 8 layers was linked in its own region: 9 linkings)."""
    from pathlib import Path as FsPath

    from loadpath.cache import Cache
    from loadpath.pipeline.paths import lies_in, reuses
    from loadpath.plugin.job import JobRequest, run_job

    examples = FsPath(__file__).resolve().parents[2] / "examples"
    cache = Cache(tmp_path / "cache")
    result = run_job(
        JobRequest(
            examples / "ohs.gcode", examples / "ohs.toml", output=tmp_path / "out.gcode",
            cli={"engine": "streamlines", "jobs": 1}, cache=cache,
        )
    )
    assert result.pipeline.check is not None and result.pipeline.check.ok
    runs = result.pipeline.jobs
    # a layer prints the runs (its copy's on staggered layers) as they are where its region is the
    # representative's within rounding and they lie in it; any other is linked in its own region
    units = [
        (r, u, r.shifted if shift else r.printed)
        for r in runs
        for u, shift in zip(r.units, r.staggered, strict=True)
    ]
    own = [
        u for r, u, ps in units
        if not (reuses(u.fill_region, r.job.unit.fill_region) and lies_in(ps, u.fill_region))
    ]
    assert len(units) - len(own) >= 6  # the test means something: most layers reuse
    copies = sum(1 for r in runs if any(r.staggered))
    linkings = len(list((tmp_path / "cache" / "links").iterdir()))
    assert linkings <= len(runs) + copies + len(own)


def test_a_reused_staggered_copy_that_cuts_into_a_hole_is_cut_to_the_layer(sliced, tmp_path):
    """CuraEngine 4.13, sparse infill combined every 2 layers, the ``stack`` density (the second
    candidate ``density = "auto"`` lays; test_replace_table's combined-sparse test failed in it): the
    engine's staggered copy of the single layers' run (its own, from seeds half a pitch on) has a
    3.5 mm step whose vertices lie inside the region but whose segment runs 0.35 mm into the hole.
    No layer prints it as it is (its region is its representative's within rounding, but the runs
    are not inside it): every new extrusion lies within TOL.region_reuse_mm of its region (the
    check would allow half a bead)."""
    from loadpath.pipeline.paths import lies_in
    from loadpath.tolerances import TOL
    from pipeline_helpers import run, write_case

    gpath = sliced("cura", "ohs", "mixed", infill_sparse_thickness=0.4)
    _, result, _ = run(gpath, write_case(tmp_path), tmp_path / "out.gcode", replace="sparse", density="stack")
    runs = result.pipeline.jobs
    # what the test is about: a staggered copy that leaves the region of the layers printing it
    leaves = [
        (r, u) for r in runs for u, shift in zip(r.units, r.staggered, strict=True)
        if shift and not lies_in(r.shifted, u.fill_region, 0.5 * u.flow_width)
    ]
    assert leaves, "no staggered copy leaves its layers' region any more: this file no longer tests the cut"
    check = result.pipeline.check
    assert check is not None and check.ok
    assert max(check.outside_mm.values()) <= TOL.region_reuse_mm
