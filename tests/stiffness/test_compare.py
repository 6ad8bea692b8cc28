"""``loadpath compare`` on real slicer output (PrusaSlicer 2.5, CuraEngine 4.13)."""

from __future__ import annotations

import hashlib
import json
import os
import shutil

import pytest
from conftest import REPO
from loadpath.plugin.cli import main

CASE = REPO / "examples" / "ohs.toml"


def digest(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture(scope="module")
def prusa_pair(sliced):
    cross = sliced("prusa", "ohs", "solid")  # rectilinear at 45 degrees, alternating: cross-hatching
    aligned = sliced(
        "prusa",
        "ohs",
        "solid",
        fill_pattern="alignedrectilinear",
        fill_angle=0,
        top_fill_pattern="alignedrectilinear",
        bottom_fill_pattern="alignedrectilinear",
        bottom_solid_layers=1,
        top_solid_layers=1,
    )
    return cross, aligned


@pytest.mark.slow
def test_compare_prints_and_writes_rows_relative_to_the_first_file(prusa_pair, tmp_path, capsys):
    cross, aligned = prusa_pair
    again = tmp_path / "cross_copy.gcode"
    shutil.copyfile(cross, again)
    before = {p: digest(p) for p in (cross, aligned)}
    out = tmp_path / "rows.json"
    rep = tmp_path / "report"
    status = main(
        [
            "compare",
            str(cross),
            str(aligned),
            str(again),
            "--loadcase",
            str(CASE),
            "--json",
            str(out),
            "--report",
            str(rep),
            "--resolution",
            "0.2",
        ]
    )
    assert status == 0
    text = capsys.readouterr().out
    assert "relative" in text.lower() or "rel. stiffness" in text
    rows = json.loads(out.read_text())
    umask = os.umask(0)
    os.umask(umask)
    assert out.stat().st_mode & 0o777 == 0o666 & ~umask  # readable like any file the user makes
    assert [r["file"] for r in rows] == [str(cross), str(aligned), str(again)]
    for r in rows:
        assert {"file", "compliance", "peak_displacement", "relative_stiffness", "beta", "coverage"} <= set(r)
    c, a, c2 = rows
    assert c["relative_stiffness"] == 1.0
    assert c2["compliance"] == c["compliance"] and c2["relative_stiffness"] == 1.0  # same beads, same mesh
    # along the pull the aligned part is stiffer and better aligned; both fill the domain
    assert a["relative_stiffness"] > 1.005
    assert a["compliance"] < c["compliance"] and a["peak_displacement"] < c["peak_displacement"]
    assert a["beta"] > 0.95 > 0.8 > c["beta"]
    assert c["coverage"] > 0.97 and a["coverage"] > 0.97
    # 1000 N on 36 x 2 mm over 150 mm of PLA (E about 3 GPa): about 0.7 mm
    assert 0.4 < c["peak_displacement"] < 1.2
    # issue 14: failure load, safety factor, per-mass figures, where it fails
    for r in rows:
        assert r["failure_load"] > 0 and r["safety_factor"] > 0 and len(r["failure_location"]) == 3
    assert c["relative_failure_load"] == 1.0 and c2["failure_load"] == c["failure_load"]
    assert a["relative_failure_load"] > 1.05  # along its beads the aligned specimen is stronger
    assert a["relative_stiffness_per_mass"] == a["relative_specific_stiffness"]
    assert "at equal mass" in text and "card PLA" in text and "beads fill model" in text
    assert sorted(p.name for p in rep.glob("*.png")) == sorted(
        [
            f"{i:02d}_{stem}_ohs.stl_{kind}.png"
            for i, stem in ((1, cross.stem), (2, aligned.stem), (3, again.stem))
            for kind in ("energy", "orientation")
        ]
        + [f"{i:02d}_gain_{stem}_vs_{cross.stem}_ohs.stl.png" for i, stem in ((2, aligned.stem), (3, again.stem))]
    )
    assert {p: digest(p) for p in (cross, aligned)} == before  # inputs untouched


@pytest.mark.slow
def test_compare_cura_against_prusaslicer_and_the_ceiling(prusa_pair, sliced, tmp_path, capsys):
    cura = sliced("cura", "ohs", "solid")
    out = tmp_path / "rows.json"
    assert (
        main(
            [
                "compare",
                str(prusa_pair[0]),
                str(cura),
                "--loadcase",
                str(CASE),
                "--json",
                str(out),
                "--resolution",
                "0.2",
                "--ceiling",
            ]
        )
        == 0
    )
    rows = json.loads(out.read_text())
    assert rows[-1]["file"] == "(model ceiling)" and rows[-1]["beta"] is None
    # Cura's solid lines also alternate +-45: within a few per cent of PrusaSlicer's cross-hatching
    assert rows[1]["relative_stiffness"] == pytest.approx(1.0, abs=0.05)
    assert rows[-1]["relative_stiffness"] > max(rows[0]["relative_stiffness"], rows[1]["relative_stiffness"])


def test_compare_refuses_a_missing_file_in_one_line(tmp_path, capsys):
    out = tmp_path / "rows.json"
    status = main(["compare", str(tmp_path / "nope.gcode"), "--loadcase", str(CASE), "--json", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 1 and len(err) == 1
    assert "nope.gcode" in err[0] and "check the path" in err[0]
    assert not out.exists()


@pytest.mark.parametrize("model", ["linear", "nmo"])
def test_every_fill_model_gives_a_failure_load(prusa_pair, tmp_path, model):
    """The models other than the bead model measure no fusion or bead transfer; the failure
    criterion takes them as fully fused (``--fill-model linear`` raised an IndexError on a part of
    more than one layer)."""
    out = tmp_path / "rows.json"
    argv = ["compare", *map(str, prusa_pair), "--loadcase", str(CASE), "--json", str(out), "--fill-model", model]
    assert main(argv) == 0
    rows = json.loads(out.read_text())
    assert all(r["failure_load"] > 0 and r["safety_factor"] > 0 and len(r["failure_location"]) == 3 for r in rows)
    assert rows[0]["relative_failure_load"] == 1.0 and rows[1]["relative_failure_load"] > 0


def test_mechanics_only_evaluation_gives_the_same_figures_without_the_path_metrics():
    """``evaluate_file(metrics=False)`` (what ``density = "auto"`` ranks its candidates by) skips the
    isotropic analysis and the path metrics, and predicts the very same stiffness and failure load."""
    import math

    from loadpath import gcode, loadcase
    from loadpath.stiffness.compare import evaluate_file

    program, case = gcode.read(REPO / "examples" / "ohs.gcode"), loadcase.read(CASE)
    meshes: dict = {}
    full = evaluate_file(program, case, meshes=meshes)
    lean = evaluate_file(program, case, meshes=meshes, metrics=False)
    assert full.isotropic and lean.isotropic == ()
    assert math.isfinite(full.beta) and math.isnan(lean.beta) and math.isnan(lean.coverage)
    assert [p.compliance for p in lean.predictions] == [p.compliance for p in full.predictions]
    assert lean.failure_load == full.failure_load


def test_coverage_is_measured_between_the_skins(prusa_ohs):
    """The coverage pools layers from the middle of the part's height, not its first and last
    (the slicer's bottom and top skins on nearly every part, which cover fully whatever the infill):
    on the specimen at 20 % sparse infill it is the coverage of those layers, pooled by area."""
    import math

    from loadpath import gcode, geometry, loadcase, metrics
    from loadpath.stiffness.compare import _coverage_layers, evaluate_file, infill_paths

    program = gcode.read(prusa_ohs)
    result = evaluate_file(program, loadcase.read(CASE))
    geo = geometry.layer_geometry(program, check=False)
    obj = geo.objects[0]
    layers = [g for g in obj.layers if not g.domain.is_empty]
    picked = sorted(_coverage_layers(len(layers)))
    assert 0 not in picked and len(layers) - 1 not in picked and len(picked) == 4
    covered = area = 0.0
    for i in picked:
        g = layers[i]
        paths = infill_paths(program, g.layer_index, obj.code, geo.filament_diameter)
        covered += metrics.coverage(paths, g.domain).coverage * g.domain.area
        area += g.domain.area
    assert math.isclose(result.coverage, covered / area, rel_tol=1e-12)
    skin = layers[0]
    skin_paths = infill_paths(program, skin.layer_index, obj.code, geo.filament_diameter)
    first = metrics.coverage(skin_paths, skin.domain)
    assert first.coverage > 0.95 > result.coverage  # the skins cover; the sparse layers between them do not
