"""Findings of the hardening campaign on parts and settings no other test slices (real slicer output).

Each test slices with the real slicer (``tests/slicing.py`` through the ``sliced`` fixture) and runs
the whole job, as a user's file would be run.
"""

from __future__ import annotations

from pathlib import Path

import pytest
import slicing
from cases import side_case
from conftest import require_tool
from pipeline_helpers import replaced_blocks, run, write_case


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    return write_case(tmp_path_factory.mktemp("case"))


def _blocks(result):
    geo = result.pipeline.geometry
    return {b.block_index: b for o in geo.objects for lg in o.layers for b in lg.blocks}


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


def _tbeam_stl(folder: Path) -> Path:
    """A T-beam cantilever in the bed plane (100 x 20 x 5 mm): a flange, a web, the root that is
    clamped and ribs between them, so the sparse infill's regions are many narrow pieces."""
    import manifold3d as mf

    sq = mf.CrossSection.square
    cs = sq((100, 4)).translate((0, 16)) + sq((6, 16)) + sq((100, 4)).translate((0, 6))
    for x in range(15, 100, 15):
        cs = cs + sq((3, 6)).translate((x, 10))
    mesh = slicing._to_trimesh(mf.Manifold.extrude(cs, 5.0))
    return slicing.write_stl(slicing._at_origin(mesh), folder / "tbeam.stl")


TIP_LOAD = side_case(
    (0.0, -150.0, 0.0), held_within=0.5, loaded_within=0.5, part_frame=True, support="wall", load="tip"
)


def test_stack_density_zones_of_a_ribbed_beam(tmp_path):
    """The density field's zones on a ribbed T-beam (Cura 40 % tetrahedral, density "stack"): two
    zone pieces that touched along an edge made a GeometryCollection, whose boundary is None, and
    the run stopped with an internal error (AttributeError: 'NoneType' object has no attribute
    'length')."""
    require_tool("CuraEngine")
    require_tool("cura")
    gc = slicing.slice_cura(
        _tbeam_stl(tmp_path), tmp_path / "tbeam.gcode",
        **{**slicing.CURA_MIXED, "infill_sparse_density": "40", "infill_pattern": "tetrahedral",
           "infill_line_distance": "2.0", "infill_sparse_thickness": "0.2"},
    )
    case = tmp_path / "tip.toml"
    case.write_text(TIP_LOAD, encoding="utf-8")
    program, result, out = run(gc, case, tmp_path / "out.gcode", replace=("sparse",), density="stack")
    assert replaced_blocks(result)
    assert result.pipeline.check.problems == []


def _block_stl(folder: Path, name: str, size: tuple[float, float, float]) -> Path:
    box = slicing.trimesh.creation.box(extents=size)
    return slicing.write_stl(slicing._at_origin(box), folder / name)


PULL_A = side_case((200.0, 0.0, 0.0), held_within=1.0, loaded_within=1.0, part_frame=True, obj="block_a.stl")


def test_cura_retraction_leaving_a_block_whose_plastic_changed(tmp_path):
    """Absolute E (Cura): the retraction that leaves a replaced block for the next object was copied
    verbatim (``G1 F1500 E143.21047``), an absolute target that is a retraction only from the
    slicer's own end of the block.  The new paths of the block (Cura 100 % cross 3D, level sets)
    ended 1.07 mm of filament short of it, within the volume tolerance, so the copied line pushed
    0.27 mm of filament out instead of pulling 0.8 mm back, and the check refused the file
    ("retraction differs after kept line 720")."""
    require_tool("CuraEngine")
    require_tool("cura")
    stls = [_block_stl(tmp_path, "block_a.stl", (30.0, 20.0, 4.0)),
            _block_stl(tmp_path, "block_b.stl", (25.0, 15.0, 5.0))]
    gc = slicing.slice_cura(
        stls, tmp_path / "blocks.gcode",
        **{**slicing.CURA_SOLID, "infill_pattern": "cross_3d", "infill_sparse_thickness": "0.2"},
    )
    case = tmp_path / "pull_a.toml"
    case.write_text(PULL_A, encoding="utf-8")
    program, result, out = run(gc, case, tmp_path / "out.gcode", engine="levelset")
    assert result.error is None and replaced_blocks(result)
    assert result.pipeline.check.problems == []
