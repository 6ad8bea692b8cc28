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
