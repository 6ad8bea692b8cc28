"""The test data itself: real slicer output with the features the parser and the geometry need."""

from __future__ import annotations

import re

import pytest
import slicing


def _layer_types(path, layer_re):
    """{layer number: set of ;TYPE: values} straight from the text (independent of the parser)."""
    layers: dict[int, set[str]] = {}
    n = -1
    for line in path.read_text().splitlines():
        if re.match(layer_re, line):
            n += 1
            layers[n] = set()
        elif line.startswith(";TYPE:") and n >= 0:
            layers[n].add(line[6:])
    return layers


def test_parts_are_watertight_with_the_stated_size():
    ohs = slicing.ohs_mesh()
    assert ohs.is_watertight
    assert ohs.bounds.tolist() == [[0, 0, 0], [150, 36, 2]]
    # box minus a 64-sided cylinder of radius 3
    polygon_area = 0.5 * 64 * 3.0**2 * __import__("math").sin(2 * __import__("math").pi / 64)
    assert ohs.volume == pytest.approx((150 * 36 - polygon_area) * 2, rel=1e-9)
    assert len(slicing.two_islands_mesh().split(only_watertight=True)) == 2
    bracket = slicing.bracket_mesh()
    assert bracket.is_watertight and bracket.volume < 60 * 40 * 3 * 0.7  # concave: far below its box
    tower = slicing.tower_mesh()
    assert tower.bounds[1][2] == pytest.approx(24.0)


def test_flattened_presets_are_the_mk3s_ones():
    flat = slicing.flatten_prusa_presets()
    assert flat["printer"]["printer_model"] == "MK3S"
    assert flat["printer"]["use_relative_e_distances"] == "1"
    assert flat["print"]["layer_height"] == "0.2"
    assert flat["filament"]["filament_diameter"] == "1.75"
    assert "inherits" not in flat["print"]


def test_prusa_specimen_has_sparse_and_solid_layers(prusa_ohs):
    types = _layer_types(prusa_ohs, r";LAYER_CHANGE$")
    assert len(types) == 10
    assert "Solid infill" in types[0] and "Solid infill" in types[1]
    assert all("Internal infill" in types[i] for i in range(2, 8))
    assert "Top solid infill" in types[9]
    text = prusa_ohs.read_text()
    assert "M83" in text and "; printing object ohs.stl" in text
    assert "; fill_density = 20%" in text


def test_prusa_solid_variant_is_100_percent(prusa_ohs_solid):
    assert "; fill_density = 100%" in prusa_ohs_solid.read_text()


def test_cura_specimen_has_fill_and_skin_layers(cura_ohs):
    types = _layer_types(cura_ohs, r";LAYER:\d+$")
    assert len(types) == 10
    fill = [i for i, t in types.items() if "FILL" in t]
    skin = [i for i, t in types.items() if "SKIN" in t]
    assert fill == [2, 3, 4, 5, 6, 7] and skin == [0, 1, 8, 9]
    text = cura_ohs.read_text()
    assert "M82" in text and re.search(r"^;MESH:\S*ohs\.stl$", text, re.M)


@pytest.mark.parametrize("slicer", ["prusa", "cura"])
def test_two_objects_are_labelled(sliced, slicer):
    text = sliced(slicer, "two_objects").read_text()
    if slicer == "prusa":
        names = set(re.findall(r"^; printing object (\S+)", text, re.M))
    else:
        names = set(re.findall(r"^;MESH:(\S+)", text, re.M)) - {"NONMESH"}
    assert {n.rsplit("/", 1)[-1] for n in names} == {"two_islands.stl", "bracket.stl"}


def test_tower_has_at_least_100_layers(prusa_tower):
    assert len(_layer_types(prusa_tower, r";LAYER_CHANGE$")) >= 100


def test_slicer_errors_are_loud(tmp_path, test_stls):
    from conftest import require_tool

    require_tool("prusa-slicer")
    with pytest.raises(slicing.SlicerError, match="fill pattern|100%|error"):
        # honeycomb cannot print 100 %: PrusaSlicer refuses (real-tools.md §3.1)
        slicing.slice_prusa(
            test_stls("ohs"), tmp_path / "bad.gcode", fill_density="100%", fill_pattern="honeycomb"
        )
    require_tool("CuraEngine")
    with pytest.raises(slicing.SlicerError, match="definition"):
        slicing.slice_cura(test_stls("ohs"), tmp_path / "bad_cura.gcode", definition="no_such_printer")
