"""Lean output (issue 17): the default bead runs write far fewer lines than the fine ones, same beads.

The same paths (from the result cache) are spliced twice into a real PrusaSlicer 2.5 solid part:
with the former fine settings (width step 5 %, tolerance 10 % of the flow width) and with the
defaults.  Both pass the splice check; the defaults' file is much smaller, and the beads it prints
(each extruding move buffered by half its ``;WIDTH:``) cover the same area within 1 %.

With linking (issue 19) on, this failed until the bead runs cut at sharp turns: a linked run's
hairpins misled the simplification's material test (lean 860,623 bytes against fine 733,294; now
464,347 against 715,873, unlinked 450,508 against 708,590).  Linked runs are now simplified
within 10 % of the flow width (``RunOptions.linked_resolution``; 40 % lowered the predicted
stiffness): the fine settings here take 5 % for them (lean 673,389 bytes against fine 1,001,032).

Linked *sparse* runs take their own bound (``RunOptions.sparse_resolution``): their beads lie apart,
so the slits that held the solid runs to 10 % cannot open; on a real 20 % gyroid L-bracket the lines
printed fall and every printed vertex stays within the two bounds of the finer file's beads.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import shapely
import slicing
from cases import BRACKET_PIN
from loadpath import gcode, loadcase, pipeline
from loadpath.cache import Cache
from loadpath.splice.beadruns import RunOptions
from loadpath.plugin import settings as settings_mod

CASE = """version = 1
[[supports]]
name = "clamp"
where = { side = "x_min", within = 10.0 }
fix = ["x", "y", "z"]
[[loads]]
name = "pull"
where = { side = "x_max", within = 1.0 }
force = [1000.0, 0.0, 0.0]
"""


def _extrusions(program, result) -> dict[int, np.ndarray]:
    """Per replaced block: its extruding moves in the output, ``(n, 5)``: x0 y0 x1 y1 width (mm)."""
    moves = gcode.parse(result.data, strict=False).moves
    out = {}
    for br in result.splice.blocks:
        sel = np.zeros(len(moves), dtype=bool)
        for a, z in result.splice.output_ranges(program, br.block):
            sel |= (moves["line"] >= a) & (moves["line"] < z)
        m = moves[sel & moves["extrude"]]
        out[br.block] = np.column_stack([m["x0"], m["y0"], m["x1"], m["y1"], m["width"]])
    return out


def _beads(program, result) -> dict[int, shapely.Geometry]:
    """Per replaced block: the union of its printed beads in the output."""
    out = {}
    for block, e in _extrusions(program, result).items():
        lines = shapely.linestrings(np.stack([e[:, 0:2], e[:, 2:4]], axis=1))
        out[block] = shapely.union_all(shapely.buffer(lines, e[:, 4] / 2, cap_style="flat"))
    return out


def test_default_runs_write_fewer_lines_and_the_same_beads(sliced, tmp_path):
    gpath = sliced("prusa", "ohs", "example")
    program = gcode.read(gpath)
    case_path = tmp_path / "case.toml"
    case_path.write_text(CASE, encoding="utf-8")
    case = loadcase.read(case_path)
    s = settings_mod.resolve(program, toolpath=case.toolpath, cli={"engine": "streamlines"})
    lean = settings_mod.splice_options(s)
    assert lean.runs == RunOptions()
    fine = dataclasses.replace(
        lean, runs=dataclasses.replace(lean.runs, width_step=0.05, resolution=0.10, linked_resolution=0.05)
    )
    opts = pipeline.PipelineOptions(engine="streamlines", workers=1)
    cache = Cache(tmp_path / "cache")
    r_fine = pipeline.run(program, case, opts, fine, cache=cache)
    r_lean = pipeline.run(program, case, opts, lean, cache=cache)
    assert cache.stats.misses.get("paths", 0) == cache.stats.hits.get("paths", 0) > 0  # same paths
    assert not r_fine.check.problems and not r_lean.check.problems
    assert [b.block for b in r_lean.splice.blocks] == [b.block for b in r_fine.splice.blocks]
    assert len(r_lean.data) < 0.8 * len(r_fine.data)
    assert r_lean.data.count(b";WIDTH:") < 0.6 * r_fine.data.count(b";WIDTH:")
    b_fine, b_lean = _beads(program, r_fine), _beads(program, r_lean)
    area = sum(g.area for g in b_fine.values())
    assert abs(sum(g.area for g in b_lean.values()) / area - 1.0) < 0.01
    assert sum(b_fine[k].symmetric_difference(b_lean[k]).area for k in b_fine) / area < 0.02
    for br in r_lean.splice.blocks:  # the volume of every block is still the slicer's
        assert abs(br.filament_new / br.filament_old - 1.0) < 0.03
    # the linked runs are simplified within their own bound: at the unlinked runs' 40 % the file is
    # smaller (issue 19: the stiffness the 40 % cost on linked zig-zags)
    loose_runs = dataclasses.replace(lean.runs, linked_resolution=lean.runs.resolution)
    loose = dataclasses.replace(lean, runs=loose_runs)
    r_loose = pipeline.run(program, case, opts, loose, cache=cache)
    assert not r_loose.check.problems
    assert len(r_loose.data) < 0.85 * len(r_lean.data)


@pytest.mark.slow
def test_sparse_runs_take_their_own_bound(tmp_path):
    """Linked sparse runs are simplified within ``RunOptions.sparse_resolution``, not the solid runs'
    ``linked_resolution``: fewer lines, every printed vertex within the two bounds of the finer
    file's beads, the same plastic per block (the beads lie apart, so no slit opens between them)."""
    src, case_path = slicing.gyroid_bracket(tmp_path, BRACKET_PIN)
    program = gcode.read(src)
    case = loadcase.read(case_path)
    lean = settings_mod.splice_options(settings_mod.resolve(program, toolpath=case.toolpath))
    runs = lean.runs
    assert runs.bound(True, True) == runs.sparse_resolution > runs.linked_resolution
    assert runs.bound(True, False) == runs.linked_resolution
    fine = dataclasses.replace(lean, runs=dataclasses.replace(runs, sparse_resolution=runs.linked_resolution))
    opts = pipeline.PipelineOptions(replace=("sparse",), workers=1)
    cache = Cache(tmp_path / "cache")
    r_fine = pipeline.run(program, case, opts, fine, cache=cache)
    r_lean = pipeline.run(program, case, opts, lean, cache=cache)
    assert cache.stats.hits.get("paths", 0) > 0  # the same paths, spliced twice
    assert not r_fine.check.problems and not r_lean.check.problems
    blocks = [b.block for b in r_lean.splice.blocks]
    assert blocks and blocks == [b.block for b in r_fine.splice.blocks]
    n_lean = n_fine = 0
    width = float(np.median([b.width_max for b in r_lean.splice.blocks]))
    reach = (runs.sparse_resolution + runs.linked_resolution + 0.02) * width
    ext_lean, ext_fine = _extrusions(program, r_lean), _extrusions(program, r_fine)
    for br_l, br_f in zip(r_lean.splice.blocks, r_fine.splice.blocks, strict=True):
        assert br_l.filament_new == pytest.approx(br_f.filament_new, rel=0.03)
        el, ef = ext_lean[br_l.block][:, :4], ext_fine[br_f.block][:, :4]
        n_lean, n_fine = n_lean + len(el), n_fine + len(ef)
        beads = shapely.linestrings(np.stack([ef[:, :2], ef[:, 2:]], axis=1))
        far = shapely.distance(shapely.union_all(beads), shapely.points(el[:, 2:]))
        assert float(far.max()) <= reach, (br_l.block, float(far.max()), reach)
    assert n_lean < 0.85 * n_fine, (n_lean, n_fine)
