"""``loadpath run`` on CuraEngine files sliced with settings other than the suite's defaults.

Each case is a real slice (CuraEngine 4.13; one PrusaSlicer 2.5) that two sweeps of new parts and
slicer settings (2026-12-07) found mishandled: a run that failed on a valid file, an output a
printer would print badly, or a message that misled.
"""

from __future__ import annotations

import cases
import numpy as np
import slicing
from cases import BRACKET_TIP, GRIP_PULL
from loadpath import gcode
from loadpath.gcode.words import G, M
from loadpath.plugin.job import JobRequest, run_job
from loadpath.splice.rewrite import STOOD_MM


def _run(tmp_path, src, case_text: str, **cli):
    case = tmp_path / "case.toml"
    case.write_text(case_text, encoding="utf-8")
    out = tmp_path / "out.gcode"
    res = run_job(JobRequest(src, case, output=out, cli={"cache": False, **cli}))
    return res, out


def test_relative_e_leaves_the_logical_e_of_the_end_code(tmp_path, sliced):
    """CuraEngine's end code switches to absolute E (``M82``) after a relative-E print: there the
    logical E must be the slicer's, though the new blocks' plastic differs from theirs by round-off
    (the L-bracket's blocks by 1-2 um each: the check refused the whole run)."""
    src = sliced("cura", "bracket", "solid", relative_extrusion="true")
    res, out = _run(tmp_path, src, BRACKET_TIP)
    assert res.error is None and out.is_file()
    a, b = gcode.read(src), gcode.read(out)
    ia = [int(i) for i in np.flatnonzero(a.state.cmd == M + 82)]
    ib = [int(i) for i in np.flatnonzero(b.state.cmd == M + 82)]
    last_a, last_b = ia[-1], ib[-1]
    assert last_a > a.layers[-1].start and last_b > b.layers[-1].start  # the end code's
    assert abs(float(b.state.e[last_b]) - float(a.state.e[last_a])) <= 2e-5
    # relative E all through the print: the blocks' plastic is not the slicer's to the micrometre
    # (read back from the text: each block's written E against the slicer's)
    sres = res.pipeline.splice
    off = []
    for r in sres.blocks:
        got = sum(
            float(b.moves["e"][b.move_rows(x, y)][b.moves["extrude"][b.move_rows(x, y)]].sum())
            for x, y in sres.output_ranges(a, r.block)
        )
        off.append(abs(got - r.filament_old))
    assert max(off) > 1e-6, off


def test_a_part_without_skins_keeps_the_default_filament_diameter(tmp_path, sliced):
    """Without top and bottom layers the first layer's 20 % infill is the part's exposed bottom; its
    lines 4 mm apart were read as solid infill and gave a 5.5 mm filament, and the run was refused."""
    src = sliced("cura", "ohs", "mixed", top_layers=0, bottom_layers=0, initial_bottom_layers=0)
    res, out = _run(tmp_path, src, GRIP_PULL, replace=("solid", "sparse"))
    assert res.error is None and out.is_file()
    assert res.settings.filament_diameter == 1.75


def test_the_infill_wipe_is_not_dragged_across_the_part(tmp_path, sliced):
    """CuraEngine ends its infill with a 0.04 mm ``G1`` past the last line (``infill_wipe_dist``) and
    changes layer with ``G0 F600 X.. Y.. Z..`` where the nozzle stands.  Kept after the new paths,
    which end elsewhere, the wipe crossed the part at print speed, primed: the run travels back to
    where the slicer's infill ended first, as a travel."""
    src = sliced("cura", "shelf", "mixed")  # before: two such moves, 59 and 43 mm, on its 2 solid layers
    res, out = _run(tmp_path, src, GRIP_PULL)
    assert res.error is None
    for path in (src, out):  # CuraEngine travels with G0: a G1 that extrudes nothing is a wipe
        p = gcode.read(path)
        m = p.moves
        g1 = p.state.cmd[m["line"]] == G + 1
        length = np.hypot(m["x1"] - m["x0"], m["y1"] - m["y0"])
        dragged = g1 & (m["e"] == 0) & (length > STOOD_MM) & (m["layer"] >= 0)  # not the start code's
        first = int(m["line"][dragged][0]) + 1 if dragged.any() else 0
        assert not dragged.any(), f"{path.name}: {int(dragged.sum())} moves, the first at line {first}"


def test_a_block_with_no_region_of_its_own_is_kept_not_fatal(tmp_path, sliced):
    """Where a thin neck leaves a skin block no region of its own (other blocks cover its area), the
    run keeps it as sliced, as ``loadpath inspect`` says it will; the Cura diameter measure read the
    geometry with its strict check and refused the file ("runs inf mm outside ... the perimeters do
    not enclose the infill")."""
    import manifold3d as mf

    def rect(x0, y0, x1, y1):
        return mf.CrossSection([[(x0, y0), (x1, y0), (x1, y1), (x0, y1)]])

    # two 20 mm pads joined by a 2.5 mm neck, 3 mm thick; CuraEngine 40 % grid, 3 walls, 0.15 mm layers
    outline = rect(0, 0, 20, 20) + rect(20, 8.75, 40, 11.25) + rect(40, 0, 60, 20)
    stl = slicing.write_stl(slicing._to_trimesh(mf.Manifold.extrude(outline, 3.0)), tmp_path / "neck.stl")
    src = slicing.slice_cura(
        stl, tmp_path / "neck.gcode", layer_height="0.15", layer_height_0="0.2", infill_sparse_density="40",
        infill_line_distance="2.0", infill_pattern="grid", top_layers="3", bottom_layers="3",
        initial_bottom_layers="3", wall_line_count="3",
    )
    res, out = _run(tmp_path, src, GRIP_PULL)
    assert res.error is None and out.is_file(), res.error
    assert any("kept as sliced (it has no region of its own" in w for w in res.warnings), res.warnings


def test_no_sparse_density_clause_when_no_sparse_infill_was_replaced(tmp_path, sliced):
    """An 8 x 5 mm part at 20 % gyroid: no new path fits in its sparse blocks, so all are kept as
    sliced; the verdict spoke of the sparse density it chose all the same."""
    import manifold3d as mf

    hole = mf.CrossSection.circle(1.2, 24).translate((4, 2.5))
    outline = mf.CrossSection([[(0, 0), (8, 0), (8, 5), (0, 5)]]) - hole
    stl = slicing.write_stl(slicing._to_trimesh(mf.Manifold.extrude(outline, 2.0)), tmp_path / "tiny.stl")
    src = slicing.slice_cura(
        stl, tmp_path / "tiny.gcode", layer_height="0.3", layer_height_0="0.3", infill_sparse_density="20",
        infill_line_distance="2.0", infill_pattern="gyroid", top_layers="2", bottom_layers="2",
        initial_bottom_layers="2", wall_line_count="2",
    )
    res, out = _run(tmp_path, src, cases.side_case((100.0, 0.0, 0.0), held_within=1.5, loaded_within=1.5),
                    replace=("solid", "sparse"))
    assert res.error is None and any("FILL: kept as sliced" in w for w in res.warnings), res.warnings
    line = res.verdict.line()
    assert "sparse" not in res.verdict.kinds and "sparse density" not in line, line


def test_a_spiral_vase_is_passed_through_as_one(tmp_path, sliced):
    """CuraEngine writes no settings, so its spiralized vase was not known as one: the run said it had
    nothing to replace and suggested replace = ["solid", "sparse"], which it had been given.  Its
    walls climb as they print: that says vase mode whatever the settings say."""
    src = sliced("cura", "ohs", "mixed", magic_spiralize="true")
    res, out = _run(tmp_path, src, GRIP_PULL, replace=("solid", "sparse"))
    assert res.error is None and not res.pipeline.changed
    assert res.pipeline.passthrough == "vase mode (spiral vase): the part has no infill to replace"


def test_nothing_to_replace_names_what_there_is(tmp_path, sliced):
    """A part at 0 % infill has no sparse infill: the run named only the kinds asked for."""
    src = sliced("prusa", "ohs", "mixed", fill_density="0%")
    res, out = _run(tmp_path, src, GRIP_PULL, replace=("sparse",))
    assert res.error is None and not res.pipeline.changed
    why = [w for w in res.warnings if w.startswith("nothing to replace")]
    assert len(why) == 1 and "they have " in why[0], res.warnings
    have = why[0].split("they have ")[1].split(":")[0].split(", ")
    assert "sparse" not in have and "bottom" in have and "replace = [\"sparse\", " in why[0]


def test_lines_drawn_twice_are_laid_at_their_plastic(tmp_path, sliced):
    """CuraEngine's ``infill_multiplier = 2`` draws each sparse line twice, 0.4 mm apart: that spacing
    was taken as the pitch, the new paths asked for 325 % of the plastic and every sparse block was
    kept, while the verdict described the sparse density it chose."""
    src = sliced("cura", "ohs", "mixed", infill_multiplier="2")
    res, out = _run(tmp_path, src, GRIP_PULL, replace=("solid", "sparse"))
    assert res.error is None and "sparse" in res.verdict.kinds, res.warnings
    assert not any("kept as sliced" in w for w in res.warnings), res.warnings


def test_blocks_the_slicer_lays_twice_over_are_kept_for_that_reason(tmp_path):
    """CuraEngine at 100 % lays four layers under a lever's top skins at 192 % of a solid layer's
    plastic (its skin edge support lines over the infill lines): one layer of new paths extrudes 60 %
    of that, so the blocks are kept as sliced -- rightly -- but the reason blamed the engine ("the
    engine covered too little of the region")."""
    import manifold3d as mf

    bar = mf.CrossSection.square((84.0, 16.0)).translate((8.0, 0.0))
    for x in (8.0, 92.0):
        bar = bar + mf.CrossSection.circle(8.0, 64).translate((x, 8.0))
    for x in (8.0, 92.0):
        bar = bar - mf.CrossSection.circle(3.0, 48).translate((x, 8.0))
    lever = slicing._at_origin(slicing._to_trimesh(mf.Manifold.extrude(bar, 4.0)))
    src = slicing.slice_cura(slicing.write_stl(lever, tmp_path / "lever.stl"), tmp_path / "lever.gcode",
                             **slicing.CURA_SOLID)
    res, _ = _run(tmp_path, src, GRIP_PULL)
    kept = [w for w in res.warnings if "kept as sliced" in w]
    assert kept and all("of a solid layer's plastic in it (lines over lines)" in w for w in kept), kept
    assert not any("the engine covered" in w for w in res.warnings)
