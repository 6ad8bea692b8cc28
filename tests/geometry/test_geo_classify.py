"""What each infill block is, on real files: sparse / solid by density, top / bottom by exposure."""

from __future__ import annotations

import math

import geometry_fixtures
import pytest
import shapely
from loadpath import gcode, geometry
from loadpath.gcode import Role
from loadpath.geometry.classify import classify
from shapely import box

sliced_step = geometry_fixtures.sliced_step  # the stepped part, sliced for real


def kinds(path, obj=0):
    geo = geometry.layer_geometry(gcode.read(path))
    return [g.kinds for g in geo.objects[obj].layers], geo


def test_prusa_specimen_mixed(prusa_ohs):
    # PrusaSlicer: Solid infill (bottoms, by name too), Internal infill 20 %, Bridge infill, Top solid infill
    ks, geo = kinds(prusa_ohs)
    assert ks == [("bottom",), ("solid",)] + [("sparse",)] * 6 + [("bridge",), ("top",)]
    blocks = [g.blocks[0] for g in geo.objects[0].layers]
    assert [b.feature for b in blocks[:3]] == ["Solid infill", "Solid infill", "Internal infill"]
    # the second layer is Solid infill too, but it lies on the first: internal solid, replaced by default
    assert blocks[1].exposed_down == 0.0 and blocks[1].exposed_up == 0.0
    assert blocks[0].exposed_down == 1.0 and blocks[-1].exposed_up == 1.0


def test_cura_specimen_mixed(cura_ohs):
    # Cura writes every skin as SKIN: the first and last layers are exposed, the ones next to them are not
    ks, geo = kinds(cura_ohs)
    assert ks == [("bottom",), ("solid",)] + [("sparse",)] * 6 + [("solid",), ("top",)]
    assert {b.feature for g in geo.objects[0].layers for b in g.blocks} == {"SKIN", "FILL"}


def test_hundred_percent_infill_is_solid_by_density(cura_ohs_solid, repo_root):
    # Cura writes 100 % infill as FILL; PrusaSlicer as Internal infill (the shipped example)
    ks, geo = kinds(cura_ohs_solid)
    assert ks == [("bottom",)] + [("solid",)] * 8 + [("top",)]
    fill = geo.objects[0].layers[4].blocks[0]
    assert fill.feature == "FILL" and fill.role == Role.SPARSE_INFILL
    assert fill.density == pytest.approx(1.0, abs=0.05)
    ks, geo = kinds(repo_root / "examples" / "ohs.gcode")  # examples/README.md: the table of layers
    assert ks == [("bottom",)] + [("solid",)] * 8 + [("top",)]
    assert geo.objects[0].layers[4].blocks[0].feature == "Internal infill"


def test_sparse_density_and_pitch(prusa_ohs, cura_ohs):
    # PrusaSlicer rectilinear 20 %: lines at flow spacing / density = 0.40708 / 0.2 = 2.035 mm
    b = geometry.layer_geometry(gcode.read(prusa_ohs)).objects[0].layers[4].blocks[0]
    assert b.kind == "sparse"
    assert b.pitch == pytest.approx(0.40708 / 0.2, rel=0.005)
    assert b.density == pytest.approx(0.2, abs=0.025)
    assert b.angle % 90 == pytest.approx(45, abs=0.5)
    # CuraEngine lines, infill_line_distance = 4.0 mm (tests/slicing.py CURA_MIXED)
    b = geometry.layer_geometry(gcode.read(cura_ohs)).objects[0].layers[4].blocks[0]
    assert b.pitch == pytest.approx(4.0, rel=0.005)
    assert b.density == pytest.approx(0.4 / 4.0, abs=0.01)


@pytest.mark.parametrize("slicer,setting", [("prusa", {"fill_pattern": "gyroid"}),
                                            ("prusa", {"fill_pattern": "honeycomb"}),
                                            ("prusa", {"fill_pattern": "grid"}),
                                            ("cura", {"infill_pattern": "gyroid"})])
def test_other_sparse_patterns(slicer, setting, sliced):
    """Curved and cellular patterns have no single line spacing: their pitch is area / length."""
    geo = geometry.layer_geometry(gcode.read(sliced(slicer, "ohs", "mixed", **setting)))
    density = 0.2 if slicer == "prusa" else 0.1
    for g in geo.objects[0].layers[2:8]:
        (b,) = g.blocks
        assert b.kind == "sparse"
        assert b.density == pytest.approx(density, rel=0.5)
        if setting.get("fill_pattern") == "grid":  # two families of lines, each at twice the spacing
            assert b.pitch == pytest.approx(2 * b.flow_width / density, rel=0.02)
        else:
            assert math.isnan(b.angle)
            assert b.pitch == pytest.approx(b.flow_width / b.density, rel=0.01)


def test_solid_pitch_is_the_flow_width(prusa_ohs_solid, cura_ohs_solid):
    for path in (prusa_ohs_solid, cura_ohs_solid):
        for g in geometry.layer_geometry(gcode.read(path)).objects[0].layers[1:-1]:
            (b,) = g.blocks
            assert b.pitch == pytest.approx(b.flow_width, rel=0.02), (path.name, g.layer_index)


@pytest.mark.parametrize("slicer", ["prusa", "cura"])
def test_step_half_exposed_layer(slicer, sliced_step):
    """Layer 10 carries the plate's top face: half of it is exposed, half lies under the boss."""
    ks, geo = kinds(sliced_step(slicer, "solid"))
    layers = geo.objects[0].layers
    assert len(layers) == 20
    ten = layers[9]
    assert "top" in ten.kinds and "solid" in ten.kinds
    top = [b for b in ten.blocks if b.kind == "top"]
    solid = [b for b in ten.blocks if b.kind == "solid"]
    # the exposed half (x > 20 in part coordinates) is in the top skin (PrusaSlicer grows its top surfaces
    # a few mm under the boss, so the skin is larger), and what is replaced lies under the boss
    x0 = ten.outline.bounds[0]
    assert all(b.region.centroid.x > x0 + 20 for b in top)
    assert all(b.region.centroid.x < x0 + 20 for b in solid)
    exposed = ten.domain.difference(layers[10].outline)
    assert exposed.area == pytest.approx(ten.domain.area / 2, rel=0.1)
    assert exposed.difference(shapely.union_all([b.region for b in top])).area < 0.01 * exposed.area
    replace = ten.replace_region(["solid"])
    assert replace.area > 0.3 * ten.domain.area
    assert replace.difference(layers[10].outline).area < 0.01 * replace.area
    # the boss's layers are internal solid, its last one the top
    assert ks[10:19] == [("solid",)] * 9 and ks[19] == ("top",)


def test_cura_skin_mixed_with_fill(sliced_step):
    """Cura, mixed step: the SKIN under the exposed half (layer 9) is internal, that of layer 10 is top."""
    ks, geo = kinds(sliced_step("cura", "mixed"))
    nine, ten = geo.objects[0].layers[8:10]
    assert nine.kinds == ("solid", "sparse") and ten.kinds == ("sparse", "top")
    skin9 = next(b for b in nine.blocks if b.feature == "SKIN")
    skin10 = next(b for b in ten.blocks if b.feature == "SKIN")
    assert skin9.exposed_up < 0.05 and skin10.exposed_up > 0.9
    # the solid replace region of layer 9 is the skin's own region, a straight-edged half
    region = nine.replace_region(["solid"])
    assert region.area == pytest.approx(skin9.region.area, rel=0.01)
    assert region.area == pytest.approx(region.minimum_rotated_rectangle.area, rel=0.02)


def test_classify_rules():
    assert classify(Role.SOLID_INFILL, 1.0, True, 0.0, 0.0) == "bottom"  # the first layer, whatever it is
    assert classify(Role.SPARSE_INFILL, 0.2, True, 0.0, 0.0) == "bottom"
    assert classify(Role.SPARSE_INFILL, 1.0, False, 0.0, 0.0) == "solid"
    assert classify(Role.SKIN, 0.99, False, 0.0, 0.5) == "top"
    assert classify(Role.SKIN, 0.99, False, 0.5, 0.0) == "bottom"
    assert classify(Role.SKIN, 0.99, False, 0.05, 0.05) == "solid"
    assert classify(Role.SOLID_INFILL, float("nan"), False, 0.0, 0.0) == "solid"
    assert classify(Role.SPARSE_INFILL, float("nan"), False, 0.0, 0.0) == "sparse"
    assert classify(Role.SPARSE_INFILL, 0.3, False, 1.0, 1.0) == "sparse"  # sparse is never a skin
    assert classify(Role.TOP_SOLID_INFILL, 1.0, False, 0.0, 0.0) == "top"
    assert classify(Role.BRIDGE_INFILL, 1.0, False, 1.0, 0.0) == "bridge"
    assert classify(Role.GAP_FILL, 1.0, False, 0.0, 0.0) == "gap_fill"
    assert classify(Role.IRONING, 1.0, False, 0.0, 0.0) == "ironing"
    assert set(geometry.REPLACEABLE) == {"solid", "sparse", "top", "bottom"}


def test_exposure_ignores_strips_thinner_than_a_bead():
    region = box(0, 0, 10, 10)
    assert geometry.exposed_fraction(region, box(0.1, 0.1, 9.9, 9.9), 0.45) == 0.0  # a tapered wall
    assert geometry.exposed_fraction(region, box(0, 0, 5, 10), 0.45) == pytest.approx(0.5)
    assert geometry.exposed_fraction(region, None, 0.45) == 1.0
