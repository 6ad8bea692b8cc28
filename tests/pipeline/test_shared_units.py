"""Several blocks of one kind in one island print one unit's runs and share its plastic (share_volume).

Under a sloped top, both slicers print the internal infill and the solid infill under the top skin
as separate blocks of one island, and at 100 % both are solid: one unit, whose linked runs cross
from one block's region into the other's.  Each run goes to the block holding its middle, so before
the plastic was shared a block could get 1.38x its own (a tapered cantilever at PrusaSlicer 100 %:
23 blocks kept as sliced beside their siblings' runs; CuraEngine 100 % on an angle bracket: 19).
"""

from __future__ import annotations

from dataclasses import replace

import manifold3d as mf
import pytest
import slicing
from pipeline_helpers import replaced_blocks, run, write_case


def _angle_stl(folder):
    # a 30 x 16 x 3 mm flange with a 3 mm wall 6 mm tall along one end: under the flange's top skin
    # CuraEngine prints the skin and, under the wall, the infill, both solid at 100 %
    mesh = mf.Manifold.cube((30.0, 16.0, 3.0)) + mf.Manifold.cube((3.0, 16.0, 6.0))
    return slicing.write_stl(slicing._at_origin(slicing._to_trimesh(mesh)), folder / "angle.stl")


@pytest.mark.parametrize("slicer", ["prusa", "cura"])
def test_blocks_of_one_unit_share_its_plastic(tmp_path, slicer):
    from conftest import require_tool

    if slicer == "prusa":
        require_tool("prusa-slicer")
        stl = slicing.write_stl(slicing.taper_mesh(40.0, 12.0, 3.0, 1.0), tmp_path / "taper.stl")
        gpath = slicing.slice_prusa([stl], tmp_path / "part.gcode", **slicing.PRUSA_SOLID)
    else:
        require_tool("CuraEngine")
        settings = dict(slicing.CURA_SOLID, top_layers="4")
        gpath = slicing.slice_cura(_angle_stl(tmp_path), tmp_path / "part.gcode", **settings)
    case = write_case(tmp_path, within=4.0)
    program, result, out = run(gpath, case, tmp_path / "out.gcode")
    assert out is not None, result.error
    geo = result.pipeline.geometry
    shared = [
        [b.block_index for b in isl.blocks if b.kind == "solid"]
        for o in geo.objects for lg in o.layers for isl in lg.islands
    ]
    shared = [ids for ids in shared if len(ids) > 1]
    assert len(shared) >= 3  # two solid blocks in one island, layer after layer
    done = replaced_blocks(result)
    reports = {r.block: r for r in result.pipeline.splice.blocks}
    scales = []
    for ids in shared:
        assert set(ids) <= done, (ids, result.warnings)
        old = sum(reports[i].filament_old for i in ids)
        new = sum(reports[i].filament_new for i in ids)
        assert abs(new / old - 1.0) < 0.03  # the unit lays the slicer's plastic
        scales += [reports[i].volume_scale for i in ids]
    # the runs' shares, not the slicer's: some block takes more than its own plastic, some less
    assert max(scales) > 1.005 and min(scales) < 0.97


def test_a_unit_prints_whole_or_as_sliced(tmp_path, monkeypatch):
    """Where the splice keeps one block of a shared unit as sliced (here provoked: its aim doubled,
    beyond the flow correction), the blocks printing the same runs are kept with it, each with a
    warning naming why; the other units are replaced and the job's checks pass."""
    from conftest import require_tool
    from loadpath import pipeline

    require_tool("prusa-slicer")
    stl = slicing.write_stl(slicing.taper_mesh(40.0, 12.0, 3.0, 1.0), tmp_path / "taper.stl")
    gpath = slicing.slice_prusa([stl], tmp_path / "part.gcode", **slicing.PRUSA_SOLID)
    real = pipeline.share_volume
    spoiled = []

    def spoil(fills, units, filament):
        out = real(fills, units, filament)
        k = next(i for i, f in enumerate(out) if f.shared)
        spoiled.append(out[k].block)
        out[k] = replace(out[k], volume_scale=2.0 * out[k].volume_scale)
        return out

    monkeypatch.setattr(pipeline, "share_volume", spoil)
    program, result, out = run(gpath, write_case(tmp_path, within=4.0), tmp_path / "out.gcode")
    assert out is not None, result.error
    bad = spoiled[-1]
    unit = next(
        [b.block_index for b in isl.blocks if b.kind == "solid"]
        for o in result.pipeline.geometry.objects for lg in o.layers for isl in lg.islands
        if bad in [b.block_index for b in isl.blocks]
    )
    skipped = dict(result.pipeline.splice.skipped)
    assert set(unit) <= set(skipped) and len(unit) > 1
    feature = program.block(bad).feature
    for i in set(unit) - {bad}:
        assert skipped[i].startswith(f"the {feature} beside it, which shares its runs, was kept as sliced: ")
    assert any("which shares its runs" in w for w in result.warnings), result.warnings
    assert len(replaced_blocks(result)) >= 10  # the other units as before
