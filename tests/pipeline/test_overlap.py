"""The engines fill as far into the perimeters as the slicer's own infill did (real PrusaSlicer 2.5)."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from loadpath import gcode, geometry
from loadpath.pipeline.units import select_units, slicer_overlap, with_overlap


def test_overlap_is_measured_from_the_slicers_lines_and_grows_the_engine_region(sliced):
    path = sliced("prusa", "ohs", "solid", infill_overlap="25%")
    program = gcode.read(path)
    geo = geometry.layer_geometry(program, check=False)
    names = [o.name for o in geo.objects]
    units = select_units(geo, names, ("solid",))
    assert units
    grown = with_overlap(units, program, geo)
    o = np.array([u.overlap for u in grown])
    # MK3S: 25 % of (perimeter spacing + infill spacing) / 2 is about 0.1 mm; the ends of the
    # slicer's lines sit a little more than half a bead inside the perimeters' flow edge
    assert np.all((o > 0.05) & (o < 0.15)), o
    for u in grown:
        assert u.fill_region.contains(u.region.buffer(-1e-6))
        added = u.fill_region.area - u.region.area
        # grown by the overlap all round its edge (minus corners), never more
        assert 0.8 * u.overlap * u.region.length <= added <= 1.05 * u.overlap * u.region.length
        # and only into the perimeters: inside the part outline
        outline = next(
            i.outline
            for ob in geo.objects
            for lg in ob.layers
            if lg.layer_index == u.layer
            for i in lg.islands
            if i.index == u.island
        )
        assert outline.contains(u.fill_region)
    # without overlap in the file, nothing grows
    flush = sliced("prusa", "ohs", "solid", infill_overlap="0%")
    p2 = gcode.read(flush)
    g2 = geometry.layer_geometry(p2, check=False)
    u2 = select_units(g2, [o.name for o in g2.objects], ("solid",))
    assert all(slicer_overlap(p2, u) < 0.03 for u in u2)


@pytest.fixture(scope="module")
def solid_run(sliced, tmp_path_factory):
    """Factory ``solid_run(engine) -> JobResult``: one whole run per engine on the specimen (solid infill).

    Made once for the module: the overlap test and the staggered-layer test check the same run.
    """
    from pipeline_helpers import run, write_case

    made = {}

    def make(engine: str):
        if engine not in made:
            folder = tmp_path_factory.mktemp(f"solid-{engine}")
            case = write_case(folder)
            made[engine] = run(sliced("prusa", "ohs", "solid"), case, folder / "out.gcode", engine=engine)[1]
        return made[engine]

    return make


def test_overlap_reaches_the_output(solid_run):
    """A whole run: the new beads reach past the region's edge as the slicer's did, and the check passes."""
    result = solid_run("swarm")
    assert result.pipeline.check.problems == []
    units = [u for j in result.pipeline.jobs for u in j.units]
    assert units and all(u.overlap > 0.05 for u in units)
    # every engine run filled the grown region, whose edge lies beyond the slicer's region
    for j in result.pipeline.jobs:
        u = j.units[0]
        pts = np.concatenate([p.points for p in j.paths.paths])
        outside = ~shapely.contains_xy(u.region, pts[:, 0], pts[:, 1])
        assert outside.any()  # some ends and edge paths now lie in the overlap band
        assert np.all(shapely.distance(u.region, shapely.points(pts[outside])) <= u.overlap + 1e-6)


@pytest.mark.slow
@pytest.mark.parametrize("engine", ["swarm", "streamlines", "levelset"])
def test_staggered_layers_are_laid_by_the_engine_itself(solid_run, engine):
    """Identical layers alternate between the engine's paths and its own copy from seeds half a pitch on.

    Real PrusaSlicer 2.5 specimen, solid infill.
    """
    from loadpath.metrics import coverage, resample

    result = solid_run(engine)
    assert result.pipeline.check.problems == []
    multi = [j for j in result.pipeline.jobs if len(j.units) > 1]
    assert multi
    for j in multi:
        assert j.staggered[0] is False and j.staggered[1] is True and j.shifted_by_engine
        u = j.units[0]
        # a whole layer again: it covers the region as well as the first copy does
        base, shifted = coverage(j.paths, u.fill_region).coverage, coverage(j.shifted, u.fill_region).coverage
        assert shifted > 0.97 and shifted > base - 0.01
        # and its paths do not lie on the first copy's: they start half a pitch on; the swarm's
        # spacing pulls them part of the way back over 150 mm (median 0.23 pitch off on this part),
        # the streamlines' and the level sets' stay about half a pitch off
        pts = shapely.points(resample(j.shifted, u.pitch)[0])
        lines = np.array([shapely.LineString(p.points) for p in j.paths.paths], dtype=object)
        d = shapely.distance(pts, lines[shapely.STRtree(lines).nearest(pts)])
        assert 0.15 * u.pitch < np.median(d) < 0.65 * u.pitch


def test_only_engines_with_boundary_or_load_seeds_lay_their_own_copy():
    from loadpath.pipeline.paths import lays_phase

    assert lays_phase("swarm", {"K": 5.0})
    assert lays_phase("streamlines", {}) and lays_phase("streamlines", {"mode": "default"})
    # faithful streamlines seed a lattice (or the element centroids): no phase, the paths are shifted
    assert not lays_phase("streamlines", {"mode": "faithful"})


def test_overlap_in_worker_processes_gives_the_same_units(sliced):
    """``with_overlap(..., workers=2)`` (the units in forked batches) gives every unit the overlap and
    engine region one process gives, exactly (the regions compared by their WKB)."""
    program = gcode.read(sliced("prusa", "ohs", "solid", infill_overlap="25%"))
    geo = geometry.layer_geometry(program, check=False)
    units = select_units(geo, [o.name for o in geo.objects], ("solid",))
    assert len(units) > 1
    one = with_overlap(units, program, geo)
    two = with_overlap(units, program, geo, workers=2)
    assert [u.overlap for u in two] == [u.overlap for u in one]
    assert any(u.overlap > 0 for u in one)
    assert [shapely.to_wkb(u.fill_region) for u in two] == [shapely.to_wkb(u.fill_region) for u in one]


@pytest.mark.parametrize("slicer", ["cura", "prusa"])
def test_the_grown_region_holds_no_more_than_the_slicers_plastic(sliced, slicer):
    """The region grows into the walls only as far as the slicer's plastic tiles it: CuraEngine runs
    its lines 0.24 mm into the walls at their ends only, and a region grown that far all round took
    3.5 % more area than the plastic covers (every bead printed narrower than its spacing).  One
    share of the reach for layers alike, in steps: they keep regions alike (one engine run)."""
    from loadpath.geometry.groups import group_regions
    from loadpath.pipeline.units import SHARE_STEP, _grown, growth_shares, island_domains, plastic_area

    program = gcode.read(sliced(slicer, "ohs", "solid"))
    geo = geometry.layer_geometry(program, check=False)
    units = select_units(geo, [o.name for o in geo.objects], ("solid",))
    domains = island_domains(geo)
    grown = with_overlap(units, program, geo)
    share = growth_shares(units, program, domains, geo.filament_diameter)
    assert all(abs(s / SHARE_STEP - round(s / SHARE_STEP)) < 1e-9 and 0 <= s <= 1 for s in share)
    mid = share[len(share) // 2]
    assert mid <= 0.25 if slicer == "cura" else mid >= 0.5, share
    over = []
    for u, g, s in zip(units, grown, share, strict=True):
        room = plastic_area(program, u, geo.filament_diameter)
        # the slicer's plastic at the layer height: about the region it fills, a few % either way
        assert 0.9 * u.region.area < room < 1.1 * u.region.area
        measured = slicer_overlap(program, u)
        assert g.overlap == pytest.approx(s * measured) or (g.overlap == 0 and s * measured < 1e-3)
        over.append(g.fill_region.area / max(room, u.region.area) - 1.0)
    # no layer's region outgrows its plastic by more than a few tenths of a percent
    assert max(over) < 0.005, over
    # layers alike stay alike: no more groups of engine regions than grown by the whole reach
    whole = [_grown(u, program, domains, 1.0) for u in units]
    before = group_regions([u.region if w is None else w[1] for u, w in zip(units, whole, strict=True)])
    after = group_regions([g.fill_region for g in grown])
    assert len(set(after)) <= len(set(before))


def test_cura_solid_beads_are_printed_at_their_spacing(tmp_path, sliced):
    """A whole run on CuraEngine's 100 % specimen: the volume correction of every replaced block is
    within 2 % of 1 (the new beads as wide as their spacing; 0.965 before the region was capped)."""
    from pipeline_helpers import run, write_case

    gcode_path = sliced("cura", "ohs", "solid")
    _, result, _ = run(gcode_path, write_case(tmp_path), tmp_path / "out.gcode", engine="levelset")
    assert result.pipeline.check.problems == []
    corr = np.array([b.correction for b in result.pipeline.splice.blocks])
    assert len(corr) and np.all(np.abs(corr - 1.0) < 0.02), corr
