"""A unit whose linked runs fall in fewer blocks than it has: the others are emptied, not the unit kept.

PrusaSlicer prints a layer's gyroid of one island in several ``Internal infill`` blocks; linked, the
island's new infill is one or two runs, and each run goes to the block holding its middle.  Before
2026-12-07 the blocks left without a run were kept as sliced ("no new path fits in its 324.6 mm of
bead") and the block holding the runs aimed at its own plastic only, extruding up to 523 % of it, so
the whole unit was kept as sliced: 1 layer of 9 on this gear.
"""

from __future__ import annotations

import math

import pytest
import slicing
import trimesh
from loadpath import gcode
from loadpath.gcode.flavors import Role
from loadpath.plugin.job import JobRequest, run_job
from shapely.geometry import Point, Polygon

GEAR_CASE = """\
version = 1
frame = "part"
[[supports]]
name = "hub"
where = { hole_near = [22.0, 22.0] }
fix = ["x", "y", "z"]
[[loads]]
name = "tooth"
where = { side = "x_max", within = 3.0 }
force = [0.0, 200.0, 0.0]
"""

GYROID = {
    "fill_density": "20%", "fill_pattern": "gyroid", "layer_height": "0.3", "first_layer_height": "0.3",
    "perimeters": "2", "top_solid_layers": "2", "bottom_solid_layers": "2",
    "top_solid_min_thickness": "0", "bottom_solid_min_thickness": "0",
}


def gear_mesh() -> trimesh.Trimesh:
    """24 square teeth on radii 19 / 22 mm, a 4 mm hub hole, 4 mm thick (13 layers at 0.3 mm)."""
    n = 24 * 8
    pts = [
        ((22 if (k // 4) % 2 else 19) * math.cos(2 * math.pi * k / n),
         (22 if (k // 4) % 2 else 19) * math.sin(2 * math.pi * k / n))
        for k in range(n)
    ]
    mesh = trimesh.creation.extrude_polygon(Polygon(pts).difference(Point(0, 0).buffer(4, 64)), 4.0)
    mesh.apply_translation(-mesh.bounds[0])
    return mesh


def _infill_e(program) -> dict[int, float]:
    """Filament of the sparse infill per layer, mm."""
    m = program.moves
    sel = m["extrude"] & (m["role"] == int(Role.SPARSE_INFILL))
    out: dict[int, float] = {}
    for layer, e in zip(m["layer"][sel].tolist(), m["e"][sel].tolist(), strict=True):
        out[layer] = out.get(layer, 0.0) + e
    return out


@pytest.fixture(scope="module")
def gear(tmp_path_factory):
    folder = tmp_path_factory.mktemp("gear")
    stl = slicing.write_stl(gear_mesh(), folder / "gear.stl")
    src = slicing.slice_prusa(stl, folder / "gear.gcode", **GYROID)
    case = folder / "gear.toml"
    case.write_text(GEAR_CASE, encoding="utf-8")
    return src, case


def test_every_sparse_layer_of_the_gear_is_replaced_with_its_blocks_emptied(gear, tmp_path):
    src, case = gear
    out = tmp_path / "out.gcode"
    cli = {"cache": False, "replace": ("sparse",), "engine": "levelset", "density": "energy"}
    res = run_job(JobRequest(src, case, output=out, cli=cli))
    assert res.error is None, res.error
    assert not any("kept as sliced" in w for w in res.warnings), res.warnings
    reports = res.pipeline.splice.blocks
    emptied = [r for r in reports if r.n_paths == 0]
    assert emptied and all(r.filament_new == 0 and r.volume_scale == 0 for r in emptied)
    program, new = gcode.read(src), gcode.read(out)
    sparse_layers = {program.block(r.block).layer for r in reports}
    assert sparse_layers == {b.layer for b in map(program.block, range(len(program.blocks)))
                             if b.role == Role.SPARSE_INFILL}
    # each layer keeps the slicer's sparse plastic: the emptied blocks' went to their siblings
    before, after = _infill_e(program), _infill_e(new)
    for layer in sparse_layers:
        assert after[layer] == pytest.approx(before[layer], rel=0.03)
