"""``loadpath inspect`` on real files: the table, the pictures, the load case, the errors."""

from __future__ import annotations

import struct

import numpy as np
import pytest
from conftest import REPO
from loadpath.plugin.cli import main


def _table(out: str) -> list[list[str]]:
    lines = out.splitlines()
    start = next(i for i, ln in enumerate(lines) if ln.lstrip().startswith("layer"))
    rows = []
    for ln in lines[start + 1:]:
        if not ln[:6].strip().isdigit():
            break
        rows.append(ln.split(None, 8))  # layer z h islands infill replace kinds group features
    return rows


def _png_size(path) -> tuple[int, int]:
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", path
    return struct.unpack(">II", data[16:24])


def test_table_prusa_specimen(prusa_ohs, capsys):
    assert main(["inspect", str(prusa_ohs)]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[0].endswith(
        "PrusaSlicer 2.5.0, 10 layers (counted from 1), objects: 'ohs.stl' (10 layers)")
    rows = _table(out)
    assert [int(r[0]) for r in rows] == list(range(1, 11))
    assert [float(r[1]) for r in rows] == pytest.approx(np.arange(1, 11) * 0.2)
    assert {r[2] for r in rows} == {"0.200"} and {r[3] for r in rows} == {"1"}
    assert [r[6] for r in rows] == ["bottom", "solid"] + ["sparse"] * 6 + ["bridge", "top"]
    # the specimen's internal domain: 150 x 36 minus the 6 mm hole, inset by 0.836 mm (tests/geometry)
    assert float(rows[4][4]) == pytest.approx(5045.7, abs=1.0)
    assert float(rows[1][5]) == pytest.approx(float(rows[1][4])) and float(rows[4][5]) == 0.0
    assert rows[4][8] == "Perimeter, External perimeter, Internal infill"
    assert "Skirt/Brim" in rows[0][8]


def test_table_cura_two_objects(cura_two_objects, capsys):
    assert main(["inspect", str(cura_two_objects), "--replace", "solid,sparse"]) == 0
    out = capsys.readouterr().out
    assert "objects: 'two_islands.stl' (10 layers), 'bracket.stl' (15 layers)" in out
    assert "replace mm2 (solid+sparse)" in out
    rows = _table(out)
    assert [r[3] for r in rows] == ["3"] * 10 + ["1"] * 5
    assert rows[2][6] == "sparse" and "FILL" in rows[2][8] and "WALL-OUTER" in rows[2][8]
    assert float(rows[2][5]) == pytest.approx(float(rows[2][4]))


def test_pictures_and_load_case(repo_root, tmp_path, capsys):
    gcode = repo_root / "examples" / "ohs.gcode"
    case = repo_root / "examples" / "ohs.toml"
    assert main(["inspect", str(gcode), "--loadcase", str(case), "--png", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "object 'ohs.stl': 2d analysis" in out
    assert ("support 'clamp' (side = \"x_min\", within = 10.0): fix x/y/z; picked boundary length 56.000 mm"
            in out)
    # the end face (36 mm) and 1 mm of each long side
    assert (
        "load 'pull' (side = \"x_max\", within = 1.0): force (1000, 0, 0) N; "
        "picked boundary length 38.000 mm" in out
    )
    assert "lines in x 199.000..200.000, y 87.000..123.000" in out
    names = sorted(p.name for p in tmp_path.iterdir())
    # three distinct layers (bottom, internal solid, top), the selections, one 2D stress field
    assert names == ["layer_0001.png", "layer_0002.png", "layer_0010.png", "selections_ohs.stl.png",
                     "stress_ohs.stl_0001.png"]
    for p in tmp_path.iterdir():
        w, h = _png_size(p)
        assert w > 500 and h > 200
    import matplotlib.image

    img = matplotlib.image.imread(tmp_path / "stress_ohs.stl_0001.png")[..., :3]
    assert img.reshape(-1, 3).std(axis=0).max() > 0.1  # a field, not a blank picture
    layer = matplotlib.image.imread(tmp_path / "layer_0002.png")[..., :3]
    green = (layer[..., 1] > layer[..., 0] + 0.1) & (layer[..., 1] > layer[..., 2] + 0.05)
    assert green.mean() > 0.05  # the replace region is drawn


def test_bad_input_is_one_line(tmp_path, capsys, sliced):
    assert main(["inspect", str(tmp_path / "missing.gcode")]) == 1
    err = capsys.readouterr().err
    assert err.startswith("loadpath: ") and "does not exist; check the path" in err and err.count("\n") == 1
    no_walls = sliced("prusa", "ohs", "mixed", perimeters=0)
    assert main(["inspect", str(no_walls)]) == 1
    err = capsys.readouterr().err
    assert "has infill but no perimeters" in err and err.count("\n") == 1
    assert main(["inspect", str(no_walls), "--replace", "walls"]) == 1
    assert "--replace walls: unknown kind" in capsys.readouterr().err


def test_blocks_the_geometry_cannot_vouch_for_are_noted_not_fatal(capsys, tmp_path):
    # the shipped PrusaSlicer 2.5 specimen with one stroke of layer 3's solid infill run 1 mm into
    # the perimeters (real files did this: small blocks in thin spots of OrcaSlicer 2.4.0-alpha,
    # 0.2-2.5 mm; the committed ones no longer do since the geometry splits shared islands)
    lines = (REPO / "examples" / "ohs.gcode").read_text().splitlines(keepends=True)
    first = next(i for i, ln in enumerate(lines) if ln.startswith("G1 X198.603 Y87.937 E"))
    assert lines[first - 3].startswith(";TYPE:Solid infill")
    stray = "G1 X198.603 Y86.937 E.05\n"
    lines.insert(first + 1, stray)
    src = tmp_path / "stray.gcode"
    src.write_text("".join(lines))
    assert main(["inspect", str(src)]) == 0
    out = capsys.readouterr().out
    notes = [ln for ln in out.splitlines() if ln.startswith("note:")]
    assert len(notes) == 1 and notes[0].startswith("note: layer 3,"), notes
    assert "mm outside the infill region found from the perimeters" in notes[0]
    assert "`loadpath run` keeps it as sliced" in notes[0]
    # and it does: the run succeeds and the stray stroke is still there, the other layers replaced
    dst = tmp_path / "out.gcode"
    case = REPO / "examples" / "ohs.toml"
    assert main(["run", str(src), "--loadcase", str(case), "-o", str(dst), "--engine", "streamlines"]) == 0
    text = dst.read_text()
    assert stray in text and "kept as sliced" in capsys.readouterr().err
    assert text != src.read_text()
