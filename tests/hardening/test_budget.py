"""Stage budgets (#20): geometry, meshing and the engines stop with one line before unbounded work.

The bounds keep coordinates on the bed; these budgets (:mod:`loadpath.budget`) keep what a file or a
setting asks of a stage within reach.  The real cases:

- the committed OrcaSlicer P1S cube with the extrusion of one sparse block of layer 95 cut a
  thousandfold (a damaged E column): its bead width shrinks as much, and the geometry's
  nearest-lines split sampled 153 mm of lines every 0.0004 mm (384,475 samples).  Before the budget ``inspect`` ran
  past a minute inside GEOS's Voronoi (SIGTERM could not stop it); now it stops at layer 95;
- the shipped specimen at the smallest accepted ``--pitch`` (0.05 mm): about 2 million pitch cells
  per layer for the path engine, refused before the FEA;
- the specimen's real outline meshed at 0.01 mm: refused before gmsh runs.

The budgets no real part reaches (gmsh's node count after meshing, segments per layer) are hit by
lowering them on a real part: the check is the same at any value.
"""

from __future__ import annotations

import re

import pytest
from loadpath import budget, gcode, geometry
from loadpath.errors import BudgetError
from loadpath.mesh.gmsh_mesher import mesh_2d
from loadpath.mesh.sizing import MeshSize, default_mesh_size
from loadpath.plugin.cli import main

ORCA = "tests/data/published/orcaslicer-2.3.1-bambu-p1s-cube20.gcode"
OHS = "examples/ohs.gcode"


def _one_line(capsys, code: int) -> str:
    err = capsys.readouterr().err.strip()
    assert code == 1, err
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("loadpath: "), err
    return lines[0]


def _thin_block(repo_root, tmp_path, scale: float = 1e-3):
    """The P1S cube with the E of layer 95's first sparse infill block scaled by ``scale``."""
    rows = (repo_root / ORCA).read_bytes().split(b"\n")
    start = rows.index(b"; Z_HEIGHT: 19")
    first = next(i for i in range(start, len(rows)) if rows[i] == b"; FEATURE: Sparse infill")
    stop = next(i for i in range(first + 1, len(rows)) if rows[i].startswith(b"; FEATURE:"))
    for i in range(first, stop):
        if rows[i].startswith(b"G1"):
            rows[i] = re.sub(rb"E(-?[0-9.]+)", lambda m: b"E%.6f" % (float(m.group(1)) * scale), rows[i])
    out = tmp_path / "thin.gcode"
    out.write_bytes(b"\n".join(rows))
    return out


def test_a_thousandfold_thinner_sparse_block_stops_at_the_split_budget(repo_root, tmp_path, capsys):
    path = _thin_block(repo_root, tmp_path)
    before = path.read_bytes()
    line = _one_line(capsys, main(["inspect", str(path)]))
    assert line.startswith("loadpath: layer 95 (z = 19 mm), object 'Object_1': "), line
    assert "samples of the nearest-lines split" in line and "exceed the budget of 100,000" in line, line
    assert "check the ;WIDTH: lines and the extrusion (E)" in line, line
    assert path.read_bytes() == before


def test_the_smallest_pitch_on_the_specimen_stops_before_the_fea(repo_root, tmp_path, capsys):
    case = tmp_path / "case.toml"
    case.write_text((repo_root / "examples" / "ohs.toml").read_text())
    out = tmp_path / "out.gcode"
    code = main(["run", str(repo_root / OHS), "--loadcase", str(case), "-o", str(out), "--pitch", "0.05",
                 "--no-cache"])
    line = _one_line(capsys, code)
    assert re.match(r"loadpath: layer \d+ \(z = [0-9.]+ mm\), object '[^']+': [0-9,]+ pitch cells for the path "
                    r"engine \([0-9,]+ mm2 of solid infill at a 0.05 mm pitch\) exceed the budget of 500,000; "
                    r"set a larger --pitch", line), line
    assert "was not written" in line and not out.exists()


@pytest.fixture(scope="module")
def specimen_outline(repo_root):
    program = gcode.read(repo_root / OHS)
    return geometry.layer_geometry(program, check=False).bodies()[0].slabs[0].outline


def test_a_mesh_far_too_fine_is_refused_before_gmsh(specimen_outline):
    with pytest.raises(BudgetError, match=r"^[0-9,]+ triangles estimated for the mesh \(5,[0-9]{3} mm2 at 0.01 mm.* "
                                          r"exceed the budget of 1,000,000; .*set a larger --pitch"):
        mesh_2d(specimen_outline, MeshSize.uniform(0.01))


def test_the_mesh_estimate_is_near_gmsh_on_the_specimen(specimen_outline):
    sz = default_mesh_size(specimen_outline, 0.45)
    holes = sum(r.length for r in specimen_outline.interiors)
    est = budget.mesh_elements_estimate(specimen_outline.area, sz.h, sz.h_min, sz.grading, holes, 0)
    n = len(mesh_2d(specimen_outline, sz).cells)
    assert 0.5 * n < est < 2.0 * n, (est, n)


def test_gmsh_node_count_over_budget_is_a_budget_error_not_a_meshing_failure(specimen_outline, monkeypatch):
    monkeypatch.setattr(budget, "MESH_NODES", 100)
    with pytest.raises(BudgetError, match=r"^[0-9,]+ mesh nodes from gmsh exceed the budget of 100; "):
        mesh_2d(specimen_outline, default_mesh_size(specimen_outline, 0.45))


def test_mesh_budget_through_run_names_the_object(repo_root, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(budget, "MESH_ELEMENTS", 100)
    case = tmp_path / "case.toml"
    case.write_text((repo_root / "examples" / "ohs.toml").read_text())
    code = main(["run", str(repo_root / OHS), "--loadcase", str(case), "-o", str(tmp_path / "o.gcode"),
                 "--no-cache"])
    line = _one_line(capsys, code)
    assert re.match(r"loadpath: object '[^']+' \(z = 0\.\.[0-9.]+ mm\), its FEA mesh: [0-9,]+ triangles "
                    r"estimated", line), line


def test_segments_per_layer_over_budget_names_the_layer(repo_root, capsys, monkeypatch):
    monkeypatch.setattr(budget, "LAYER_SEGMENTS", 100)
    line = _one_line(capsys, main(["inspect", str(repo_root / OHS)]))
    assert re.match(r"loadpath: layer 1 \(z = 0.2 mm\), object '[^']+': [0-9,]+ extrusion segments exceed the "
                    r"budget of 100; check the file", line), line


def test_budgets_are_not_a_number_proof():
    with pytest.raises(BudgetError, match="nan"):
        budget.check(float("nan"), 10, "layer 1", "samples", "fix")
    budget.check(10, 10, "layer 1", "samples", "fix")
