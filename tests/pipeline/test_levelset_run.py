"""The level-set engine on real slices: printed as the slicer prints its infill, the check clean.

Real PrusaSlicer 2.5 and CuraEngine 4.13 slices of the open-hole specimen (the shared slice cache),
run whole (``loadpath run``) with ``--engine levelset`` and, for comparison, the swarm.  What is
counted is what the verdict counts (:func:`loadpath.printability.verdict_counts`): the replaced
blocks and the moves into them.
"""

from __future__ import annotations

import pytest
from cases import BRACKET_PIN
from loadpath.printability import verdict_counts
from pipeline_helpers import run, write_case


def _counts(sliced, tmp_path, slicer, settings, engine, replace):
    case = write_case(tmp_path)
    _, result, _ = run(
        sliced(slicer, "ohs", settings), case, tmp_path / f"{engine}.gcode", engine=engine, replace=replace
    )
    pres = result.pipeline
    assert pres is not None and pres.changed
    assert pres.check.problems == []
    counts, why = verdict_counts(pres)
    assert counts is not None, why
    return counts


@pytest.mark.slow
def test_solid_infill_prints_with_fewer_retractions_than_the_swarm_and_near_the_slicers(sliced, tmp_path):
    ours = _counts(sliced, tmp_path, "prusa", "solid", "levelset", ("solid",))
    swarm = _counts(sliced, tmp_path, "prusa", "solid", "swarm", ("solid",))
    slicer = ours["slicer"]
    assert ours["loadpath"]["retractions"] < 0.6 * swarm["loadpath"]["retractions"], (ours, swarm)
    assert ours["loadpath"]["retractions"] <= 6 * slicer["retractions"], ours
    assert ours["loadpath"]["print_s"] <= 1.1 * slicer["print_s"], ours


@pytest.mark.slow
@pytest.mark.parametrize("slicer", ["prusa", "cura"])
def test_sparse_infill_keeps_the_slicers_plastic_and_few_travels(sliced, tmp_path, slicer):
    ours = _counts(sliced, tmp_path, slicer, "mixed", "levelset", ("sparse",))
    s, n = ours["slicer"], ours["loadpath"]
    assert n["filament_mm"] == pytest.approx(s["filament_mm"], rel=0.02), ours
    # PrusaSlicer's sparse infill: a few zig-zags a layer; Cura's: none retracted (combing)
    assert n["retractions"] <= max(2.5 * s["retractions"], s["retractions"] + 20), ours
    assert n["print_s"] <= 1.15 * s["print_s"], ours


@pytest.mark.slow
def test_a_bending_part_links_the_level_sets_that_reach_its_faces_at_a_few_degrees(sliced, tmp_path):
    """The L-bracket in bending (``cases.BRACKET_PIN``), PrusaSlicer 100 %: the level sets leave the
    cut along the neutral axis and reach the faces at a few degrees, their ends many pitches apart
    along the edge.  Linked along the edge beside the converging path (``LinkOptions.wedge``, the
    engine's ``Engine.linking``), they print as zig-zags: without it this part took 10.6x the
    slicer's retractions and 1.15x its print time, with it 7.8x and 1.11x (the swarm 20.9x, 1.57x)."""
    case = tmp_path / "bracket.toml"
    case.write_text(BRACKET_PIN, encoding="utf-8")
    gcode = sliced("prusa", "bracket", "solid")
    _, result, _ = run(gcode, case, tmp_path / "out.gcode", engine="levelset", replace=("solid",))
    pres = result.pipeline
    assert pres is not None and pres.changed and pres.check.problems == []
    counts, why = verdict_counts(pres)
    assert counts is not None, why
    slicer, ours = counts["slicer"], counts["loadpath"]
    assert ours["retractions"] <= 9 * slicer["retractions"], counts
    assert ours["print_s"] <= 1.13 * slicer["print_s"], counts


@pytest.mark.slow
def test_sparse_infill_of_a_bent_beam_keeps_its_failure_load(tmp_path):
    # The 3-point beam of bench_sparse (120 x 20 x 4 mm, PrusaSlicer gyroid 20 %, 3 top / 3 bottom
    # layers).  The level sets' wedge links (LinkOptions.wedge), laid on its sparse infill too, ran
    # a bead along each face beside the lines converging on it and took its predicted failure load
    # from 1.882x to 1.346x the slicer's; they are for solid infill only.  That difference is inside
    # round-off's reach (2026-12-05): with the force turned by 1e-4 to 4e-4 rad the first ply fails
    # at the left support, where the level sets fan, at 1.329-1.334x (the case's own force: 2.153x),
    # and with the wedge links on sparse infill at 1.338-1.347x.  So this asks for what holds through
    # round-off: the beam's sparse infill well above the slicer's failure load.
    import slicing
    import trimesh
    from cases import BEAM_3PT
    from loadpath import loadcase
    from loadpath.plugin.job import JobRequest, run_job
    from loadpath.stiffness import compare_files

    stl = slicing.write_stl(slicing._at_origin(trimesh.creation.box(extents=(120.0, 20.0, 4.0))), tmp_path / "b.stl")
    conf = {**slicing.PRUSA_MIXED, "top_solid_layers": "3", "bottom_solid_layers": "3"}
    src = slicing.slice_prusa(stl, tmp_path / "beam.gcode", **{**conf, "fill_pattern": "gyroid", "fill_density": "20%"})
    case = tmp_path / "beam.toml"
    case.write_text(BEAM_3PT, encoding="utf-8")
    out = tmp_path / "out.gcode"
    cli = {"engine": "levelset", "replace": ("solid", "sparse"), "density": "energy", "cache": False}
    res = run_job(JobRequest(src, case, output=out, cli=cli))
    assert res.written and res.error is None, res.error
    slicer, ours = compare_files([str(src), str(out)], loadcase.read(case))[0]
    assert ours.mass / slicer.mass == pytest.approx(1.0, abs=0.02)
    assert ours.relative_failure_load >= 1.25, (ours.relative_failure_load, ours.failure_location)
