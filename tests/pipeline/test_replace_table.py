"""interface.md "What is replaced, what is kept": every row on a real file (PrusaSlicer 2.5, CuraEngine 4.13).

Each test runs the whole job (geometry, load case, FEA, streamline engine, splice, check, write) on
real slicer output; the job's own check (kept lines byte for byte, machine state, volume within 3 %,
retraction balance, absolute E, feature types, nothing outside the region) must pass or the job fails.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import slicing
import trimesh
from loadpath import gcode
from loadpath.gcode.flavors import Role
from loadpath.splice.verify import layer_features
from pipeline_helpers import new_lines, replaced_blocks, run, span_lines_kept, write_case

DATA = Path(__file__).resolve().parents[1] / "data"


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    return write_case(tmp_path_factory.mktemp("case"))


def _kinds(result):
    geo = result.pipeline.geometry
    return {
        b.block_index: b.kind for o in geo.objects for lg in o.layers for i in lg.islands for b in i.blocks
    }


def test_internal_solid_replaced_skins_and_first_layer_kept(sliced, case, tmp_path):
    """Default: internal solid infill only; the first layer, skins, sparse infill and perimeters are kept."""
    program, result, out = run(sliced("prusa", "ohs", "mixed"), case, tmp_path / "out.gcode")
    kinds = _kinds(result)
    done = replaced_blocks(result)
    assert done and done == {i for i, k in kinds.items() if k == "solid"}
    assert 0 not in {program.block(i).layer for i in done}
    for i, k in kinds.items():
        if k != "solid":
            assert span_lines_kept(program, out, result, i), (i, k)
    assert layer_features(out) == layer_features(program)
    assert result.pipeline.check.problems == []


def test_cura_absolute_e_default(sliced, case, tmp_path):
    program, result, out = run(sliced("cura", "ohs", "mixed"), case, tmp_path / "out.gcode")
    assert replaced_blocks(result)
    assert {program.block(i).feature for i in replaced_blocks(result)} == {"SKIN"}
    assert result.pipeline.check.problems == []
    assert out.dialect.family == "cura"


def test_sparse_on_request_with_alternating_principal(sliced, case, tmp_path):
    """replace = ["sparse"] keeps the slicer's plastic; principal = "alternate" crosses the layers.

    With the default ``density = "auto"`` the ``"stack"`` criterion may be kept, which shares the
    plastic of a sigma1 layer and its sigma2 neighbour as the two principal stresses ask (in the
    specimen's tension the sigma2 layers keep their minimum): the replaced blocks together keep the
    slicer's volume, each block between the no-sag minimum and twice it.
    """
    program, result, out = run(
        sliced("prusa", "ohs", "mixed"), case, tmp_path / "out.gcode", replace="sparse", principal="alternate"
    )
    kinds = _kinds(result)
    done = replaced_blocks(result)
    assert done == {i for i, k in kinds.items() if k == "sparse"}
    blocks = result.pipeline.splice.blocks
    old, new = sum(r.filament_old for r in blocks), sum(r.filament_new for r in blocks)
    assert abs(new / old - 1) < 0.03  # the slicer's plastic, not solid
    assert all(0.2 < r.volume_ratio < 2.05 for r in blocks), [r.volume_ratio for r in blocks]
    # in the uniform part of the specimen sigma1 runs along x, sigma2 along y
    mask = new_lines(result, program)
    m = out.moves
    sel = (
        m["extrude"]
        & mask[m["line"]]
        & (np.abs(m["x0"] - 75) < 20)
        & (np.hypot(m["x1"] - m["x0"], m["y1"] - m["y0"]) > 1)
    )
    by_layer = {}
    for layer in np.unique(m["layer"][sel]):
        s = sel & (m["layer"] == layer)
        d = np.column_stack([m["x1"] - m["x0"], m["y1"] - m["y0"]])[s]
        # the share of the layer's filament length along x: the links between lines (a few mm each,
        # along the edge) weigh by their length, not one move each (counted per move, the sigma2
        # layers' share sat at 0.26 against the bound 0.3, and PrusaSlicer's run-to-run changes
        # in the region's edge tipped it to 0.304 once)
        by_layer[int(layer)] = float(np.abs(d[:, 0]).sum() / np.hypot(d[:, 0], d[:, 1]).sum())
    even = [v for k, v in by_layer.items() if k % 2 == 0]
    odd = [v for k, v in by_layer.items() if k % 2 == 1]
    assert even and odd
    # measured 0.997 and 0.083 with the energy density; 0.993 and 0.220 with "stack", whose sigma2
    # layers keep the no-sag minimum (lines 8 mm apart) in the specimen's tension, so the links
    # along the region's edge weigh more against the short lines along y
    assert min(even) > 0.95 and max(odd) < 0.3, by_layer


@pytest.mark.slow
def test_top_and_bottom_skins_on_request(sliced, case, tmp_path):
    program, result, out = run(
        sliced("prusa", "ohs", "solid"), case, tmp_path / "out.gcode", replace="solid,top,bottom"
    )
    layers = {program.block(i).layer for i in replaced_blocks(result)}
    assert 0 in layers and len(program.layers) - 1 in layers
    assert result.pipeline.check.problems == []


def _table_stl(folder: Path) -> Path:
    """A table: two legs and a top, so PrusaSlicer makes a bridge and (with supports on) support."""
    legs = [trimesh.creation.box(extents=(6, 12, 2.4)) for _ in range(2)]
    legs[0].apply_translation((3, 6, 1.2))
    legs[1].apply_translation((37, 6, 1.2))
    top = trimesh.creation.box(extents=(40, 12, 1.2))
    top.apply_translation((20, 6, 3.0))
    mesh = trimesh.boolean.union([*legs, top])
    path = folder / "table.stl"
    mesh.export(path)
    return path


@pytest.mark.slow
def test_bridges_and_supports_are_kept(case, tmp_path):
    """Bridges and support material are never replaced, even when every infill kind is."""
    gpath = slicing.slice_prusa(
        _table_stl(tmp_path),
        tmp_path / "table.gcode",
        **slicing.PRUSA_SOLID,
        support_material=1,
        support_material_auto=1,
    )
    program = gcode.read(gpath)
    roles = {program.block(i).role for i in range(len(program.blocks))}
    assert Role.BRIDGE_INFILL in roles and Role.SUPPORT in roles
    program, result, out = run(gpath, case, tmp_path / "out.gcode", replace="solid,sparse,top,bottom")
    assert replaced_blocks(result)
    for i in range(len(program.blocks)):
        b = program.block(i)
        if b.role in (
            Role.BRIDGE_INFILL,
            Role.SUPPORT,
            Role.SUPPORT_INTERFACE,
            Role.PERIMETER,
            Role.EXTERNAL_PERIMETER,
            Role.SKIRT,
            Role.GAP_FILL,
        ):
            assert i not in replaced_blocks(result) and span_lines_kept(program, out, result, i), b


@pytest.mark.slow
def test_two_objects_each_on_its_own_and_object_limits(sliced, tmp_path):
    """Each object is solved on its own; object = "bracket.stl" passes the other through with a warning."""
    gpath = sliced("prusa", "two_objects", "solid")
    # y sides: both plates of two_islands and both legs' ends of the bracket are held and loaded
    program, result, out = run(gpath, write_case(tmp_path, axis="y", within=3.0), tmp_path / "all.gcode")
    assert set(result.pipeline.analyses) == {"two_islands.stl", "bracket.stl"}
    objs = {program.block(i).object.split(" id:")[0] for i in replaced_blocks(result)}
    assert objs == {"two_islands.stl", "bracket.stl"}
    one = write_case(tmp_path, "one.toml", extra='object = "bracket.stl"', axis="y", within=3.0)
    program, result, out = run(gpath, one, tmp_path / "one.gcode")
    assert {program.block(i).object.split(" id:")[0] for i in replaced_blocks(result)} == {"bracket.stl"}
    assert any("two_islands.stl" in w and "passed through" in w for w in result.warnings)
    for i in range(len(program.blocks)):
        if (program.block(i).object or "").startswith("two_islands"):
            assert span_lines_kept(program, out, result, i)


def test_sparse_infill_of_a_narrow_bar_is_replaced_on_every_layer(tmp_path, case):
    """PrusaSlicer anchors every sparse line along the perimeters: on a 12 mm wide bar that is 19 %
    more plastic than its lines' 2.035 mm spacing lays.  The new paths are laid at the slicer's
    plastic per area, and a run whose paths come out longer than the flow correction can take back
    is run again at a wider pitch (here the swarm's staggered copies, 24 % over), so no layer is
    kept as sliced for want of volume (with the grip 10 mm long, two to three of six were)."""
    from conftest import require_tool

    require_tool("prusa-slicer")
    stl = tmp_path / "bar.stl"
    slicing.write_stl(trimesh.creation.box(extents=(100, 12, 2)), stl)
    gpath = slicing.slice_prusa([stl], tmp_path / "bar.gcode", **slicing.PRUSA_MIXED)
    long_grip = write_case(tmp_path, name="grip10.toml", within=10.0)
    for lc, engine in ((long_grip, "swarm"), (long_grip, "streamlines"), (case, "swarm")):
        program, result, out = run(gpath, lc, tmp_path / f"{engine}.gcode", replace="sparse", engine=engine)
        kinds = _kinds(result)
        sparse = {i for i, k in kinds.items() if k == "sparse"}
        assert len(sparse) == 6 and replaced_blocks(result) == sparse, result.warnings
        pitches = [u.pitch for j in result.pipeline.jobs for u in j.units]
        assert len(pitches) == 6
        assert max(pitches) < 0.9 * 2.035  # denser than the lines' spacing: the slicer's plastic per area
        for r in result.pipeline.splice.blocks:
            assert abs(r.volume_ratio - 1) < 0.03


def test_several_extruders_infill_keeps_its_tool(tmp_path, test_stls, case):
    """PrusaSlicer multi-material from config: infill on extruder 2; new infill still runs on T1."""
    gpath = slicing.slice_prusa(
        test_stls("ohs"),
        tmp_path / "mmu.gcode",
        **slicing.PRUSA_MIXED,
        nozzle_diameter="0.4,0.4",
        infill_extruder=2,
        solid_infill_extruder=2,
        wipe_tower=0,
    )
    program, result, out = run(gpath, case, tmp_path / "out.gcode")
    assert replaced_blocks(result)
    tools = {int(program.state.tool[program.block(i).start]) for i in replaced_blocks(result)}
    assert tools == {1}
    mask = new_lines(result, program)
    ext = np.flatnonzero(mask & (out.kind_of_line == 1))
    assert set(out.state.tool[ext].tolist()) == {1}
    assert program.text.count("\nT1") == out.text.count("\nT1") > 0


def test_purges_into_infill_are_kept(tmp_path, test_stls, case):
    """wipe_into_infill: the infill block printed right after a tool change takes the purge: kept."""
    gpath = slicing.slice_prusa(
        test_stls("ohs"),
        tmp_path / "purge.gcode",
        **slicing.PRUSA_MIXED,
        nozzle_diameter="0.4,0.4",
        infill_extruder=2,
        solid_infill_extruder=2,
        wipe_tower=1,
        wipe_into_infill=1,
    )
    from loadpath.pipeline.units import purge_blocks

    program = gcode.read(gpath)
    purges = purge_blocks(program)
    assert purges
    program, result, out = run(gpath, case, tmp_path / "out.gcode", replace="solid,sparse,bottom")
    assert not purges & replaced_blocks(result)
    for i in purges:
        assert span_lines_kept(program, out, result, i)


def test_variable_layer_height(sliced, case, tmp_path):
    """Cura's adaptive layers (0.2, 0.25, 0.3 mm): paths are regenerated per distinct layer height."""
    gpath = sliced(
        "cura",
        "ohs",
        "solid",
        adaptive_layer_height_enabled="true",
        adaptive_layer_height_variation=0.1,
        adaptive_layer_height_variation_step=0.05,
    )
    program = gcode.read(gpath)
    heights = {round(layer.height, 3) for layer in program.layers[1:]}
    assert len(heights) >= 2
    program, result, out = run(gpath, case, tmp_path / "out.gcode", replace="solid,sparse")
    job_heights = {round(j.units[0].height, 3) for j in result.pipeline.jobs}
    assert len(job_heights) >= 2
    assert result.pipeline.check.problems == []


def test_infill_every_n_layers_keeps_combined_thickness(tmp_path, test_stls, case):
    """infill_every_layers = 2: the combined 0.4 mm sparse infill is replaced at 0.4 mm."""
    gpath = slicing.slice_prusa(
        test_stls("ohs"), tmp_path / "every2.gcode", **slicing.PRUSA_MIXED, infill_every_layers=2
    )
    program, result, out = run(gpath, case, tmp_path / "out.gcode", replace="sparse")
    reps = result.pipeline.splice.blocks
    assert 0.4 in {round(r.height, 3) for r in reps}
    combined = [b for b in program.blocks_of(4) if b.feature == "Internal infill"]
    assert combined and program.height_of_line[combined[0].stop - 1] == pytest.approx(0.4)
    assert all(abs(r.volume_ratio - 1) < 0.03 for r in reps)
    mask = new_lines(result, program)
    assert any(out.line(int(i)) == ";HEIGHT:0.4" for i in np.flatnonzero(mask))


def test_cura_combined_sparse_infill_keeps_its_flow(sliced, case, tmp_path):
    """Cura's infill_sparse_thickness = 0.4 on 0.2 mm layers: every other layer prints the sparse infill
    at double flow; the new paths keep that flow (volume within 3 %)."""
    gpath = sliced("cura", "ohs", "mixed", infill_sparse_thickness=0.4)
    program, result, out = run(gpath, case, tmp_path / "out.gcode", replace="sparse")
    units = [u for j in result.pipeline.jobs for u in j.units]
    assert any(u.flow_width > 0.7 for u in units)  # the combined layers (flow width 0.8 at 0.2 mm)
    done = replaced_blocks(result)
    assert {b.block_index for u in units for b in u.blocks} == done
    assert all(abs(r.volume_ratio - 1) < 0.03 for r in result.pipeline.splice.blocks)


@pytest.mark.parametrize(
    "what,overrides,part",
    [
        ("vase", {"spiral_vase": 1, "perimeters": 1, "top_solid_layers": 0, "fill_density": "0%"}, "ohs"),
        # the tower's spiral ramps its flow up over a 16 mm climbing move at 15 % of the bead: refused
        # as a damaged wall before 2026-12-07 (gcode.bounds)
        ("vase", {"spiral_vase": 1, "perimeters": 1, "top_solid_layers": 0, "fill_density": "0%"}, "tower"),
        (
            "sequential",
            {"complete_objects": 1, "extruder_clearance_radius": 10, "extruder_clearance_height": 5},
            "two_objects",
        ),
    ],
)
def test_vase_mode_and_sequential_printing_pass_through(tmp_path, test_stls, case, what, overrides, part):
    gpath = slicing.slice_prusa(
        test_stls(part), tmp_path / f"{what}.gcode", **{**slicing.PRUSA_MIXED, **overrides}
    )
    program, result, out = run(gpath, case, tmp_path / "out.gcode")
    assert (tmp_path / "out.gcode").read_bytes() == gpath.read_bytes()
    assert not result.changed
    assert any(("vase" if what == "vase" else "sequential") in w for w in result.warnings)


def test_arcs_in_kept_blocks_current_prusaslicer(tmp_path, case):
    """PrusaSlicer 2.9.2 with arc fitting and M486 labels: arcs are read as geometry, new paths are lines."""
    src = DATA / "current" / "prusaslicer-2.9.2-calicat-mini-arcs-m486.gcode"
    program, result, out = run(src, write_case(tmp_path, base=True), tmp_path / "out.gcode")
    assert replaced_blocks(result)
    assert out.moves["arc"].any()
    mask = new_lines(result, program)
    assert not np.any(np.isin(out.state.cmd[mask], (10_002, 10_003)))  # no G2/G3 among new lines
    assert result.pipeline.check.problems == []


def test_binary_gcode_in_binary_out(tmp_path, case):
    from loadpath.gcode import bgcode

    src = DATA / "bgcode" / "mini_cube_ps2.8.1.bgcode"
    program, result, _ = run(src, case, tmp_path / "out.bgcode")
    data = (tmp_path / "out.bgcode").read_bytes()
    assert bgcode.is_bgcode(data)
    back = bgcode.decode(data)
    orig = bgcode.decode(src.read_bytes())
    assert [(m.kind, m.items) for m in back.metadata] == [(m.kind, m.items) for m in orig.metadata]
    assert [t.data for t in back.thumbnails] == [t.data for t in orig.thumbnails]
    assert result.changed and replaced_blocks(result)
    assert layer_features(gcode.parse(back.gcode_bytes)) == layer_features(program)
