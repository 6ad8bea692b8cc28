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


def test_the_shipped_examples_layers_print_their_representatives_runs(tmp_path):
    """On the shipped example every layer of an engine run whose region is its representative's within
    rounding prints the representative's linked runs (or its staggered copy's): the run links once per
    job and copy, plus once per layer cut to its own region, and the cache holds just those linkings
    (before, each of the 8 layers was linked in its own region: 9 linkings)."""
    from pathlib import Path as FsPath

    from loadpath.cache import Cache
    from loadpath.pipeline.paths import reuses
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
    units = [(r, u) for r in runs for u in r.units]
    own = [u for r, u in units if not reuses(u.fill_region, r.job.unit.fill_region)]
    assert len(units) - len(own) >= 6  # the test means something: most layers reuse
    copies = sum(1 for r in runs if any(r.staggered))
    linkings = len(list((tmp_path / "cache" / "links").iterdir()))
    assert linkings <= len(runs) + copies + len(own)
