"""Findings of the hardening campaign on parts and settings no other test slices (real slicer output).

Each test slices with the real slicer (``tests/slicing.py`` through the ``sliced`` fixture) and runs
the whole job, as a user's file would be run.
"""

from __future__ import annotations

import pytest
from pipeline_helpers import replaced_blocks, run, write_case


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    return write_case(tmp_path_factory.mktemp("case"))


def _blocks(result):
    geo = result.pipeline.geometry
    return {b.block_index: b for o in geo.objects for lg in o.layers for i in lg.islands for b in i.blocks}


@pytest.mark.parametrize("pattern, spacing", [("trihexagon", 1.2), ("grid", 0.8), ("cubic", 1.2)])
def test_cura_full_infill_of_crossing_line_families_is_replaced(sliced, case, tmp_path, pattern, spacing):
    """Cura at 100 % with a pattern of several line families (grid: two, trihexagon and cubic: three
    per layer, each at 2-3 flow widths) is solid by its plastic, but each family's lines stand 2-3
    flow widths apart.  That spacing was taken as the new paths' pitch, so they extruded a third to
    a half of the slicer's volume and every block was kept as sliced ("nothing replaced")."""
    gc = sliced("cura", "ohs", "solid", infill_pattern=pattern, infill_line_distance=spacing)
    program, result, out = run(gc, case, tmp_path / "out.gcode")
    blocks = _blocks(result)
    fill = {i for i, b in blocks.items() if b.feature == "FILL"}
    assert fill and all(blocks[i].kind == "solid" for i in fill)
    for i in fill:  # the pitch of a full block is about its flow width, whatever its line families
        assert blocks[i].pitch == pytest.approx(blocks[i].flow_width, rel=0.1), (i, blocks[i].pitch)
    assert fill <= replaced_blocks(result), sorted(fill - replaced_blocks(result))
    assert result.pipeline.check.problems == []
